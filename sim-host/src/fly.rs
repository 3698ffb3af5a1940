//! Flying one scenario the way `sim-host run` does, written once for its three users: the
//! command line (`sim-host run`), campaign runs (`campaign::exec`) and the Python package
//! (`acs.run`). The link is chosen ([`link_kind`]), the run flown into the caller's
//! recorder ([`run`]), then the `[margins]` it asks for measured on the same link into its
//! summary ([`Ran::with_margins`]); [`Flown::verdict`] says how the run ends and with
//! which exit status. The two phases are apart because the Python package measures the
//! margins on a worker thread while it looks for Ctrl-C.

use crate::margins::{MarginOptions, MarginReport};
use anyhow::{Context, Result};
use sim_core::link::{self, LinkKind, LinkOptions};
use sim_core::recorder::series::Recorder;
use sim_core::recorder::summary::Failure;
use sim_core::runner::{self, Summary};
use sim_core::scenario::Scenario;

/// How one scenario is flown.
#[derive(Clone, Debug, Default)]
pub struct FlyOptions {
    /// The link asked for (`sim-host run --link`, `acs.run(link=…)`); `None`: the
    /// scenario's `link.kind`, else in-process. Open-loop scenarios fly in-process whatever
    /// is asked (no flight code to talk to).
    pub link: Option<LinkKind>,
    /// Firmware and cancellation token, for the run and its margins measurement alike.
    pub link_options: LinkOptions,
    /// Worker threads of the `[margins]` measurement (kept within
    /// `sim_core::scenario::THREADS` by `MarginOptions::with_request`).
    pub margin_threads: usize,
}

impl FlyOptions {
    /// The threads `sim-host run` and `acs.run` give a margins measurement: the machine's.
    pub fn machine_threads() -> usize {
        std::thread::available_parallelism().map_or(2, |n| n.get())
    }
}

/// How the run is watched while it flies.
pub enum Watch<'w> {
    /// Nothing shown.
    Quiet,
    /// The console progress bar (`sim-host run` without `--quiet`).
    Bar,
    /// Called after every control step with (steps done, steps in the run); an `Err`
    /// stops the run with that error (cancellation, Ctrl-C).
    Observer(&'w mut dyn FnMut(u64, u64) -> Result<()>),
}

/// The link a run of `sc` uses when `asked` is asked for (see [`FlyOptions::link`]).
pub fn link_kind(sc: &Scenario, asked: Option<&LinkKind>) -> Result<LinkKind> {
    Ok(match (asked, &sc.link.kind) {
        _ if !sc.closed_loop() => LinkKind::InProcess,
        (Some(k), _) => k.clone(),
        (None, Some(s)) => s.parse().context("scenario link.kind")?,
        (None, None) => LinkKind::InProcess,
    })
}

/// A run that flew to its end (or its failure), its margins not yet measured.
pub struct Ran<'s> {
    sc: &'s Scenario,
    kind: LinkKind,
    opts: FlyOptions,
    pub summary: Summary,
}

/// Flies `sc` into `rec` on the link [`link_kind`] picks; the link is closed on return.
pub fn run<'s>(sc: &'s Scenario, opts: &FlyOptions, rec: &mut dyn Recorder, watch: Watch) -> Result<Ran<'s>> {
    let kind = link_kind(sc, opts.link.as_ref())?;
    let mut l = link::open(&kind, &opts.link_options)?;
    let summary = match watch {
        Watch::Quiet => runner::run_recorded(sc, l.as_mut(), false, rec)?,
        Watch::Bar => runner::run_recorded(sc, l.as_mut(), true, rec)?,
        Watch::Observer(observe) => runner::run_observed(sc, l.as_mut(), rec, observe)?,
    };
    drop(l);
    Ok(Ran { sc, kind, opts: opts.clone(), summary })
}

