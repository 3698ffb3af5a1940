#!/usr/bin/env bash
# Static checks CI enforces (scripts/test.sh runs this first): `cargo fmt --check` on the
# workspace and the firmware, then `cargo clippy … -D warnings` on the host workspace (all
# targets), on `acs-flight` for thumbv7em-none-eabihf and on both firmware boards.
# Any warning fails the script.
set -euo pipefail
cd "$(dirname "$0")/.."
TRIPLE=thumbv7em-none-eabihf

step() { echo "lint: $*" >&2; }

step "cargo fmt --check (workspace, firmware)"
cargo fmt --all -- --check
(cd firmware && cargo fmt --all -- --check)

step "clippy: host workspace, all targets"
cargo clippy --release --workspace --all-targets --quiet -- -D warnings
step "clippy: acs-flight on $TRIPLE"
cargo clippy --release -p acs-flight --no-default-features --target "$TRIPLE" --quiet -- -D warnings
step "clippy: firmware, QEMU mps2-an386"
(cd firmware && cargo clippy --release --quiet -- -D warnings)
step "clippy: firmware, STM32F405"
(cd firmware && CARGO_TARGET_DIR=target/stm32f405 \
  cargo clippy --release --quiet --no-default-features --features board-stm32f405 -- -D warnings)
