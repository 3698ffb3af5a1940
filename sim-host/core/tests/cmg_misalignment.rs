//! CMG gimbal-axis misalignment (`actuators.cmg.gimbal_misalignment_deg`): plant only.
//! Truths: the key's documented bounds (finite, at most 10 deg per unit) refused naming the
//! key; the flight upload unchanged by it; the plant's units rotated by Rodrigues' formula;
//! and paper 000 test 3 (yaw slew to 50 deg) still reaching its target (final error
//! < 0.1 deg, the bound of the ideal-geometry test) with 0.5 deg misalignments.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use sim_core::attitude::Vec3;
use sim_core::link::in_process::InProcess;
use sim_core::runner;
use sim_core::scenario::Scenario;
use std::path::{Path, PathBuf};

const KEY: &str = "actuators.cmg.gimbal_misalignment_deg";

fn test3_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/paper000/test3.toml")
}

/// paper 000 test 3 with `line` added to `[actuators.cmg]`.
fn test3_with(line: &str) -> anyhow::Result<Scenario> {
    let text = std::fs::read_to_string(test3_path()).unwrap();
    let anchor = "max_gimbal_rate_deg_s = 60.0     # table 1\n";
    assert!(text.contains(anchor));
    Scenario::from_toml(&text.replace(anchor, &format!("{anchor}{line}\n")))
}

/// Independent Rodrigues rotation of `v` by the rotation vector `rv` (rad).
fn rodrigues(rv: Vec3, v: Vec3) -> Vec3 {
    let th = rv.norm();
    let k = rv / th;
    v * th.cos() + k.cross(&v) * th.sin() + k * (k.dot(&v) * (1.0 - th.cos()))
}

/// One rotation vector per unit, random direction, norm `angle_deg` (deg).
fn random_misalignment(angle_deg: f64, seed: u64) -> [[f64; 3]; 4] {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    std::array::from_fn(|_| {
        let v = Vec3::from_fn(|_, _| StandardNormal.sample(&mut rng));
        (v.normalize() * angle_deg).into()
    })
}

#[test]
fn too_large_or_non_finite_misalignments_are_refused_naming_the_key() {
    let ok = "gimbal_misalignment_deg = [[0, 0, 0], [0, 9.9, 0], [0, 0, 0], [0, 0, 0]]";
    assert!(test3_with(ok).is_ok());
    for bad in [
        // 20 deg about x on unit 3.
        "gimbal_misalignment_deg = [[0, 0, 0], [0, 0, 0], [20, 0, 0], [0, 0, 0]]",
        // Each component below 10 but the angle (norm) 10.39 deg.
        "gimbal_misalignment_deg = [[6, 6, 6], [0, 0, 0], [0, 0, 0], [0, 0, 0]]",
        "gimbal_misalignment_deg = [[0, 0, 0], [0, nan, 0], [0, 0, 0], [0, 0, 0]]",
        "gimbal_misalignment_deg = [[0, 0, 0], [0, 0, 0], [0, 0, 0], [inf, 0, 0]]",
    ] {
        let e = format!("{:#}", test3_with(bad).unwrap_err());
        assert!(e.contains(KEY), "{bad}: {e}");
    }
    // Set after loading (as a Monte Carlo does): refused when the plant is built, too.
    let mut sc = Scenario::load(&test3_path()).unwrap();
    sc.actuators.cmg.as_mut().unwrap().gimbal_misalignment_deg[0] = [0.0, 0.0, 20.0];
    assert!(format!("{:#}", sc.spacecraft().unwrap_err()).contains(KEY));
    assert!(format!("{:#}", sc.flight_params().unwrap_err()).contains(KEY));
}

#[test]
fn misalignment_rotates_the_plant_units_and_leaves_the_flight_upload_unchanged() {
    let nominal = Scenario::load(&test3_path()).unwrap();
    let mis = random_misalignment(3.0, 11);
    let text = format!("gimbal_misalignment_deg = {mis:?}");
    let rotated = test3_with(&text).unwrap();
    assert_eq!(rotated.actuators.cmg.as_ref().unwrap().gimbal_misalignment_deg, mis);
    // Flight upload: exactly the same parameters.
    assert_eq!(rotated.flight_params().unwrap(), nominal.flight_params().unwrap());
    // Plant: each unit's spin0 and trans0 rotated (Rodrigues, tol 1e-12).
    let (a, b) = (nominal.spacecraft().unwrap(), rotated.spacecraft().unwrap());
    let (ca, cb) = (a.cmg.as_ref().unwrap(), b.cmg.as_ref().unwrap());
    for (i, (ua, ub)) in ca.units.iter().zip(&cb.units).enumerate() {
        let rv = Vec3::from(mis[i]).map(f64::to_radians);
        assert!((ub.spin0 - rodrigues(rv, ua.spin0)).norm() < 1e-12, "unit {i}");
        assert!((ub.trans0 - rodrigues(rv, ua.trans0)).norm() < 1e-12, "unit {i}");
        // 3 deg is visible: the gimbal axis tilts by up to 3 deg.
        assert!((ub.spin0 - ua.spin0).norm() > 1e-3 || (ub.trans0 - ua.trans0).norm() > 1e-3);
    }
    // Zero misalignment: the same plant as without the key.
    let zero = test3_with("gimbal_misalignment_deg = [[0, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0, 0]]").unwrap();
    assert_eq!(zero.spacecraft().unwrap().cmg, a.cmg);
}

/// Paper 000 test 3 in-process with random misalignments of `angle_deg` on every unit.
fn run_test3(angle_deg: f64, seed: u64) -> sim_core::recorder::summary::Summary {
    let mut sc = Scenario::load(&test3_path()).unwrap();
    sc.actuators.cmg.as_mut().unwrap().gimbal_misalignment_deg = random_misalignment(angle_deg, seed);
    runner::run(&sc, &mut InProcess::new(), false).unwrap_or_else(|e| panic!("{e:#}")).summary
}

#[test]
fn test3_yaw_slew_still_settles_with_half_degree_misalignments() {
    let ideal = run_test3(0.0, 0);
    eprintln!("ideal: settle {:?} s, final error {:.2e} deg", ideal.settle_time_s, ideal.final_error_deg);
    for seed in 1..=3 {
        let s = run_test3(0.5, seed);
        eprintln!(
            "0.5 deg, seed {seed}: settle {:?} s (bound {} deg), final error {:.2e} deg",
            s.settle_time_s, s.settle_bound_deg, s.final_error_deg
        );
        assert!(s.final_error_deg < 0.1, "seed {seed}: final error {} deg", s.final_error_deg);
        assert!((s.final_euler_deg[2] - 50.0).abs() < 0.1);
        let t = s.settle_time_s.expect("settles");
        // A 0.5 deg geometry error is a small torque error: within 1 s of the ideal run.
        assert!((t - ideal.settle_time_s.unwrap()).abs() < 1.0, "seed {seed}: settle {t} s");
    }
}