/// [`run`], then [`Ran::with_margins`].
pub fn fly(sc: &Scenario, opts: &FlyOptions, rec: &mut dyn Recorder, watch: Watch) -> Result<Flown> {
    run(sc, opts, rec, watch)?.with_margins()
}

impl Ran<'_> {
    /// Measures the margins `[margins]` asks for (nothing without the table) on the run's
    /// link into the summary: a loop that is not stable at a steady hold fails the run
    /// (`run_status` `margins_failed`). An invalid `[margins]` table is an error.
    pub fn with_margins(self) -> Result<Flown> {
        let Ran { sc, kind, opts, mut summary } = self;
        let base = MarginOptions {
            link: kind,
            link_options: opts.link_options,
            threads: opts.margin_threads,
            ..Default::default()
        };
        let margins = crate::margins::summary::record(sc, &base, &mut summary)?;
        Ok(Flown { summary, margins })
    }
}

/// A flown run: its summary (margins included) and the margins report when one was measured.
pub struct Flown {
    pub summary: Summary,
    pub margins: Option<MarginReport>,
}

/// How a flown run ends.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Flew, and its `[margins]` (if any) measured a stable loop at a steady hold.
    Ok,
    /// Flew but failed (diverged, every step refused, link anomaly, samples dropped, no
    /// control): exit status [`EXIT_RUN_FAILED`].
    Failed(String),
    /// `[margins]` not a stable loop at a steady hold: `sim-host margins`'s exit status.
    Margins { exit_code: u8, message: String },
}

/// Exit status of a run that flew but failed.
pub const EXIT_RUN_FAILED: u8 = 3;

impl Verdict {
    /// The process exit status of `sim-host run` for this verdict.
    pub fn exit_code(&self) -> u8 {
        match self {
            Verdict::Ok => 0,
            Verdict::Failed(_) => EXIT_RUN_FAILED,
            Verdict::Margins { exit_code, .. } => *exit_code,
        }
    }
}

impl Flown {
    /// The verdict of the run: its failure, else its `[margins]` verdict.
    pub fn verdict(&self) -> Verdict {
        verdict(&self.summary)
    }
}

