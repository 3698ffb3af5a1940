//! `cargo bench -p sim-core --bench rtf`: in-process real-time factors of paper 000 test 3
//! (100 Hz control, 100 Hz RK4, output decimated to 20 Hz), the paper-001 1200 s
//! reaction-wheel slew (accurate wheel model, 10 Hz control, 200 Hz RK4) and 5-orbit
//! paper-003 cubesat runs (magnetorquer hold; free), the 7200 s mode-manager mission, and, when QEMU and the firmware are
//! available, the flight step's instruction count on the emulated Cortex-M4F.
//!
//! Not a test: it prints figures. Real-time factor = simulated time / wall time of the
//! closed loop (no file output).

use acs_flight::link::{SensorFrame, valid};
use acs_test_support::rng::Lcg64;
use acs_test_support::vec3::cross;
use sim_core::link::FlightLink;
use sim_core::link::in_process::InProcess;
use sim_core::link::qemu::{QemuLink, default_firmware};
use sim_core::runner;
use sim_core::scenario::Scenario;
use std::path::Path;

/// Instructions per flight step on the emulated Cortex-M4F with paper 004's thrusters and
/// LP allocation, over a sweep of torque demands: attainable (small), saturated (large),
/// and degenerate (along a thruster column and along facet normals `b_i × b_j`). The
/// DCM-PD law makes the demand `Kd ∘ ω` at zero attitude error, so each demand is set
/// through the measured rate.
fn allocation_sweep() {
    for (file, label) in
        [("paper004/dp-nominal.toml", "direction-preserving"), ("paper004/bodson-nominal.toml", "Bodson")]
    {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios").join(file);
        let sc = Scenario::load(&path).expect("scenario");
        let b = sc.thruster_set().expect("thrusters").torque_matrix();
        let kd = [-42.0, -91.0, -91.0];
        let mut dirs: Vec<[f64; 3]> = Vec::new();
        let mut lcg = Lcg64(12345);
        let mut rnd = || lcg.symmetric();
        for _ in 0..100 {
            dirs.push([rnd(), rnd(), rnd()]);
        }
        for (i, bi) in b.iter().enumerate() {
            dirs.push(*bi);
            for bj in &b[i + 1..] {
                let n = cross(bi, bj);
                dirs.push(n);
                dirs.push(n.map(|x| -x));
            }
        }
        let mut link = QemuLink::start(None).expect("qemu");
        link.hello().expect("hello");
        link.upload(&sc.flight_params().expect("params")).expect("upload");
        let ipt = 40.0; // 25 MHz counter, 1 instruction per ns
        let (mut worst, mut sum, mut n) = (0u32, 0u64, 0u64);
        let mut seq = 0u32;
        for d in &dirs {
            let norm = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt().max(1e-12);
            for mag in [0.3, 3.0, 60.0] {
                let w: [f32; 3] = std::array::from_fn(|k| (d[k] / norm * mag / kd[k]) as f32);
                let f = SensorFrame {
                    rate_rad_s: w,
                    valid: valid::ATTITUDE | valid::RATE,
                    ..SensorFrame::empty(seq, seq as u64 * 10_000)
                };
                seq += 1;
                let r = link.step(&f).expect("step");
                worst = worst.max(r.step_cost_ticks);
                sum += r.step_cost_ticks as u64;
                n += 1;
            }
        }
        println!(
            "qemu Cortex-M4F, paper 004 {label} LP (12-thruster capacity, 8 used): worst {} instructions per flight step, mean {:.0}, over {n} demands (random, along columns, along ±facet normals; 0.3 / 3 / 60 N m)",
            (worst as f64 * ipt) as u64,
            sum as f64 / n as f64 * ipt
        );
    }
}

fn main() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/paper000/test3.toml");
    let sc = Scenario::load(&path).expect("scenario");
    let reps = 50;
    let mut rtf: Vec<f64> = (0..reps)
        .map(|_| runner::run(&sc, &mut InProcess::new(), false).expect("run").summary.real_time_factor)
        .collect();
    rtf.sort_by(|a, b| a.total_cmp(b));
    println!(
        "in-process {}: {} steps, real-time factor median {:.0}x (min {:.0}x, max {:.0}x) over {reps} runs, one core",
        sc.name,
        sc.steps(),
        rtf[reps / 2],
        rtf[0],
        rtf[reps - 1]
    );

    for (file, reps) in [
        ("paper001/wheel-slew.toml", 3),
        ("paper003/orbit-mtq-hold.toml", 3),
        ("paper003/orbit-free.toml", 3),
        ("modes/cubesat-mission.toml", 5),
    ] {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios").join(file);
        let sc = Scenario::load(&path).expect("scenario");
        let mut rtf: Vec<f64> = (0..reps)
            .map(|_| runner::run(&sc, &mut InProcess::new(), false).expect("run").summary.real_time_factor)
            .collect();
        rtf.sort_by(|a, b| a.total_cmp(b));
        println!(
            "in-process {}: {:.0} s simulated, {} Hz control x {} RK4 substeps, real-time factor median {:.0}x over {reps} runs",
            sc.name,
            sc.duration_s,
            sc.timing.control_rate_hz,
            sc.timing.dynamics_substeps,
            rtf[reps / 2]
        );
    }

    if std::process::Command::new("qemu-system-arm").arg("--version").output().is_err() || !default_firmware().exists()
    {
        println!("qemu: skipped (needs qemu-system-arm and `scripts/firmware.sh build`)");
        return;
    }
    let mut link = QemuLink::start(None).expect("qemu");
    let r = runner::run(&sc, &mut link, false).expect("qemu run").summary;
    drop(link);
    allocation_sweep();
    println!(
        "qemu mps2-an386 (Cortex-M4F) {}: Fsw::step max {} instructions, mean {:.0}, over {} steps (±40: 25 MHz counter); PIL real-time factor {:.1}x",
        sc.name,
        r.max_step_instructions.unwrap_or(0),
        r.mean_step_instructions.unwrap_or(f64::NAN),
        r.steps + 1,
        r.real_time_factor
    );
}
