#!/bin/bash
# The outputs in the real QGIS desktop under Xvfb (Aletsch): screenshot + JSON in test-artifacts/. Look at the PNG.
set -e
cd "$(dirname "$0")/../.."
SITE=$("${MONOPLOT_VENV:-.venv}/bin/python" -c "import sysconfig; print(sysconfig.get_paths()['purelib'])")
export PYTHONPATH="$SITE${PYTHONPATH:+:$PYTHONPATH}" MONOPLOT_REPO="$PWD"
export HOME="${MONOPLOT_DESKTOP_HOME:-$(mktemp -d)}"  # isolated QGIS profile
timeout 240 xvfb-run -a -s "-screen 0 1600x1000x24" qgis --nologo --noversioncheck --code tests/outputs/desktop_outputs.py
grep -q '"errors": \[\]' test-artifacts/outputs_desktop.json
