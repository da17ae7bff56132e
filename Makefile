# Monoplot developer commands. The README promises two: `make demo` and `make test`.
# Both start with `make setup`, which is idempotent: apt packages only when missing, the venv only when absent,
# pip only when a requirements file changed (stamp file inside .venv).
SHELL := /bin/bash
.DEFAULT_GOAL := help

VENV      := .venv
PY        := $(VENV)/bin/python
STAMP     := $(VENV)/.requirements.stamp
REQ_FILES := requirements.txt requirements-dev.txt constraints.txt
APT_PKGS  := qgis python3-qgis xvfb pyqt5-dev-tools
VERSION    = $(shell sed -n 's/^version=//p' metadata.txt)

export QT_QPA_PLATFORM ?= offscreen

.PHONY: help setup apt venv resources test test-installer test-qgis340 demo qgis package clean bench eval lint

help:
	@echo "make demo     set up everything, then run the demo job"
	@echo "make qgis     open QGIS with the plugin and the demo project"
	@echo "make test     set up everything, then run the whole test suite (ruff included: tests/test_lint.py)"
	@echo "make lint     ruff on the whole repository (configuration in pyproject.toml)"
	@echo "make test-installer  the Install button's pip for real: QGIS's Python + a throwaway user site"
	@echo "make test-qgis340    the whole suite on QGIS 3.40 (Debian 13 root file system in .cache/, needs root)"
	@echo "make package  build dist/monoplot-<version>.zip for plugins.qgis.org"
	@echo "make bench    core speed benchmarks (per-pixel XYZ, render, orthophoto, fit, suggestions, time-lapse), one JSON line each"
	@echo "make eval     camera fit measured on the real Aletsch case and a synthetic scene, one JSON line per case"

setup: apt venv resources

# Debian packages: QGIS and its Python bindings, Xvfb for the desktop smoke test, pyrcc5 for resources.qrc.
apt:
	@missing=""; for p in $(APT_PKGS); do dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -n "$$missing" ]; then \
	  echo "setup: apt-get install$$missing"; \
	  SUDO=; [ "$$(id -u)" = 0 ] || SUDO=sudo; \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq$$missing >/dev/null; \
	fi

venv: $(STAMP)

$(PY):
	@echo "setup: creating $(VENV) (system site packages: qgis, osgeo, numpy from Debian)"
	@/usr/bin/python3 -m venv --system-site-packages $(VENV)

$(STAMP): $(REQ_FILES) | $(PY)
	@echo "setup: pip install -r requirements-dev.txt"
	@set -o pipefail; $(PY) -m pip install -q --disable-pip-version-check -r requirements-dev.txt 2>&1 \
	  | { grep -v 'is neither a file nor a directory' || true; }
	@touch $(STAMP)

# Icons compiled from resources.qrc into resources_rc.py (gitignored, shipped in the zip); the plugin imports it.
resources: resources_rc.py

resources_rc.py: resources.qrc $(wildcard icons/*)
	@pyrcc5 resources.qrc | sed 's/^from PyQt5 import QtCore/from qgis.PyQt import QtCore/' > $@.tmp && mv $@.tmp $@

test: setup
	@mkdir -p test-artifacts
	$(PY) -m pytest -q --durations=15 tests

# ruff (pyflakes, pycodestyle, bugbear; pyproject.toml). make test runs it too, as tests/test_lint.py.
lint: setup
	$(PY) -m ruff check .

# The missing-dependencies installer for real: resolves and installs torch, OpenCV, SciPy, numba into a throwaway user
# site of QGIS's Python (/usr/bin/python3), then imports osgeo.gdal_array, qgis.core and the plugin from it.
test-installer: setup
	@mkdir -p test-artifacts
	MONOPLOT_INSTALLER_TEST=1 $(PY) -m pytest -q tests/test_deps_install.py

# The whole suite on Debian 13's QGIS 3.40 (Python 3.13, numpy 2) in a chroot; see scripts/test_qgis340.sh.
# The root file system is built once into .cache/debian13 (MONOPLOT_DEBIAN13_ROOT overrides); screenshots in
# test-artifacts-qgis340/. PYTEST_ARGS="tests/desktop" runs a part.
test-qgis340: resources
	bash scripts/test_qgis340.sh $(PYTEST_ARGS)

# The whole pipeline through qgis_process on a generated scene (demo/run_demo.py); outputs in demo-output/.
demo: setup
	$(PY) demo/run_demo.py

# Real QGIS desktop with the plugin from this checkout and a project of the demo's outputs (runs the demo first
# when demo-output/ is missing). Needs a display; under Xvfb: xvfb-run -a make qgis
qgis: setup
	$(PY) demo/qgis_desktop.py

# Core benchmarks on generated terrain: one JSON line per benchmark (median seconds, peak MB). bench_large_dem.py
# writes a 1.7 G-cell DEM (tiled VRTs, ~40 MB of files) to a temporary folder and deletes it after.
bench: setup
	$(PY) bench/run_bench.py
	$(PY) bench/bench_fit.py
	$(PY) bench/bench_auto.py
	$(PY) bench/bench_curation.py
	$(PY) bench/bench_timelapse.py
	$(PY) bench/bench_large_dem.py
	$(PY) bench/bench_dock.py

# Camera fit on the real Aletsch case (../shared/data/aletsch), smapshot's 100 real small GCP sets and the synthetic
# suite (232 generated scenes), cameras on the ground seeing near ground (40 scenes): one JSON line per case or stratum.
eval: setup
	$(PY) -m eval.aletsch
	$(PY) -m eval.smapshot
	$(PY) -m eval.synthetic_suite --careless 24
	$(PY) -m eval.eye_level --scenes 40
	$(PY) -m eval.lens
	$(PY) -m eval.auto
	$(PY) -m eval.user_trial

package: setup
	$(PY) scripts/package.py --output dist

clean:
	rm -rf dist build test-artifacts .pytest_cache resources_rc.py
