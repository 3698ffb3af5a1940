#!/usr/bin/env bash
# The project's test command (CI runs exactly this): installs what is missing, builds
# the firmware for every board, then runs every test, including processor-in-the-loop
# against the firmware under QEMU. Release mode throughout: the closed-loop simulations
# are long and one profile avoids building the world twice.
#
# Tests that need a tool outside Cargo (QEMU, the QEMU cycle plugin, the firmware ELF,
# Slurm, python3 with venv for the Python package's tests) fail when it is missing under CI (`CI` set: .ci/run sets it) and otherwise skip
# loudly, each appending a line to target/skipped-tests.log
# (sim-host/tests/support/require_tool.rs); this script empties that log first and ends
# with one summary line when anything was skipped.
set -euo pipefail
cd "$(dirname "$0")/.."

SKIP_LOG=target/skipped-tests.log
mkdir -p target
: >"$SKIP_LOG"
skip_summary() {
  if [ -s "$SKIP_LOG" ]; then
    local n tools
    n=$(wc -l <"$SKIP_LOG")
    # lines read `[tool] test: why; …`: count the tests per tool
    tools=$(sed -E 's/^\[([^]]*)\].*/\1/' "$SKIP_LOG" | sort | uniq -c | awk '{c=$1; $1=""; printf "%s%s (%d)", sep, substr($0,2), c; sep=", "}')
    echo "SKIPPED: $n tests skipped because tools are missing: $tools (details: $SKIP_LOG; scripts/setup.sh installs them)" >&2
  fi
}
trap skip_summary EXIT

scripts/setup.sh
# The flight rules, enforced (docs/architecture.md, "Rules"): formatting, then clippy with
# every warning an error on the host workspace, on the flight crate for the Cortex-M4F and
# on both firmware boards.
scripts/lint.sh
scripts/firmware.sh build          # QEMU mps2-an386 image used by the PIL tests
scripts/firmware.sh build-stm32    # the flight board image must keep building
cargo build --release -p acs-flight --no-default-features --target thumbv7em-none-eabihf
# Static checks of both images (tools/elf-check, docs/elf-check.md): no panic reachable from
# the tasks and interrupt handlers, stack bound within half of the stack region.
cargo run --release --quiet -p elf-check -- qemu firmware/target/thumbv7em-none-eabihf/release/acs-firmware >/dev/null
cargo run --release --quiet -p elf-check -- stm32 firmware/target/stm32f405/thumbv7em-none-eabihf/release/acs-firmware >/dev/null
cargo test --release --workspace
# The Python package (sim-host/python): venv, pip install, pytest (docs/python.md).
scripts/python-tests.sh
