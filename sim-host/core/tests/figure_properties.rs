//! Every figure of one scenario per actuator family, checked on the figure plans the
//! renderer draws from (`recorder::plots::plan`), not on pixels: no y axis narrower than
//! its quantity's resolution floor, no panel of a model that is off, no (colour, dash)
//! pair twice in a panel, the legend outside the plot area, the scenario's name and time
//! window on every figure, titles that fit, `modes.png` only with a mode manager (named
//! levels, thresholds in the signal's unit). The figures are also rendered (PNG files).

use sim_core::link::{self, LinkKind, LinkOptions};
use sim_core::recorder::output::RunOutput;
use sim_core::recorder::parquet::RunMetadata;
use sim_core::recorder::plots::{self, FigurePlan};
use sim_core::scenario::Scenario;
use std::collections::HashSet;
use std::path::Path;

/// Flies `scenarios/<rel>` (at most `max_s` seconds), returns the plans of its figures
/// and the names of the PNG files written.
fn fly(rel: &str, max_s: f64) -> (Scenario, Vec<FigurePlan>, Vec<String>) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios").join(rel);
    let mut sc = Scenario::load(&path).unwrap();
    sc.duration_s = sc.duration_s.min(max_s);
    let dir = std::env::temp_dir().join(format!("figure-properties-{}-{}", std::process::id(), rel.replace('/', "-")));
    let metadata = RunMetadata { scenario: sc.name.clone(), ..RunMetadata::default() };
    let thresholds = sc.modes.as_ref().map(|m| m.plot_thresholds()).unwrap_or_default();
    let mut rec =
        RunOutput::new(&dir, true).metadata(metadata).mode_thresholds(thresholds).assume_free_bytes(Some(1 << 40));
    let mut l = link::open(&LinkKind::InProcess, &LinkOptions::default()).unwrap();
    let summary = sim_core::runner::run_recorded(&sc, l.as_mut(), false, &mut rec).unwrap();
    let plans = rec.figure_plans();
    let files = rec.finish(&summary).unwrap();
    let pngs = files
        .iter()
        .filter(|f| f.extension().is_some_and(|e| e == "png"))
        .map(|f| f.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    std::fs::remove_dir_all(&dir).ok();
    (sc, plans, pngs)
}

/// The properties every figure has.
fn check_common(sc: &Scenario, plans: &[FigurePlan], pngs: &[String]) {
    assert!(!plans.is_empty(), "{}: no figure", sc.name);
    let planned: Vec<&str> = plans.iter().map(|p| p.file_name.as_str()).collect();
    assert_eq!(planned, pngs, "{}: the plans are the figures drawn", sc.name);
    for p in plans {
        let f = format!("{} {}", sc.name, p.file_name);
        assert!(p.subtitle.starts_with(&sc.name), "{f}: subtitle {:?} does not name the scenario", p.subtitle);
        assert!(p.subtitle.contains(" · t = "), "{f}: subtitle {:?} has no time window", p.subtitle);
        assert!(plots::text_width(&p.title, p.title_size) <= p.width - 20, "{f}: title clipped");
        assert!(p.legend_area.x0 >= p.plot_area.x1, "{f}: legend on the plot area");
        assert!(p.legend_area.x1 <= p.width as i32);
        for panel in &p.panels {
            let g = format!("{f} panel {:?}", panel.title);
            let (lo, hi) = panel.y_range;
            assert!(lo.is_finite() && hi.is_finite() && hi > lo, "{g}: y range {lo} … {hi}");
            if panel.log_y {
                assert!(lo > 0.0 && hi / lo >= 10.0, "{g}: log axis under a decade ({lo} … {hi})");
            } else if panel.categories.is_empty() {
                assert!(hi - lo >= panel.floor, "{g}: y span {} below the floor {}", hi - lo, panel.floor);
            }
            assert!(plots::text_width(&panel.title, panel.title_size) <= p.plot_area.x1 as u32, "{g}: title clipped");
            for t in &panel.y_ticks {
                assert!(plots::text_width(t, 15) <= plots::Y_TICK_W, "{g}: tick label {t:?} wider than its column");
            }
            let legend_w = (p.legend_area.x1 - p.legend_area.x0 - 48) as u32;
            for l in &panel.lines {
                assert!(plots::text_width(&l.label, 11) <= legend_w, "{g}: legend label {:?} does not fit", l.label);
            }
            let styles: HashSet<_> = panel.lines.iter().map(|l| (l.colour, l.dash)).collect();
            assert_eq!(styles.len(), panel.lines.len(), "{g}: a (colour, dash) pair repeats");
            assert!(panel.y_label != "-", "{g}: dimensionless axis labelled \"-\"");
            // A panel of a model that is off is left out: a model panel in which every
            // line is identically zero would be one.
            let model_panel = matches!(p.file_name.as_str(), "environment.png" | "wheels.png");
            let all_zero = panel.lines.iter().all(|l| l.label.ends_with("≡ 0"));
            assert!(!(model_panel && all_zero), "{g}: every line ≡ 0 (a model that is off)");
        }
    }
    let has_modes = plans.iter().any(|p| p.file_name == "modes.png");
    assert_eq!(has_modes, sc.modes.is_some(), "{}: modes.png without a mode manager (or none with one)", sc.name);
}

fn panel_titles<'a>(plans: &'a [FigurePlan], file: &str) -> Vec<&'a str> {
    plans.iter().filter(|p| p.file_name == file).flat_map(|p| p.panels.iter().map(|x| x.title.as_str())).collect()
}

