#!/usr/bin/env bash
# Installs what the build and the tests need on a fresh Debian/Ubuntu machine:
# the Cortex-M4F Rust target and QEMU (for processor-in-the-loop). Idempotent.
set -euo pipefail

if command -v rustup >/dev/null 2>&1; then
  if ! rustup target list --installed | grep -qx thumbv7em-none-eabihf; then
    rustup target add thumbv7em-none-eabihf
  fi
else
  echo "setup: rustup not found; install the thumbv7em-none-eabihf target for your toolchain by hand" >&2
fi

if ! command -v qemu-system-arm >/dev/null 2>&1; then
  SUDO=""
  [ "$(id -u)" -ne 0 ] && command -v sudo >/dev/null 2>&1 && SUDO="sudo"
  if command -v apt-get >/dev/null 2>&1; then
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq qemu-system-arm >/dev/null
  else
    echo "setup: no apt-get; install qemu-system-arm (>= 7.2) yourself" >&2
  fi
fi
qemu-system-arm --version | head -1
