#!/bin/bash
# `make test-qgis340`: the whole test suite (desktop tests included) on Debian 13's QGIS 3.40, Python 3.13, numpy 2.
#
#   scripts/test_qgis340.sh [PYTEST ARGS...]      (default: -q tests)
#   scripts/test_qgis340.sh --run 'COMMAND'        (a shell command in the chroot instead, e.g. a desktop script)
#
# 1. scripts/debian13_root.sh builds (once) the Debian 13 root file system, default .cache/debian13
#    (MONOPLOT_DEBIAN13_ROOT overrides; gitignored);
# 2. pip inside it is set up as on this machine: its configuration files, CA bundle, the local package folders the
#    configuration names (bind-mounted read-only) and its cache;
# 3. a venv /opt/monoplot-venv inside the tree (--system-site-packages: QGIS, GDAL, numpy 2, torch from Debian)
#    gets requirements-debian13.txt (pins: constraints-debian13.txt), again only when those files change;
# 4. in a private mount namespace: /proc, /dev, /sys, /tmp, the repository and ../shared bind-mounted at their own
#    paths, test-artifacts-qgis340/ over test-artifacts/; then pytest inside the chroot.
# Needs root. Times of each phase are printed.
set -euo pipefail

REPO=$(cd "$(dirname "$0")/.." && pwd)
ROOT=$(realpath -m "${MONOPLOT_DEBIAN13_ROOT:-$REPO/.cache/debian13}")
SHARED=$(realpath -m "$REPO/../shared")
VENV=/opt/monoplot-venv
ARTIFACTS="$REPO/test-artifacts-qgis340"
start=$SECONDS

bash "$REPO/scripts/debian13_root.sh" "$ROOT"
echo "qgis340: root file system $((SECONDS - start)) s"

# --- pip as on the host ------------------------------------------------------------------------------------------
# Configuration files (global, XDG, user), the files and local folders their values name, PIP_* variables.
host_pip_files=()
for f in /etc/pip.conf /etc/xdg/pip/pip.conf "${XDG_CONFIG_HOME:-$HOME/.config}/pip/pip.conf" "$HOME/.pip/pip.conf" \
         ${PIP_CONFIG_FILE:-}; do
  [ -f "$f" ] && host_pip_files+=("$f")
done
pip_values=$( (/usr/bin/python3 -m pip config list 2>/dev/null || true; env | grep '^PIP_' || true) \
              | sed -e "s/^[^=]*=//" -e "s/^'//" -e "s/'$//")
local_dirs=()
for value in $pip_values; do
  path=${value#file://}
  case "$path" in /*) ;; *) continue ;; esac
  if [ -f "$path" ]; then
    host_pip_files+=("$path")
  elif [ -d "$path" ] && [ "$(basename "$path")" = simple ]; then  # a local index: its files lie beside simple/
    local_dirs+=("$(realpath "$(dirname "$path")")")
  elif [ -d "$path" ]; then
    local_dirs+=("$(realpath "$path")")
  fi
done
[ -f /etc/ssl/certs/ca-certificates.crt ] && host_pip_files+=(/etc/ssl/certs/ca-certificates.crt)
for f in "${host_pip_files[@]}"; do
  target="$ROOT$f"
  [ "$f" = "$HOME/.config/pip/pip.conf" ] && target="$ROOT/root/.config/pip/pip.conf"
  [ "$f" = "$HOME/.pip/pip.conf" ] && target="$ROOT/root/.pip/pip.conf"
  mkdir -p "$(dirname "$target")" && cp "$f" "$target"
done
PIP_CACHE=$(/usr/bin/python3 -m pip cache dir 2>/dev/null || echo "$HOME/.cache/pip")
mkdir -p "$PIP_CACHE"
cp /etc/resolv.conf "$ROOT/etc/resolv.conf"

# Variables passed into the chroot (env -i there): pip's, TLS bundles, CI, the display/Qt ones the tests set.
# The venv is NOT on PATH: QGIS's embedded Python would find its python3 there and take the venv for its own.
pass_env=(PATH=/usr/sbin:/usr/bin:/sbin:/bin HOME=/root LANG=C.UTF-8 QT_QPA_PLATFORM=offscreen
          MONOPLOT_VENV=$VENV MONOPLOT_INSTALLER_TEST=1)
while IFS= read -r line; do pass_env+=("$line"); done < <(env | grep -E '^(PIP_|CI=|SSL_CERT_|REQUESTS_CA_BUNDLE=|CURL_CA_BUNDLE=|MONOPLOT_TORCH_INDEX=)' || true)

mkdir -p "$ARTIFACTS" "$REPO/test-artifacts"
mounts="mount -t proc proc '$ROOT/proc'
mount --rbind /dev '$ROOT/dev'
mount --rbind /sys '$ROOT/sys'
mount --bind /tmp '$ROOT/tmp'
mkdir -p '$ROOT$REPO' '$ROOT$SHARED' '$ROOT/root/.cache/pip'
mount --bind '$REPO' '$ROOT$REPO'
mount --bind '$ARTIFACTS' '$ROOT$REPO/test-artifacts'
mount --bind '$PIP_CACHE' '$ROOT/root/.cache/pip'
if [ -d '$SHARED' ]; then mount --bind '$SHARED' '$ROOT$SHARED'; mount -o remount,bind,ro '$ROOT$SHARED'; fi"
for d in "${local_dirs[@]}"; do
  mounts+="
mkdir -p '$ROOT$d'; mount --bind '$d' '$ROOT$d'; mount -o remount,bind,ro '$ROOT$d'"
done

in_root() {  # in_root SCRIPT: bash -e SCRIPT inside the chroot (with the mounts), in the repository
  local script
  script=$(mktemp /tmp/monoplot-qgis340.XXXXXX)  # /tmp is shared with the chroot
  printf 'cd %q\n%s\n' "$REPO" "$1" >"$script"
  unshare --mount --propagation private bash -ec "$mounts
exec chroot '$ROOT' /usr/bin/env -i ${pass_env[*]@Q} bash -e '$script'" && rm -f "$script" || { rm -f "$script"; return 1; }
}

# --- the venv with the platform's pins ---------------------------------------------------------------------------
phase=$SECONDS
stamp=$(cat "$REPO/requirements-debian13.txt" "$REPO/constraints-debian13.txt" | sha256sum | cut -c1-16)
if [ "$(cat "$ROOT$VENV/.stamp" 2>/dev/null)" != "$stamp" ]; then
  echo "qgis340: venv $VENV (Python $(cat "$ROOT/.versions" | sed -n 's/^python3 //p')), pip install -r requirements-debian13.txt"
  in_root "rm -rf $VENV && /usr/bin/python3 -m venv --system-site-packages $VENV
    set -o pipefail; $VENV/bin/python -m pip install -q -r requirements-debian13.txt 2>&1 | { grep -v 'is neither a file nor a directory' || true; }
    echo $stamp > $VENV/.stamp"
fi
echo "qgis340: venv $((SECONDS - phase)) s"

# --- the suite ---------------------------------------------------------------------------------------------------
phase=$SECONDS
if [ "${1:-}" = --run ]; then  # scripts/test_qgis340.sh --run 'SHELL COMMAND': anything else inside the tree
  command=$2
else
  [ $# -gt 0 ] || set -- -q tests
  command="$(printf '%q ' "$VENV/bin/python" -m pytest "$@")"
fi
in_root "make resources >/dev/null && $command" && status=0 || status=$?
echo "qgis340: tests $((SECONDS - phase)) s (exit $status); total $((SECONDS - start)) s; screenshots in $ARTIFACTS"
exit $status