#[test]
fn cmg_figures() {
    let (sc, plans, pngs) = fly("paper000/test1.toml", 40.0);
    check_common(&sc, &plans, &pngs);
    let gimbals = plans.iter().find(|p| p.file_name == "gimbals.png").unwrap();
    let rates: Vec<&str> = gimbals.panels[1].lines.iter().map(|l| l.label.as_str()).collect();
    assert_eq!(rates, ["dδ1/dt", "dδ2/dt", "dδ3/dt", "dδ4/dt"], "gimbal-rate legend");
    let sing = plans.iter().find(|p| p.file_name == "singularity.png").unwrap();
    assert!(sing.panels.iter().all(|p| p.y_label == "(dimensionless)"));
}

#[test]
fn accurate_wheel_figures() {
    let (sc, plans, pngs) = fly("paper001/wheel-slew.toml", 300.0);
    check_common(&sc, &plans, &pngs);
    let wheels = panel_titles(&plans, "wheels.png");
    assert!(wheels.contains(&"motor current"), "{wheels:?}");
    assert!(wheels.iter().any(|t| t.starts_with("electrical power")), "{wheels:?}");
    assert!(!wheels.iter().any(|t| t.starts_with("mechanical power")), "{wheels:?}");
}

#[test]
fn ideal_wheel_and_estimation_figures() {
    let (sc, plans, pngs) = fly("estimation/tracker-outage-eclipse.toml", 600.0);
    check_common(&sc, &plans, &pngs);
    let wheels = panel_titles(&plans, "wheels.png");
    assert!(!wheels.contains(&"motor current"), "ideal wheels have no motor current panel: {wheels:?}");
    assert!(!wheels.iter().any(|t| t.starts_with("electrical power")), "{wheels:?}");
    assert!(wheels.iter().any(|t| t.starts_with("mechanical power")), "{wheels:?}");
    let env = panel_titles(&plans, "environment.png");
    assert!(!env.contains(&"solar radiation pressure") && !env.contains(&"rig pendulum and stops"), "{env:?}");
    assert!(plans.iter().any(|p| p.file_name == "estimation.png"));
}

#[test]
fn magnetorquer_figures() {
    let (sc, plans, pngs) = fly("paper003/bdot.toml", 600.0);
    check_common(&sc, &plans, &pngs);
    assert!(plans.iter().any(|p| p.file_name == "magnetorquers.png"));
}

#[test]
fn thruster_figures() {
    let (sc, plans, pngs) = fly("paper004/dp-nominal.toml", 100.0);
    check_common(&sc, &plans, &pngs);
    let thr = plans.iter().find(|p| p.file_name == "thrusters.png").unwrap();
    assert!(thr.panels[0].lines.len() > 7, "the panel that needs the second dash pattern");
}

#[test]
fn mode_manager_figures() {
    let (sc, plans, pngs) = fly("modes/cubesat-mission.toml", 10_000.0);
    check_common(&sc, &plans, &pngs);
    let modes = plans.iter().find(|p| p.file_name == "modes.png").unwrap();
    let names = ["detumble", "sun-safe", "stabilise", "manoeuvre", "hold"];
    assert_eq!(modes.panels[0].categories, names, "modes as named levels");
    // The mode line holds category indices only (steps between real values, nothing in
    // between), and the spans follow the run's transitions.
    let levels = &modes.panels[0].lines[0].y;
    assert!(levels.iter().all(|v| v.is_nan() || (v.fract() == 0.0 && (0.0..5.0).contains(v))));
    assert!(modes.modes.len() >= 5, "{:?}", modes.modes);
    assert_eq!(modes.modes[0].2, "detumble");
    // Thresholds in the unit of the signal they are compared with.
    let rate = modes.panels.iter().find(|p| p.title.starts_with("body rate")).unwrap();
    assert_eq!(rate.y_label, "deg/s");
    let m = sc.modes.as_ref().unwrap();
    assert!(rate.thresholds.iter().any(|t| Some(t.0) == m.detumble_enter_rate_deg_s));
    let error = modes.panels.iter().find(|p| p.title.starts_with("attitude error")).unwrap();
    assert!(error.thresholds.iter().any(|t| Some(t.0) == m.hold_exit_error_deg));
    // Every time plot carries the mode spans.
    assert!(plans.iter().all(|p| p.modes == modes.modes));
    // And the eclipses, shaded and named in the subtitle. A whole eclipse of this circular
    // 617 km orbit lasts at most the β = 0 cylindrical-shadow arc, T acos(√(h² + 2 R h) / r) / π
    // (closed form, with its period T = 2π √(r³/μ)); the one that starts and ends inside
    // the run must be no longer, and (β is small at this dawn-dusk-free epoch) not much shorter.
    let (re, h, mu) = (6_378_137.0f64, 617_000.0f64, 3.986_004_418e14f64);
    let r = re + h;
    let period = std::f64::consts::TAU * (r.powi(3) / mu).sqrt();
    let longest = period * ((h * h + 2.0 * re * h).sqrt() / r).acos() / std::f64::consts::PI;
    let ecl = &modes.eclipses;
    assert!(!ecl.is_empty() && plans.iter().all(|p| p.eclipses == *ecl), "{ecl:?}");
    assert!(plans.iter().all(|p| p.subtitle.contains("grey: eclipse")));
    // Tolerance: the spans' ends are those of the plot envelope's buckets (≤ 4096 points
    // over 10,000 s: two buckets ≈ 5 s) and of the 0.5 s control step.
    for (a, b) in ecl.iter().filter(|(a, b)| *a > 0.0 && *b < 10_000.0) {
        assert!(b - a <= longest + 5.0 && b - a > 0.8 * longest, "eclipse {a}..{b} s vs at most {longest:.0} s");
    }
}
