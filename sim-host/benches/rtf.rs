//! `cargo bench -p sim-host --bench rtf`: in-process real-time factors of paper 000 test 3
//! (100 Hz control, 100 Hz RK4, output decimated to 20 Hz), the paper-001 1200 s
//! reaction-wheel slew (accurate wheel model, 10 Hz control, 200 Hz RK4) and 5-orbit
//! paper-003 cubesat runs (magnetorquer hold; free), and, when QEMU and the firmware are
//! available, the flight step's instruction count on the emulated Cortex-M4F.
//!
//! Not a test: it prints figures. Real-time factor = simulated time / wall time of the
//! closed loop (no file output).

use sim_host::link::in_process::InProcess;
use sim_host::link::qemu::{QemuLink, default_firmware};
use sim_host::runner;
use sim_host::scenario::Scenario;
use std::path::Path;

fn main() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/paper000/test3.toml");
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

    for (file, reps) in
        [("paper001/wheel-slew.toml", 3), ("paper003/orbit-mtq-hold.toml", 3), ("paper003/orbit-free.toml", 3)]
    {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios").join(file);
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
    println!(
        "qemu mps2-an386 (Cortex-M4F) {}: Fsw::step max {} instructions, mean {:.0}, over {} steps (±40: 25 MHz counter); PIL real-time factor {:.1}x",
        sc.name,
        r.max_step_instructions.unwrap_or(0),
        r.mean_step_instructions.unwrap_or(f64::NAN),
        r.steps + 1,
        r.real_time_factor
    );
}
