//! Measured stack high-water mark of the firmware under QEMU against the static bound of
//! tools/elf-check: the firmware paints its stack at boot and reports the deepest
//! overwritten word in `HelloAck::stack_hwm_bytes` (firmware/src/stack.rs). A scenario
//! that uploads parameters (the deepest static chain goes through `Configured::build`) and
//! steps the controller must leave a high-water mark that is (a) deeper than the one
//! right after boot, and (b) within the static bound. Where qemu-system-arm is not
//! installed: fails under CI, skips loudly otherwise (`acs_tests::require_tool`).

use acs_tests::{build_qemu_firmware, qemu_available, scenario};
use elf_check::{Analysis, Board};
use sim_core::link::FlightLink;
use sim_core::link::qemu::{QemuLink, default_firmware};
use sim_core::runner;

#[test]
fn measured_stack_high_water_mark_is_within_the_static_bound() {
    if !qemu_available("stack high-water mark") {
        return;
    }
    build_qemu_firmware();

    let board = Board::named("qemu").unwrap();
    let analysis = Analysis::of_elf(&board, &default_firmware()).unwrap();
    assert!(analysis.errors.is_empty(), "elf-check: {:?}", analysis.errors);
    let bound = analysis.bound;

    let mut link = QemuLink::start(None).unwrap();
    let at_boot = link.hello().unwrap().stack_hwm_bytes;
    let mut sc = scenario("paper000/test3.toml");
    sc.duration_s = 5.0;
    runner::run(&sc, &mut link, false).unwrap();
    let after = link.hello().unwrap().stack_hwm_bytes;
    eprintln!(
        "stack: measured high-water mark {at_boot} B after boot, {after} B after the scenario; static bound {bound} B \
         (measured = {:.0} % of the bound)",
        f64::from(after) * 100.0 / f64::from(bound)
    );
    assert!(at_boot > 0, "the firmware did not paint its stack");
    assert!(after > at_boot, "parameter upload and steps must reach deeper than boot ({after} vs {at_boot} B)");
    assert!(after <= bound, "measured {after} B exceeds the static bound {bound} B: the analysis is unsound");
}
