#!/usr/bin/env bash
# Build, run and measure the flight-computer firmware (firmware/). See docs/firmware.md.
#
#   scripts/firmware.sh build                 release build for QEMU mps2-an386; prints the ELF path
#   scripts/firmware.sh build-stm32           release build for the STM32F405RG; prints the ELF path
#   scripts/firmware.sh run-stm32             build-stm32, then flash and run it with probe-rs
#                                             (probe-rs run --chip STM32F405RGTx; defmt via RTT)
#   scripts/firmware.sh run-qemu PORT [--realtime]
#                                             boot the QEMU ELF: host link (UART0) on
#                                             tcp://127.0.0.1:PORT (QEMU waits for the client),
#                                             defmt frames (semihosting) on stdout
#   scripts/firmware.sh qemu-cmd PORT [--realtime]
#                                             print the QEMU command line instead of running it
#   scripts/firmware.sh size                  flash / RAM use of the built ELFs
#   scripts/firmware.sh math-fingerprint      build firmware/examples/f32m_fingerprint.rs and
#                                             run it under QEMU: prints the fingerprint of
#                                             acs_flight::math::f32m on the Cortex-M4F
#   scripts/firmware.sh estimation-cost       build firmware/examples/estimation_cost and run it
#                                             under QEMU in lockstep (-icount shift=0): cost
#                                             of MEKF steps, TRIAD, QUEST (ticks × 40 =
#                                             instructions) and the fingerprint of their outputs
#
# ACS_FIRMWARE_ELF=path overrides the ELF that run-qemu boots.
# Builds use CARGO_BUILD_JOBS=1 unless it is set. The QEMU ELF lives in firmware/target/…,
# the STM32 one in firmware/target/stm32f405/… so neither build overwrites the other.
#
# Clocks: by default (lockstep) QEMU runs with -icount shift=0,align=off,sleep=off: guest
# time counts executed instructions only (1 ns each; idle time is skipped), so step costs
# are instruction counts and runs are reproducible. --realtime drops -icount: guest time
# follows the host clock, which the real-time mode (StartRealTime) needs.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
FW="$ROOT/firmware"
TRIPLE=thumbv7em-none-eabihf
QEMU_ELF="${ACS_FIRMWARE_ELF:-$FW/target/$TRIPLE/release/acs-firmware}"
STM32_TARGET_DIR="$FW/target/stm32f405"
STM32_ELF="$STM32_TARGET_DIR/$TRIPLE/release/acs-firmware"
export CARGO_BUILD_JOBS="${CARGO_BUILD_JOBS:-1}"

usage() {
    sed -n '2,30p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'
    exit 2
}

build_qemu() {
    (cd "$FW" && cargo build --release --quiet) >&2
}

build_stm32() {
    (cd "$FW" && CARGO_TARGET_DIR="$STM32_TARGET_DIR" \
        cargo build --release --quiet --no-default-features --features board-stm32f405) >&2
}

qemu_cmd() {
    local port="$1"
    local clock=(-icount shift=0,align=off,sleep=off)
    # Real-time mode paces steps by the guest clock, which must follow the host clock:
    # no instruction counting (the cost counter then measures emulated wall time).
    # The semihosting argument `realtime` tells the firmware (QEMU offers no other way):
    # only then does it keep the CMSDK watchdog for real-time mode (docs/firmware.md).
    local semi=enable=on,target=native,chardev=semi
    [[ "${2:-}" == "--realtime" ]] && clock=() && semi="$semi,arg=acs-firmware,arg=realtime"
    # -nographic: no display; -monitor none: stdio is not taken by the monitor.
    # UART0 (serial0) → TCP server, QEMU waits for the host to connect (wait=on).
    # Semihosting console → chardev on stdio → defmt frames on stdout.
    # -icount shift=0: 1 instruction = 1 ns of virtual time (25 MHz counter = 40 insns/tick).
    QEMU_ARGS=(qemu-system-arm
        -machine mps2-an386 -cpu cortex-m4
        -nographic -monitor none
        -serial "tcp:127.0.0.1:${port},server=on,wait=on,nodelay=on"
        "${clock[@]}"
        -chardev stdio,id=semi
        -semihosting-config "$semi"
        -kernel "$QEMU_ELF")
}

# flash = everything loaded from the image (vector table, code, rodata, .data init);
# RAM = .data + .bss + .uninit (static), the stack takes the rest of RAM.
size_of() {
    local elf="$1" name="$2" tool
    if [[ ! -f "$elf" ]]; then
        echo "$name: not built ($elf)"
        return
    fi
    tool="$(command -v llvm-size || command -v rust-size || command -v arm-none-eabi-size || true)"
    if [[ -z "$tool" ]]; then
        echo "size: need llvm-size, rust-size or arm-none-eabi-size" >&2
        exit 1
    fi
    "$tool" -A "$elf" | awk -v name="$name" -v elf="$elf" '
        $1 == ".vector_table" || $1 == ".text" || $1 == ".rodata" { flash += $2 }
        $1 == ".data" { flash += $2; ram += $2 }
        $1 == ".bss" || $1 == ".uninit" { ram += $2 }
        END {
            printf "%s: flash %d B (%.1f KiB), static RAM %d B (%.1f KiB)  [%s]\n",
                name, flash, flash / 1024, ram, ram / 1024, elf
        }'
}

cmd="${1:-}"
case "$cmd" in
    build)
        build_qemu
        echo "$QEMU_ELF"
        ;;
    build-stm32)
        build_stm32
        echo "$STM32_ELF"
        ;;
    run-stm32)
        build_stm32
        command -v probe-rs >/dev/null || { echo "probe-rs not found (cargo install probe-rs-tools)" >&2; exit 1; }
        exec probe-rs run --chip STM32F405RGTx "$STM32_ELF"
        ;;
    run-qemu | qemu-cmd)
        [[ $# -ge 2 ]] || usage
        [[ "$2" =~ ^[0-9]+$ ]] || { echo "PORT must be a number" >&2; exit 2; }
        [[ -f "$QEMU_ELF" ]] || build_qemu
        qemu_cmd "$2" "${3:-}"
        if [[ "$cmd" == qemu-cmd ]]; then
            echo "${QEMU_ARGS[*]}"
        else
            exec "${QEMU_ARGS[@]}" </dev/null
        fi
        ;;
    math-fingerprint)
        (cd "$FW" && cargo build --release --quiet --example f32m_fingerprint) >&2
        # No -icount or serial: a plain run to SYS_EXIT; the timeout only guards a hang.
        timeout 120 qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -nographic -monitor none \
            -semihosting-config enable=on,target=native \
            -kernel "$FW/target/$TRIPLE/release/examples/f32m_fingerprint" </dev/null
        ;;
    estimation-cost)
        (cd "$FW" && cargo build --release --quiet --example estimation_cost) >&2
        # Lockstep clock: the FPGAIO counter then counts instructions (40 per tick).
        timeout 120 qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -nographic -monitor none \
            -icount shift=0,align=off,sleep=off -semihosting-config enable=on,target=native \
            -kernel "$FW/target/$TRIPLE/release/examples/estimation_cost" </dev/null
        ;;
    size)
        size_of "$QEMU_ELF" "qemu-mps2-an386"
        size_of "$STM32_ELF" "stm32f405"
        ;;
    *)
        usage
        ;;
esac
