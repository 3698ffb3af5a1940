#!/usr/bin/env bash
# Installs what the build and the tests need on a Debian/Ubuntu machine: the Cortex-M4F
# Rust target and the lint tools, QEMU 10.x (processor-in-the-loop), the LLVM binutils
# (tools/elf-check), a C compiler (the QEMU cycle plugin), python3 with venv (the Python
# package's tests), a single-node Slurm with munge (the campaign tests), node >= 20 with npm
# (the 3D viewer's bundle: tools/viewer's locked packages, built into target/viewer/) and
# Debian's Chromium (the viewer's browser tests).
#
# Every run asks apt for the exact package set, whether or not the commands are already on
# the PATH: a no-op when the set is installed, a failure when it cannot be installed. So a
# machine that already has QEMU fails the same way a fresh machine would (issue 36).
# Failures are final: the script stops with apt's error and the package set it asked for.
#
# QEMU: the supported versions are 10.x only (tested: 10.0.2). On Debian 12 (bookworm)
# that is bookworm-backports' qemu-system-arm (bookworm's own 7.2 cannot be installed
# beside the qemu-utils 10.0.2 such machines come with): the suite is added from Debian's
# own archive when it is missing, and only the QEMU packages are pinned to it
# (/etc/apt/preferences.d/acs-qemu-backports), so nothing else is upgraded from backports.
set -euo pipefail

QEMU_MIN_MAJOR=10
NODE_MIN_MAJOR=20
PREFS=/etc/apt/preferences.d/acs-qemu-backports
BACKPORTS_LIST=/etc/apt/sources.list.d/acs-bookworm-backports.sources

die() {
  echo "setup: FAILED: $*" >&2
  exit 1
}

# --- Rust: the flight target and the lint tools CI runs (scripts/test.sh) --------------------
command -v rustup >/dev/null 2>&1 \
  || die "rustup not found: install the Rust toolchain with rustup (https://rustup.rs), then re-run"
rustup target add thumbv7em-none-eabihf >/dev/null 2>&1 \
  || die "rustup target add thumbv7em-none-eabihf"
rustup component add clippy rustfmt >/dev/null 2>&1 || die "rustup component add clippy rustfmt"

# --- Debian packages ----------------------------------------------------------------------
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null 2>&1 || die "not root and no sudo: apt-get cannot install the packages"
  SUDO="sudo"
fi
command -v apt-get >/dev/null 2>&1 \
  || die "no apt-get: install by hand qemu-system-arm (>= $QEMU_MIN_MAJOR.0), llvm, gcc, python3-venv, slurmctld, slurmd, slurm-client, munge, nodejs (>= 20) with npm, chromium"

codename=""
[ -r /etc/os-release ] && codename=$(. /etc/os-release && echo "${VERSION_CODENAME:-}")

# On bookworm, QEMU 10 comes from bookworm-backports, pinned for the QEMU packages only.
if [ "$codename" = bookworm ]; then
  if ! grep -rqs --include='*.list' --include='*.sources' 'bookworm-backports' /etc/apt/sources.list /etc/apt/sources.list.d; then
    echo "setup: adding Debian's bookworm-backports suite ($BACKPORTS_LIST)" >&2
    $SUDO tee "$BACKPORTS_LIST" >/dev/null <<'EOF'
Types: deb
URIs: http://deb.debian.org/debian
Suites: bookworm-backports
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg
EOF
  fi
  $SUDO tee "$PREFS" >/dev/null <<'EOF'
# scripts/setup.sh (acs): QEMU 10.x from bookworm-backports, nothing else from there.
Package: qemu-system-arm qemu-system-common qemu-system-data qemu-utils qemu-block-extra
Pin: release n=bookworm-backports
Pin-Priority: 500
EOF
fi

