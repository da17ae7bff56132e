#!/bin/bash
# Debian 13 (trixie) root file system with QGIS 3.40 for `make test-qgis340`.
#
#   scripts/debian13_root.sh ROOT
#
# Built with debootstrap from Debian's registry, then `apt-get install qgis python3-qgis xvfb ...` inside it.
# Cached: debootstrap runs once (ROOT/.monoplot-debootstrap-done; an interrupted one is removed and started again);
# apt-get runs again only when PACKAGES below change (ROOT/.monoplot-root-ready holds the list it installed).
# Needs root (debootstrap, chroot).
set -euo pipefail

ROOT=${1:?usage: $0 ROOT}
MIRROR=${DEBIAN_MIRROR:-http://deb.debian.org/debian}
SUITE=trixie
READY="$ROOT/.monoplot-root-ready"
# QGIS 3.40 and its Python bindings, Xvfb (+ xauth for xvfb-run) for the desktop tests, pyrcc5 for resources.qrc,
# venv/pip for the platform's pins, fonts so that screenshots show text. torch: Debian's CPU build, because
# PyPI's Linux torch is the CUDA one and PyTorch's CPU index (the plugin's default) may not be reachable.
PACKAGES="qgis python3-qgis xvfb xauth pyqt5-dev-tools python3-venv python3-pip make ca-certificates
  fonts-dejavu-core python3-torch"
PACKAGES=$(echo $PACKAGES)
DEBOOTSTRAPPED="$ROOT/.monoplot-debootstrap-done"

mkdir -p "$(dirname "$ROOT")"
exec 9>"$ROOT.lock"
flock 9  # two runs at once (e.g. two worktrees' make): the second waits for the first's tree

if [ -f "$READY" ] && [ "$(cat "$READY")" = "$PACKAGES" ]; then
  echo "debian13: reusing $ROOT"
  exit 0
fi
if [ "$(id -u)" != 0 ]; then
  echo "debian13: building a root file system needs root (debootstrap, chroot)" >&2
  exit 1
fi
command -v debootstrap >/dev/null || {
  echo "debian13: apt-get install debootstrap"
  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq debootstrap >/dev/null
}

umount_all() {
  for m in dev/pts dev proc; do mountpoint -q "$ROOT/$m" && umount -l "$ROOT/$m" || true; done
}
trap umount_all EXIT

start=$SECONDS
if [ ! -f "$DEBOOTSTRAPPED" ]; then
  if [ -e "$ROOT" ]; then
    echo "debian13: removing the unfinished $ROOT"
    umount_all
    rm -rf --one-file-system "$ROOT"
  fi
  mkdir -p "$(dirname "$ROOT")"
  echo "debian13: debootstrap $SUITE from $MIRROR"
  for attempt in 1 2; do  # a network hiccup on the mirror: once more from scratch
    debootstrap --variant=minbase --include=ca-certificates "$SUITE" "$ROOT" "$MIRROR" >"$ROOT.debootstrap.log" 2>&1 \
      && break
    tail -30 "$ROOT.debootstrap.log" >&2
    [ "$attempt" = 2 ] && exit 1
    echo "debian13: debootstrap failed, trying again" >&2
    umount_all
    rm -rf --one-file-system "$ROOT"
  done
  mv "$ROOT.debootstrap.log" "$ROOT/debootstrap.log"
  touch "$DEBOOTSTRAPPED"
  echo "debian13: debootstrap done in $((SECONDS - start)) s"
fi
echo "debian13: apt-get install $PACKAGES"

cat >"$ROOT/usr/sbin/policy-rc.d" <<'EOF'
#!/bin/sh
exit 101
EOF
chmod +x "$ROOT/usr/sbin/policy-rc.d"  # no daemons started inside the tree
cp /etc/resolv.conf "$ROOT/etc/resolv.conf"
mount -t proc proc "$ROOT/proc"
mount --bind /dev "$ROOT/dev"
mount --bind /dev/pts "$ROOT/dev/pts"
chroot "$ROOT" /usr/bin/env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin DEBIAN_FRONTEND=noninteractive bash -ec "
  apt-get -o Acquire::Retries=3 update -qq
  apt-get -o Acquire::Retries=3 install -y -qq --no-install-recommends $PACKAGES >/var/log/monoplot-apt.log 2>&1 || {
    tail -40 /var/log/monoplot-apt.log; exit 1; }
  apt-get clean
"
chroot "$ROOT" dpkg-query -W -f='${Package} ${Version}\n' qgis python3-qgis python3-numpy python3 >"$ROOT/.versions"
cat "$ROOT/.versions"
echo "$PACKAGES" >"$READY"
echo "debian13: root file system ready in $((SECONDS - start)) s"
