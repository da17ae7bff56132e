#!/bin/bash
# Scripted Aletsch session in the real QGIS desktop under Xvfb; screenshots + JSON in test-artifacts/.
# QGIS runs /usr/bin/python3: the venv's site-packages (torch, cv2, scipy, numba) are added to its path
# (MONOPLOT_VENV: another venv than .venv, e.g. make test-qgis340's).
set -e
cd "$(dirname "$0")/../.."
SITE=$("${MONOPLOT_VENV:-.venv}/bin/python" -c "import sysconfig; print(sysconfig.get_paths()['purelib'])")
export PYTHONPATH="$SITE${PYTHONPATH:+:$PYTHONPATH}" MONOPLOT_REPO="$PWD"
export HOME="${MONOPLOT_DESKTOP_HOME:-$(mktemp -d)}"  # isolated QGIS profile
timeout 240 xvfb-run -a -s "-screen 0 1600x1000x24" qgis --nologo --noversioncheck --code tests/gui/desktop_aletsch.py
grep -q '"errors": \[\]' test-artifacts/aletsch_session.json