# apt_install PKG...: the exact set, every run; apt's own output on failure, then stop.
apt_install() {
  local log
  log=$(mktemp)
  # Package scripts must not start the daemons they install (Slurm, munge): the tests start
  # their own under a temporary directory. policy-rc.d answers 101 ("not allowed").
  local policy=/usr/sbin/policy-rc.d made_policy=""
  if [ ! -e "$policy" ]; then
    printf '#!/bin/sh\nexit 101\n' | $SUDO tee "$policy" >/dev/null && $SUDO chmod +x "$policy" && made_policy=1
  fi
  if ! DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q --no-install-recommends "$@" >"$log" 2>&1; then
    [ -n "$made_policy" ] && $SUDO rm -f "$policy"
    cat "$log" >&2
    rm -f "$log"
    die "apt-get install $* (the apt error is above)"
  fi
  [ -n "$made_policy" ] && $SUDO rm -f "$policy"
  rm -f "$log"
}

$SUDO apt-get update -qq || die "apt-get update"
apt_install qemu-system-arm
apt_install llvm gcc libc6-dev
apt_install python3 python3-venv
apt_install slurmctld slurmd slurm-client munge
# The 3D replay: node builds the viewer bundle; the browser tests drive Debian's Chromium.
apt_install nodejs chromium
# Debian's nodejs ships npm apart (NodeSource's includes it).
command -v npm >/dev/null 2>&1 || apt_install npm

# --- Checks: what the tests will call is there, at a supported version ---------------------
command -v qemu-system-arm >/dev/null 2>&1 || die "qemu-system-arm is not on the PATH after its install"
qemu_version=$(qemu-system-arm --version | head -1)
qemu_major=$(sed -nE 's/.*version ([0-9]+)\..*/\1/p' <<<"$qemu_version")
[ -n "$qemu_major" ] && [ "$qemu_major" -ge "$QEMU_MIN_MAJOR" ] \
  || die "$qemu_version: the supported QEMU is $QEMU_MIN_MAJOR.x (the cycle plugin declares plugin API 2, which QEMU 7.2 refuses)"
echo "$qemu_version"
for tool in llvm-objdump llvm-nm llvm-addr2line cc python3; do
  command -v "$tool" >/dev/null 2>&1 || die "$tool is not on the PATH after its install"
done
python3 -c "import ensurepip, venv" >/dev/null 2>&1 || die "python3's venv/ensurepip is missing after installing python3-venv"
for bin in sbatch slurmctld slurmd munged; do
  command -v "$bin" >/dev/null 2>&1 || [ -x "/usr/sbin/$bin" ] || die "$bin is missing after installing Slurm and munge"
done
# (sbatch --version needs a slurm.conf; the daemons print the version without one)
slurmctld -V

# The viewer: node >= NODE_MIN_MAJOR (playwright-core's floor), its npm packages exactly as
# locked (no install scripts: esbuild's binary comes as an optional package), the bundle in
# target/viewer/ where `sim-host view` finds it (docs/viewer.md).
node_major=$(node --version 2>/dev/null | sed -nE 's/^v([0-9]+)\..*/\1/p')
[ -n "$node_major" ] && [ "$node_major" -ge "$NODE_MIN_MAJOR" ] \
  || die "node $(node --version 2>/dev/null || echo missing): the viewer needs node >= $NODE_MIN_MAJOR (apt's nodejs from a NodeSource repository, or nvm)"
[ -x /usr/bin/chromium ] || die "/usr/bin/chromium is missing after installing chromium"
viewer="$(dirname "${BASH_SOURCE[0]}")/../tools/viewer"
npm --prefix "$viewer" ci --ignore-scripts --no-audit --no-fund --loglevel=error >/dev/null \
  || die "npm ci in tools/viewer (the npm registry must be reachable)"
npm --prefix "$viewer" run --silent build || die "the viewer bundle did not build (tools/viewer/build.mjs)"

# The QEMU cycle plugin (tools/qemu-cycles: only libc, no QEMU or glib headers needed).
"$(dirname "${BASH_SOURCE[0]}")/../tools/qemu-cycles/build.sh" >/dev/null \
  || die "the QEMU cycle plugin did not build (tools/qemu-cycles/build.sh)"
