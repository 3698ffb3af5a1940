#!/usr/bin/env bash
# Installs what the build and the tests need on a fresh Debian/Ubuntu machine:
# the Cortex-M4F Rust target, QEMU (for processor-in-the-loop) and a single-node Slurm
# with munge (for the campaign tests) and the LLVM binutils (for tools/elf-check). Idempotent.
set -euo pipefail

if command -v rustup >/dev/null 2>&1; then
  if ! rustup target list --installed | grep -qx thumbv7em-none-eabihf; then
    rustup target add thumbv7em-none-eabihf
  fi
else
  echo "setup: rustup not found; install the thumbv7em-none-eabihf target for your toolchain by hand" >&2
fi

SUDO=""
[ "$(id -u)" -ne 0 ] && command -v sudo >/dev/null 2>&1 && SUDO="sudo"
APT_UPDATED=""
# apt_install PKG...: installs with apt-get, running `apt-get update` at most once per run.
apt_install() {
  if ! command -v apt-get >/dev/null 2>&1; then
    return 1
  fi
  if [ -z "$APT_UPDATED" ]; then
    $SUDO apt-get update -qq
    APT_UPDATED=1
  fi
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "$@" >/dev/null
}

if ! command -v qemu-system-arm >/dev/null 2>&1; then
  apt_install qemu-system-arm || echo "setup: no apt-get; install qemu-system-arm (>= 7.2) yourself" >&2
fi
qemu-system-arm --version | head -1

# LLVM binutils (llvm-objdump, llvm-nm, llvm-addr2line) for tools/elf-check.
if ! command -v llvm-objdump >/dev/null 2>&1 || ! command -v llvm-addr2line >/dev/null 2>&1; then
  apt_install llvm || echo "setup: no apt-get; install LLVM's binutils (llvm-objdump, llvm-nm, llvm-addr2line) yourself" >&2
fi

# C compiler for the QEMU cycle plugin (tools/qemu-cycles; only libc, no QEMU or glib
# headers needed). Without it the cycle tests fail under CI and skip loudly otherwise.
if ! command -v cc >/dev/null 2>&1; then
  apt_install gcc libc6-dev || echo "setup: no apt-get; install a C compiler for tools/qemu-cycles yourself" >&2
fi
if command -v cc >/dev/null 2>&1; then
  "$(dirname "${BASH_SOURCE[0]}")/../tools/qemu-cycles/build.sh" >/dev/null || echo "setup: the QEMU cycle plugin did not build (tools/qemu-cycles/build.sh)" >&2
fi

# Python 3 with venv and pip for the Python package's tests (scripts/python-tests.sh): the
# wheels it installs come from PyPI. Debian/Ubuntu ship `venv`'s ensurepip apart
# (python3-venv).
if ! command -v python3 >/dev/null 2>&1 || ! python3 -c "import ensurepip, venv" >/dev/null 2>&1; then
  apt_install python3 python3-venv || echo "setup: no apt-get; install python3 with its venv module yourself" >&2
fi

# Single-node Slurm + munge for the local-cluster tests (sim-host/tests/support/slurm.rs). The Debian
# packages enable system services; the tests never use those, they start their own daemons
# under a temporary directory.
missing=""
for bin in sbatch slurmctld slurmd munged; do
  command -v "$bin" >/dev/null 2>&1 || [ -x "/usr/sbin/$bin" ] || missing="$missing $bin"
done
if [ -n "$missing" ]; then
  apt_install slurmctld slurmd slurm-client munge \
    || echo "setup: no apt-get; install slurmctld slurmd slurm-client munge yourself (missing:$missing); the Slurm tests skip (fail under CI) without them" >&2
fi
# (sbatch --version needs a slurm.conf; the daemons print the version without one)
if command -v slurmctld >/dev/null 2>&1; then slurmctld -V; fi
