//! Magnetorquer rank loss (issue 42; docs/fdir.md "Magnetorquer rank loss"): the ground masks
//! a failed rod (`[actuators.magnetorquers] masked_rods`) and the flight code detumbles and
//! unloads on the two others. On the 3U mission of the FDIR campaigns
//! (`campaigns/base-3u-mag-fault.toml`, every monitor on, its own fault taken out; flown
//! whole, 7000 s: tumble at 10°/s, B-dot, sun-safe, the slew, the hold) with the x rod
//! reversed from the start: unmasked, B-dot drives the tumble up and control is lost
//! (`control_lost`, the rate above the 3°/s detumble entry rate at the end); masked, the
//! mission reaches its hold as the fault-free one does, and the rod's dipole command
//! (`dipole_cmd_x_am2`) is zero at every recorded step.
//! A rod list naming no rod, or one twice, is refused at load naming the key.

use sim_core::link::in_process::InProcess;
use sim_core::runner::{RunResult, run};
use sim_core::scenario::Scenario;
use std::path::Path;

fn mission(extra_rods: &str, fault: bool) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../campaigns/base-3u-mag-fault.toml");
    let text = std::fs::read_to_string(path).unwrap();
    let text = text.replacen("[actuators.magnetorquers]\n", &format!("[actuators.magnetorquers]\n{extra_rods}"), 1);
    let its_fault = "[[faults]]\nonset_s = 6000.0\nunit = \"magnetometer.x\"\nkind = \"stuck\"\n";
    assert!(text.contains(its_fault), "the base's own fault moved");
    let fault = if fault { "[[faults]]\nonset_s = 0.0\nunit = \"magnetorquer.0\"\nkind = \"reversed\"\n" } else { "" };
    text.replacen(its_fault, fault, 1)
}

fn fly(text: &str) -> RunResult {
    run(&Scenario::from_toml(text).unwrap(), &mut InProcess::new(), false).unwrap()
}

fn status(r: &RunResult) -> String {
    serde_json::to_value(&r.summary).unwrap()["run_status"].as_str().unwrap().to_string()
}

#[test]
fn a_masked_reversed_rod_leaves_the_mission_to_the_two_others() {
    let healthy = fly(&mission("", false));
    let unmasked = fly(&mission("", true));
    let masked = fly(&mission("masked_rods = [0]\n", true));
    let masked_healthy = fly(&mission("masked_rods = [0]\n", false));
    let (h, u, m, mh) = (status(&healthy), status(&unmasked), status(&masked), status(&masked_healthy));
    println!(
        "3U mission, rod x reversed from 0 s: unmasked {u} (final {:.2}°), masked {m} (final {:.4}°); \
         healthy {h} ({:.4}°), healthy with x masked {mh} ({:.4}°)",
        unmasked.summary.final_error_deg,
        masked.summary.final_error_deg,
        healthy.summary.final_error_deg,
        masked_healthy.summary.final_error_deg
    );
    assert_eq!(h, "ok");
    assert_eq!(u, "control_lost", "the reversed rod, used, loses the detumble");
    assert_eq!(m, "ok", "masked, the two other rods detumble and unload");
    // Masked, the plant's x rod does nothing whether it is reversed or healthy: the two
    // runs are the same run, bit for bit.
    assert_eq!(masked.summary.final_error_deg.to_bits(), masked_healthy.summary.final_error_deg.to_bits());
    // The commanded x dipole is zero at every recorded step; y's is used.
    let col = |r: &RunResult, n: &str| r.series.col(n).unwrap_or_else(|| panic!("column {n}")).to_vec();
    assert!(col(&masked, "dipole_cmd_x_am2").iter().all(|d| *d == 0.0), "x commanded");
    assert!(col(&masked, "dipole_cmd_y_am2").iter().any(|d| d.abs() > 1e-3), "y never used");
    assert!(col(&unmasked, "dipole_cmd_x_am2").iter().any(|d| d.abs() > 1e-3), "the test can fail");
    assert!(masked.summary.final_error_deg < 0.5, "{}", masked.summary.final_error_deg);
}

#[test]
fn a_rod_list_naming_no_rod_or_one_twice_is_refused_naming_the_key() {
    for bad in ["masked_rods = [3]\n", "masked_rods = [1, 1]\n"] {
        let err = format!("{:#}", Scenario::from_toml(&mission(bad, false)).unwrap_err());
        assert!(err.contains("actuators.magnetorquers.masked_rods"), "{bad}: {err}");
    }
}
