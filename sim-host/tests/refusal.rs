//! The simulator refuses, before the first step and with exit code 1 (not an abort), a run
//! of absurd duration or one whose output would not fit on the disk; the error names the
//! scenario key to change.

use sim_core::recorder::output::{Format, RUN_FILES, estimated_csv_bytes, read_run};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// paper 000 test 3 (30 s at 100 Hz, every 5th step recorded) with `from` replaced by `to`.
fn scenario(dir: &Path, from: &str, to: &str) -> PathBuf {
    let text = std::fs::read_to_string(repo().join("scenarios/paper000/test3.toml")).unwrap();
    assert!(text.contains(from), "{from}");
    let p = dir.join("sc.toml");
    std::fs::write(&p, text.replace(from, to)).unwrap();
    p
}

fn run(sc: &Path, out: &Path, free: Option<&str>) -> Output {
    run_as(sc, out, free, "parquet")
}

fn run_as(sc: &Path, out: &Path, free: Option<&str>, format: &str) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_sim-host"));
    c.args(["run", sc.to_str().unwrap(), "--out", out.to_str().unwrap(), "--no-plots", "--quiet"]);
    c.args(["--link", "in-process", "--format", format]);
    match free {
        Some(f) => c.env("SIM_HOST_ASSUME_FREE_BYTES", f),
        None => c.env_remove("SIM_HOST_ASSUME_FREE_BYTES"),
    };
    c.output().unwrap()
}

#[test]
fn an_absurd_duration_is_refused_naming_the_key() {
    let tmp = tempfile::tempdir().unwrap();
    for d in ["1e12", "1e300", "inf"] {
        let sc = scenario(tmp.path(), "duration_s = 30.0", &format!("duration_s = {d}"));
        let out = tmp.path().join("out");
        let r = run(&sc, &out, None);
        let err = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(1), "{d}: {err}");
        assert!(err.contains("duration_s"), "{d}: {err}");
        for f in RUN_FILES {
            assert!(!out.join(f).exists(), "{d}: {f}");
        }
    }
}

#[test]
fn a_run_that_would_not_fit_on_the_disk_is_refused_and_the_estimate_covers_the_real_size() {
    let tmp = tempfile::tempdir().unwrap();
    // Every step recorded: 3001 rows.
    let sc = scenario(tmp.path(), "output_every = 5 ", "output_every = 1 ");
    let out = tmp.path().join("out");
    let r = run(&sc, &out, None);
    assert_eq!(r.status.code(), Some(0), "{}", String::from_utf8_lossy(&r.stderr));
    let pq = out.join("timeseries.parquet");
    let series = read_run(&pq).unwrap().series;
    let (rows, cols) = (series.len() as u64, series.names.len());
    assert_eq!(rows, 3001);
    assert!(!out.join("timeseries.csv").exists());
    // The estimate is an upper bound of the real size (the uncompressed worst case).
    let est = Format::Parquet.estimated_bytes(rows, cols);
    let real = std::fs::metadata(&pq).unwrap().len();
    assert!(est >= real, "estimate {est} B, real {real} B");

    // 1 MB free: refused before anything is written.
    let out2 = tmp.path().join("out2");
    let r = run(&sc, &out2, Some("1000000"));
    let err = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(1), "{err}");
    assert!(err.contains("timing.output_every") && err.contains("duration_s"), "{err}");
    assert!(!out2.join("timeseries.parquet").exists());
    // Plenty free: runs, same bytes.
    let out3 = tmp.path().join("out3");
    let r = run(&sc, &out3, Some("1000000000000"));
    assert_eq!(r.status.code(), Some(0), "{}", String::from_utf8_lossy(&r.stderr));
    assert_eq!(std::fs::read(out3.join("timeseries.parquet")).unwrap(), std::fs::read(&pq).unwrap());
}