/// The verdict of a run's summary (see [`Flown::verdict`]).
pub fn verdict(summary: &Summary) -> Verdict {
    let name = &summary.scenario;
    let failed = |what: String| Verdict::Failed(format!("{name}: {what}"));
    match &summary.failure {
        Some(Failure::Diverged { t_s, quantity }) => failed(format!(
            "the run diverged: {quantity} is not finite at t = {t_s} s; the run was stopped there \
             (summary.json: run_status \"diverged\")"
        )),
        Some(Failure::Refused { reason }) => {
            failed(format!("every control step was refused: {reason} (summary.json: run_status \"all_refused\")"))
        }
        Some(Failure::Link { reason }) => failed(format!("{reason} (summary.json: run_status \"link_anomaly\")")),
        Some(Failure::Sensors { reason }) => failed(format!("{reason} (summary.json: run_status \"samples_dropped\")")),
        Some(Failure::KeepOut { reason }) => {
            failed(format!("{reason} (summary.json: run_status \"keepout_violated\")"))
        }
        Some(Failure::Timeline { reason }) => {
            failed(format!("{reason} (summary.json: run_status \"timeline_missed\")"))
        }
        Some(Failure::Fdir { reason }) => failed(format!("{reason} (summary.json: run_status \"fdir_false_alarm\")")),
        Some(Failure::ControlLost { reason }) => {
            failed(format!("{reason} (summary.json: run_status \"control_lost\")"))
        }
        Some(Failure::RecoveryFailed { reason }) => {
            failed(format!("{reason} (summary.json: run_status \"recovery_failed\")"))
        }
        Some(Failure::PointingDegraded { reason }) => {
            failed(format!("{reason} (summary.json: run_status \"pointing_degraded\")"))
        }
        Some(Failure::Propellant { reason }) => {
            failed(format!("{reason} (summary.json: run_status \"propellant_exceeded\")"))
        }
        Some(Failure::Control { reason }) => {
            failed(format!("the flight code could not control: {reason} (summary.json: run_status \"no_control\")"))
        }
        Some(Failure::Margins { .. }) | None => {
            let Some(m) = summary.margins.as_ref() else { return Verdict::Ok };
            match crate::margins::summary::exit_code(m) {
                0 => Verdict::Ok,
                code => Verdict::Margins {
                    exit_code: u8::try_from(code).unwrap_or(1),
                    message: format!(
                        "{name}: [margins] not met (summary.json: run_status \"margins_failed\"): {}",
                        crate::margins::summary::line(m)
                    ),
                },
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn load(rel: &str) -> Scenario {
        Scenario::load(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(rel)).unwrap()
    }

    /// The rule `sim-host run --link` states (its help): open loop flies in-process
    /// whatever is asked; else the asked link, else the scenario's `link.kind`, else
    /// in-process; a `link.kind` that does not parse is an error naming the key.
    #[test]
    fn link_choice_follows_the_documented_rule() {
        let qemu = LinkKind::Qemu;
        let open = load("scenarios/paper003/rig-open-loop.toml");
        assert!(!open.closed_loop());
        assert_eq!(link_kind(&open, Some(&qemu)).unwrap(), LinkKind::InProcess);
        let mut closed = load("scenarios/paper000/test1.toml");
        assert!(closed.closed_loop());
        assert_eq!(link_kind(&closed, None).unwrap(), LinkKind::InProcess);
        assert_eq!(link_kind(&closed, Some(&qemu)).unwrap(), qemu);
        closed.link.kind = Some("qemu".into());
        assert_eq!(link_kind(&closed, None).unwrap(), qemu);
        assert_eq!(link_kind(&closed, Some(&LinkKind::InProcess)).unwrap(), LinkKind::InProcess);
        closed.link.kind = Some("pigeon".into());
        assert!(format!("{:#}", link_kind(&closed, None).unwrap_err()).contains("scenario link.kind"));
    }

    /// A run that flies clean is `Ok` (exit 0); one whose summary records a failure exits 3
    /// with the scenario's name and the `run_status` in the message.
    #[test]
    fn verdict_of_a_clean_and_of_a_diverged_run() {
        let sc = load("scenarios/paper000/test1.toml");
        let mut summary = runner::fly(&sc).unwrap();
        assert_eq!(verdict(&summary), Verdict::Ok);
        summary.failure = Some(Failure::Diverged { t_s: 1.5, quantity: "rate_rad_s".into() });
        let v = verdict(&summary);
        assert_eq!(v.exit_code(), EXIT_RUN_FAILED);
        let Verdict::Failed(m) = v else { panic!("{v:?}") };
        assert!(m.starts_with(&sc.name) && m.contains("\"diverged\"") && m.contains("t = 1.5 s"), "{m}");
        // Every other failure: exit 3, its run_status named.
        let failures = [
            (Failure::KeepOut { reason: "a boresight entered its keep-out cone".into() }, "keepout_violated"),
            (Failure::ControlLost { reason: "control lost with no FDIR event".into() }, "control_lost"),
            (Failure::RecoveryFailed { reason: "recovery failed".into() }, "recovery_failed"),
            (Failure::PointingDegraded { reason: "pointing degraded".into() }, "pointing_degraded"),
            (Failure::Propellant { reason: "propellant exceeded".into() }, "propellant_exceeded"),
        ];
        for (failure, status) in failures {
            summary.failure = Some(failure);
            let v = verdict(&summary);
            assert_eq!(v.exit_code(), EXIT_RUN_FAILED, "{status}");
            assert!(matches!(&v, Verdict::Failed(m) if m.contains(&format!("\"{status}\""))), "{v:?}");
        }
    }
}
