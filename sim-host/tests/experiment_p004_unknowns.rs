//! Experiment `p004-unknowns` (paper 004 tables 5 and 6): the unknown thrust, Isp, PWPF
//! rate, minimum on-time and gain units. Every assertion checks a finding against an
//! independent truth: a closed form recomputed here, a second accounting of the same
//! run, a trend the physics demands, or the published tables.

use sim_core::plant::thrusters::G0_M_S2;
use sim_host::report::experiment::{self, Context, Explains, fly_recorded};
use sim_host::report::experiments::p004_unknowns as x;

/// Paper 004 table 2, per newton (r = d = 0.73 m), columns = thrusters 1..8.
fn table2_columns() -> Vec<[f64; 3]> {
    let (r, d, k) = (0.73, 0.73, std::f64::consts::FRAC_1_SQRT_2);
    let rows =
        [[r, 0.0, r, -0.43, -r, 0.0, -r, 0.43], [d, -0.43, -d, 0.0, -d, 0.43, d, 0.0], [d, -d, d, -d, d, -d, d, -d]];
    (0..8).map(|j| [k * rows[0][j], k * rows[1][j], k * rows[2][j]]).collect()
}

/// max |B u| over the valve patterns of the thrusters not in `failed` (1-based).
fn max_torque_per_newton(failed: &[usize]) -> f64 {
    let cols: Vec<[f64; 3]> =
        table2_columns().into_iter().enumerate().filter(|(i, _)| !failed.contains(&(i + 1))).map(|(_, c)| c).collect();
    (0u32..1 << cols.len())
        .map(|m| {
            let mut t = [0.0; 3];
            for (j, c) in cols.iter().enumerate() {
                if m >> j & 1 == 1 {
                    (0..3).for_each(|a| t[a] += c[a]);
                }
            }
            (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt()
        })
        .fold(0.0, f64::max)
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

#[test]
fn p004_unknowns() {
    let dir = tempfile::tempdir().unwrap();
    let ctx = Context { repo: experiment::repo_root(), fig_dir: dir.path().to_path_buf(), jobs: 2 };
    let e = x::run(&ctx).unwrap();
    let f = |k: &str| e.finding(k).unwrap();
    assert_eq!(e.id, "p004-unknowns");
    for b in &e.blocks {
        if let experiment::Block::Figure { file, .. } = b {
            assert!(dir.path().join(file).is_file(), "figure {file} not written");
        }
    }

    // 1. Isp only scales propellant: m = I_tot / (Isp g0), nothing fed back to the flight.
    let (m110, m220, m330) = (f("propellant_kg_dp_isp110"), f("propellant_kg_dp_isp220"), f("propellant_kg_dp_isp330"));
    assert!(m220 > 0.0);
    // total impulse m Isp g0 independent of Isp, to rounding
    let (i110, i220, i330) = (m110 * 110.0 * G0_M_S2, m220 * 220.0 * G0_M_S2, m330 * 330.0 * G0_M_S2);
    assert!(rel(i110, i220) < 1e-9 && rel(i330, i220) < 1e-9, "impulse {i110} {i220} {i330} N s");
    // the trajectory and the valve activity do not depend on Isp (bit-identical)
    for k in ["pulses_dp", "mean_error_deg_dp"] {
        assert_eq!(f(&format!("{k}_isp110")), f(&format!("{k}_isp220")), "{k}");
        assert_eq!(f(&format!("{k}_isp330")), f(&format!("{k}_isp220")), "{k}");
    }

    // 2. Second accounting of the baseline propellant: the recorded valve states
    //    (bitmask per control step) × thrust × dt / (Isp g0).
    let mut sc = ctx.scenario("paper004/dp-nominal.toml").unwrap();
    sc.timing.output_every = 1;
    let thr = sc.actuators.thrusters.clone().unwrap();
    let dt = 1.0 / sc.timing.control_rate_hz;
    let r = fly_recorded(&sc).unwrap();
    let on = r.series.col("thrusters_on").unwrap();
    let valve_s: f64 = on[..on.len() - 1].iter().map(|m| f64::from((*m as u32).count_ones()) * dt).sum();
    let from_valves = thr.thrust_n * valve_s / (thr.isp_s * G0_M_S2);
    assert!(
        rel(from_valves, f("propellant_kg_dp_baseline")) < 1e-9,
        "{from_valves} vs {}",
        f("propellant_kg_dp_baseline")
    );
    assert!(rel(f("propellant_kg_dp_baseline"), m220) < 1e-12, "baseline variant = shipped scenario");

    // 3. Whole-run mean floor (closed form recomputed here): |ω| <= α t, θ >= θ0 - α t²/2,
    //    mean >= (2/3) θ0 t1 / T with t1 = sqrt(2 θ0 / α), α = F max|Bu| / I_min.
    let theta0 =
        nalgebra::UnitQuaternion::from_euler_angles(15f64.to_radians(), 15f64.to_radians(), 15f64.to_radians())
            .angle()
            .to_degrees();
    assert!((theta0 - f("initial_error_deg")).abs() < 1e-6, "initial error {theta0} vs {}", f("initial_error_deg"));
    let (big_t, i_min) = (60.0, 9.0);
    let floor = |thrust: f64, failed: &[usize]| {
        let alpha = thrust * max_torque_per_newton(failed) / i_min;
        let t1 = (2.0 * theta0.to_radians() / alpha).sqrt();
        (2.0 / 3.0 * theta0.to_radians() * t1 / big_t).to_degrees()
    };
    assert!(rel(floor(10.0, &[]), f("whole_run_mean_floor_deg_dp_10n")) < 1e-9);
    assert!(rel(floor(10.0, &[1, 4]), f("whole_run_mean_floor_deg_dp_fail_10n")) < 1e-9);
    // every flown run (all variants, all four cases) respects its floor
    assert!(f("whole_run_mean_over_floor_min") >= 1.0, "a run beat the physical floor");
    // inverse: thrust at which the floor equals the paper's figure
    let thrust_for = |mean_deg: f64, failed: &[usize]| {
        let t1 = 1.5 * big_t * mean_deg / theta0;
        2.0 * theta0.to_radians() / (t1 * t1) * i_min / max_torque_per_newton(failed)
    };
    for (key, paper, failed) in [
        ("dp", 0.0521, &[][..]),
        ("bodson", 0.0018, &[][..]),
        ("dp_fail", 0.0128, &[1, 4][..]),
        ("bodson_fail", 0.0022, &[1, 4][..]),
    ] {
        let want = thrust_for(paper, failed);
        let got = f(&format!("thrust_n_min_whole_run_mean_{key}"));
        assert!(rel(got, want) < 1e-9, "{key}: {got} vs {want}");
        assert!((floor(want, failed) - paper).abs() < 1e-9 * paper.max(1.0), "inverse of the floor");
    }
    // the Bodson figures as whole-run means would need thrusters of more than 10 kN on a
    // 150 kg spacecraft (attitude thrusters of that class are 1-25 N): not the paper's metric
    assert!(f("thrust_n_min_whole_run_mean_bodson") > 1.0e4 && f("thrust_n_min_whole_run_mean_bodson_fail") > 1.0e4);
    for key in ["dp", "bodson", "dp_fail", "bodson_fail"] {
        assert!(f(&format!("mean_error_deg_{key}_baseline")) >= f(&format!("whole_run_mean_floor_deg_{key}_10n")));
    }

    // 4. Trends the physics demands.
    // a) Saturated demand (gains per degree): valves open whenever the demand is on, so the
    //    on-time does not depend on F and propellant ∝ F (within 10 %), strictly increasing.
    let thrusts = [1.0, 3.0, 10.0, 30.0, 100.0, 300.0, 1000.0];
    let per_n: Vec<f64> = thrusts.iter().map(|t| f(&format!("propellant_kg_dp_deg_gains_thrust_{t}")) / t).collect();
    for w in per_n.windows(2) {
        assert!(rel(w[1], w[0]) < 0.10, "propellant / thrust {per_n:?}");
    }
    // b) Printed gains: the PWPF dead zone (Uon/Km = 0.1 of full thrust) is a torque ∝ F
    //    which the PD balances at an angle ∝ F/Kp, so the settled error grows with thrust;
    //    at 1000 N the initial demand is inside the dead zone: nothing fires at all.
    let err: Vec<f64> = thrusts[..6].iter().map(|t| f(&format!("settled_error_deg_dp_thrust_{t}"))).collect();
    for w in err.windows(2) {
        assert!(w[1] > w[0], "settled error vs thrust {err:?}");
    }
    assert_eq!(f("propellant_kg_dp_thrust_1000"), 0.0);
    assert!((f("settled_error_deg_dp_thrust_1000") - 15.0).abs() < 1e-6, "no firing: the attitude stays at 15°");
    // c) same dead zone against the gain: ×10 on Kp cuts the angle ~10× (allow 0.3)
    assert!(f("settled_error_deg_dp_gain_10.0") < 0.3 * f("settled_error_deg_dp_gain_1.00"));
    // d) chatter with saturated demand: more samples per second, more pulses
    let pulses: Vec<f64> =
        [10.0, 20.0, 50.0, 100.0, 200.0].iter().map(|r| f(&format!("pulses_dp_deg_gains_rate_{r}"))).collect();
    for w in pulses.windows(2) {
        assert!(w[1] > w[0], "pulses vs PWPF rate {pulses:?}");
    }

    // 5. Verdict against the published tables: the best fitted variant is reported with the
    //    Isp in the plausible range, and no grid point gives Bodson's tracking advantage
    //    (paper: Bodson/DP error 0.0018/0.0521 = 0.035 nominal, 0.0022/0.0128 = 0.17 failed).
    let isp = f("isp_s_best");
    assert!((x::ISP_RANGE_S.0..=x::ISP_RANGE_S.1).contains(&isp));
    assert!(f("bodson_over_dp_error_ratio_min_grid") > x::RATIO_FACTOR * 0.0018 / 0.0521);
    assert_eq!(f("grid_points_reproducing"), 0.0);
    assert_eq!(e.explains, Explains::No);
    assert!(e.conclusion.contains("remains unexplained"));
}