/// `--format csv`: the CSV estimate bounds the real size, a run that would not fit is
/// refused, and the CSV holds the same values as the Parquet file of the same run.
#[test]
fn the_csv_format_is_refused_when_it_would_not_fit_and_holds_the_parquet_values() {
    let tmp = tempfile::tempdir().unwrap();
    let sc = scenario(tmp.path(), "output_every = 5 ", "output_every = 1 ");
    let out = tmp.path().join("out");
    let r = run_as(&sc, &out, None, "csv");
    assert_eq!(r.status.code(), Some(0), "{}", String::from_utf8_lossy(&r.stderr));
    let csv = std::fs::read_to_string(out.join("timeseries.csv")).unwrap();
    assert!(!out.join("timeseries.parquet").exists());
    let (rows, cols) = (csv.lines().count() as u64 - 1, csv.lines().next().unwrap().split(',').count());
    assert_eq!(rows, 3001);
    // The estimate is an upper bound of the real size, and not a wild one.
    let est = estimated_csv_bytes(rows, cols);
    let real = csv.len() as u64;
    assert!(est >= real && est <= 3 * real, "estimate {est} B, real {real} B");
    let out2 = tmp.path().join("out2");
    let r = run_as(&sc, &out2, Some("1000000"), "csv");
    assert_eq!(r.status.code(), Some(1), "{}", String::from_utf8_lossy(&r.stderr));
    assert!(!out2.join("timeseries.csv").exists());
    // The same run as Parquet: the same values, bit for bit.
    let out3 = tmp.path().join("out3");
    let r = run(&sc, &out3, None);
    assert_eq!(r.status.code(), Some(0), "{}", String::from_utf8_lossy(&r.stderr));
    let (a, b) = (read_run(&out).unwrap().series, read_run(&out3).unwrap().series);
    assert_eq!(sim_core::recorder::output::first_difference(&a, &b), None);
}

/// Bad sensor-model keys are refused before the first step with the key named (they used
/// to reach an `assert!` in the gyro's constructor).
#[test]
fn bad_sensor_model_keys_are_refused_naming_the_key() {
    let base = std::fs::read_to_string(repo().join("scenarios/paper000/test3.toml")).expect("scenario");
    for (table, key) in [
        ("[sensors.gyro]\nsaturation_rad_s = -1.0\n", "sensors.gyro.saturation_rad_s"),
        ("[sensors.gyro]\nquantisation_rad_s = nan\n", "sensors.gyro.quantisation_rad_s"),
        ("[sensors.star_tracker]\nsun_exclusion_deg = 200.0\n", "sensors.star_tracker.sun_exclusion_deg"),
        ("[sensors.star_tracker]\nboresight_body = [0.0, 0.0, 0.0]\n", "sensors.star_tracker.boresight_body"),
        ("[sensors.star_tracker]\nnoise_about_deg = -0.1\n", "sensors.star_tracker.noise_about_deg"),
        ("[sensors.star_tracker]\noutages_s = [[10.0, 5.0]]\n", "sensors.star_tracker.outages_s"),
        ("[sensors.gyro]\nbias_instability_rad_s = -1e-5\n", "sensors.gyro.bias_instability_rad_s"),
        ("[sensors.gyro]\nbias_instability_rad_s = 1e-5\n", "sensors.gyro.bias_correlation_s"),
        (
            "[sensors.gyro]\nbias_instability_rad_s = 1e-5\nbias_correlation_s = 0.0\n",
            "sensors.gyro.bias_correlation_s",
        ),
        ("[sensors.magnetometer]\nmisalignment_deg = [0.0, nan, 0.0]\n", "sensors.magnetometer.misalignment_deg"),
        ("[sensors.css]\nnormals_body = []\n", "sensors.css.normals_body"),
        ("[sensors.css]\nnormals_body = [[1.0, 0.0, 0.0], [0.0, 0.0, 0.0]]\n", "sensors.css.normals_body"),
        ("[sensors.css]\nnormals_body = [[1.0, 0.0, 0.0]]\nnoise = -0.1\n", "sensors.css.noise"),
        ("[sensors.css]\nnormals_body = [[1.0, 0.0, 0.0]]\nalbedo = 1.5\n", "sensors.css.albedo"),
        ("[sensors.css]\nnormals_body = [[1.0, 0.0, 0.0]]\nrate_hz = 0.0\n", "sensors.css.rate_hz"),
        ("[sensors.gnss]\nrate_hz = -1.0\n", "sensors.gnss.rate_hz"),
        ("[sensors.gnss]\nposition_noise_m = -5.0\n", "sensors.gnss.position_noise_m"),
        ("[sensors.gnss]\nvelocity_noise_m_s = inf\n", "sensors.gnss.velocity_noise_m_s"),
        ("[sensors.gnss]\noutages_s = [[10.0, 5.0]]\n", "sensors.gnss.outages_s"),
    ] {
        let text = format!("{base}\n{table}");
        let err = sim_core::scenario::Scenario::from_toml(&text)
            .and_then(|s| s.validate().map(|()| s))
            .err()
            .unwrap_or_else(|| panic!("{key} accepted"));
        assert!(format!("{err:#}").contains(key), "{key}: {err:#}");
    }
}
