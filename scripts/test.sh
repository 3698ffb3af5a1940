#!/usr/bin/env bash
# The project's test command (CI runs exactly this): installs what is missing, builds
# the firmware for every board, then runs every test, including processor-in-the-loop
# against the firmware under QEMU. Release mode throughout: the closed-loop simulations
# are long and one profile avoids building the world twice.
set -euo pipefail
cd "$(dirname "$0")/.."

scripts/setup.sh
scripts/firmware.sh build          # QEMU mps2-an386 image used by the PIL tests
scripts/firmware.sh build-stm32    # the flight board image must keep building
cargo build --release -p acs-flight --no-default-features --target thumbv7em-none-eabihf
# Static checks of both images (tools/elf-check, docs/elf-check.md): no panic reachable from
# the tasks and interrupt handlers, stack bound within half of the stack region.
cargo run --release --quiet -p elf-check -- qemu firmware/target/thumbv7em-none-eabihf/release/acs-firmware >/dev/null
cargo run --release --quiet -p elf-check -- stm32 firmware/target/stm32f405/thumbv7em-none-eabihf/release/acs-firmware >/dev/null
cargo test --release --workspace
