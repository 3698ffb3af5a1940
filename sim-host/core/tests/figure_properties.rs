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
    check_steady_state(sc, plans);
    check_text_fits(sc, plans);
    let has_modes = plans.iter().any(|p| p.file_name == "modes.png");
    assert_eq!(has_modes, sc.modes.is_some(), "{}: modes.png without a mode manager (or none with one)", sc.name);
}

/// Every line of every linear panel of a time figure: its steady-state part (from the
/// plan's `steady_from`: the second half of the run) spans at least the visible fraction
/// of its axis (3 %: 7 px of a 230-px plot area), or its legend says it is constant there
/// ("≡", "≈"); a panel followed by its steady-state panel is read there instead.
fn check_steady_state(sc: &Scenario, plans: &[FigurePlan]) {
    let visible = plots::STEADY_ZOOM.visible_fraction;
    let mut bad = Vec::new();
    for p in plans {
        let Some(from) = p.steady_from else { continue };
        for (k, panel) in p.panels.iter().enumerate() {
            let zoomed = p.panels.get(k + 1).is_some_and(|n| n.steady_from.is_some());
            if panel.log_y || !panel.categories.is_empty() || zoomed {
                continue;
            }
            if let Some(z) = panel.steady_from {
                assert_eq!(z, from, "{} / {}: steady-state window", p.file_name, panel.title);
                assert_eq!(panel.x_range.0, from, "{} / {}: drawn from its window", p.file_name, panel.title);
            }
            let axis = panel.y_range.1 - panel.y_range.0;
            for l in &panel.lines {
                let tail = p.x.iter().zip(&l.y).filter(|(x, y)| **x >= from && y.is_finite()).map(|(_, y)| *y);
                let (lo, hi) = tail.fold((f64::INFINITY, f64::NEG_INFINITY), |a, v| (a.0.min(v), a.1.max(v)));
                let shown = hi - lo >= visible * axis;
                let annotated = l.label.contains('≡') || l.label.contains('≈') || l.label.contains("no data");
                if !(shown || annotated || lo > hi) {
                    let pct = 100.0 * (hi - lo) / axis;
                    bad.push(format!("{} / {} / {}: {pct:.3} % of the axis", p.file_name, panel.title, l.label));
                }
            }
        }
    }
    assert!(bad.is_empty(), "{}: steady state flat and not annotated:\n{}", sc.name, bad.join("\n"));
}

/// No title, subtitle or legend text leaves the canvas: every text line's width measured
/// with the embedded font at the size it is drawn, against the figure's width and its
/// legend column; the legend's last line inside its panel's cell.
fn check_text_fits(sc: &Scenario, plans: &[FigurePlan]) {
    let mut bad = Vec::new();
    for p in plans {
        if plots::text_width(&p.subtitle, p.subtitle_size) > p.width - 20 {
            bad.push(format!("{}: subtitle {:?}", p.file_name, p.subtitle));
        }
        let legend_w = p.legend_area.x1 - p.legend_area.x0;
        for (k, panel) in p.panels.iter().enumerate() {
            let entries: Vec<&str> = panel.legend.iter().flat_map(|e| e.lines.iter().map(|l| l.as_str())).collect();
            for l in panel.lines.iter().map(|l| &l.label).chain(p.x_lines.iter().map(|l| &l.1)) {
                let words = l.split(' ').filter(|w| !w.is_empty());
                assert!(
                    words.clone().all(|w| entries.iter().any(|e| e.contains(w))),
                    "{}: {l:?} not in the legend",
                    p.file_name
                );
            }
            for e in &panel.legend {
                for line in &e.lines {
                    if e.x + plots::text_width(line, e.size) as i32 > legend_w {
                        bad.push(format!("{} / {}: legend {line:?}", p.file_name, panel.title));
                    }
                }
                let bottom = e.y + (e.lines.len() as i32 - 1) * e.line_height() + e.size as i32 / 2;
                if bottom > p.cell_height(k) as i32 {
                    bad.push(format!("{} / {}: legend entry {:?} below the panel", p.file_name, panel.title, e.lines));
                }
            }
        }
    }
    assert!(bad.is_empty(), "{}: text beyond the canvas:\n{}", sc.name, bad.join("\n"));
}

fn panel_titles<'a>(plans: &'a [FigurePlan], file: &str) -> Vec<&'a str> {
    plans.iter().filter(|p| p.file_name == file).flat_map(|p| p.panels.iter().map(|x| x.title.as_str())).collect()
}

#[test]
fn cmg_figures() {
    let (sc, plans, pngs) = fly("paper000/test1.toml", 40.0);
    check_common(&sc, &plans, &pngs);
    let gimbals = plans.iter().find(|p| p.file_name == "gimbals.png").unwrap();
    let rate_panel = gimbals.panels.iter().find(|p| p.title == "commanded gimbal rates dδ/dt").unwrap();
    let rates: Vec<&str> = rate_panel.lines.iter().map(|l| l.label.as_str()).collect();
    assert_eq!(rates, ["dδ1/dt", "dδ2/dt", "dδ3/dt", "dδ4/dt"], "gimbal-rate legend");
    // In the unit of the scenario's limit (deg/s), and within it.
    assert_eq!(rate_panel.y_label, "deg/s");
    let peak = rate_panel.lines.iter().flat_map(|l| l.y.iter()).fold(0.0f64, |m, v| m.max(v.abs()));
    // The slew saturates the servo: the peak is the limit (f32 command: 1e-6 relative).
    let limit = sc.actuators.cmg.as_ref().unwrap().max_gimbal_rate_deg_s;
    assert!((peak - limit).abs() <= 1e-6 * limit, "peak gimbal rate drawn {peak} deg/s, limit {limit} deg/s");
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
fn hold_figures() {
    let (sc, plans, pngs) = fly("estimation/mekf-hold.toml", 3000.0);
    check_common(&sc, &plans, &pngs);
}

#[test]
fn pointing_figures() {
    let (sc, plans, pngs) = fly("guidance/eo-cubesat.toml", 6000.0);
    check_common(&sc, &plans, &pngs);
    // No detumble in this run: the torquer panel does not name B-dot.
    let momentum = panel_titles(&plans, "momentum.png");
    assert!(momentum.contains(&"torquer torque m × B (unloading)"), "{momentum:?}");
    // The blends of the pointing are shaded and named.
    let pointing = plans.iter().find(|p| p.file_name == "pointing.png").unwrap();
    assert!(!pointing.shaded.is_empty() && pointing.subtitle.contains("pointing blend"), "{:?}", pointing.shaded);
    // A blend lasts its pointing's transition_s (120 s for the passes, 180 s for Sun and
    // nadir); tolerance 2 s: the plot envelope's buckets (2 rows of 1 s) and the 0.25 s
    // step. A blend restarted before its end is one longer span (at most two transitions).
    let spans: Vec<f64> = pointing.shaded.iter().skip(1).map(|(a, b)| b - a).collect();
    assert!(spans.iter().all(|d| (118.0..=362.0).contains(d)), "{spans:?}");
    assert!(
        spans.iter().any(|d| (d - 120.0).abs() <= 2.0) && spans.iter().any(|d| (d - 180.0).abs() <= 2.0),
        "{spans:?}"
    );
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
    // The run detumbles (B-dot on the torquers): the torquer panel says so.
    let momentum = panel_titles(&plans, "momentum.png");
    assert!(momentum.iter().any(|t| t.contains("B-dot while detumbling")), "{momentum:?}");
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
