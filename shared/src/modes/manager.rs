//! The transition logic: which mode runs, and why (see the [module docs](super)).

use super::Reason;
use crate::params::{MODE_COUNT, Mode, ModeManagerParams, ModeRequest};

/// What the manager looks at each step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModeInputs {
    /// `|ω|`, inertial body rate, rad/s.
    pub rate_rad_s: f32,
    /// `|ω - ω_c|`, rate relative to the active mode's commanded rate, rad/s.
    pub rel_rate_rad_s: f32,
    /// Attitude error to the active mode's target, rad (NaN when unknown).
    pub error_rad: f32,
    /// Per mode: this frame carries every input that mode's law needs.
    pub inputs_ok: [bool; MODE_COUNT],
    /// Largest wheel speed as a fraction of its limit (NaN when unknown: never trips).
    pub wheel_speed_fraction: f32,
    /// Stored wheel momentum `|h|` over the cluster capacity `J_w Ω_max` (NaN unknown).
    pub stored_momentum_fraction: f32,
    /// A CMG gimbal is at its angle limit or the cluster near a singularity (see
    /// [`ModeManagerParams::gimbal_singularity_min`]); false without CMGs.
    pub gimbal_saturated: bool,
}

/// Transition state. `configured[i]`: slot `i` has a parameter set.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModeManager {
    pub params: ModeManagerParams,
    pub mode: Mode,
    pub reason: Reason,
    pub locked: bool,
    configured: [bool; MODE_COUNT],
    dwell_steps: u32,
    trigger_steps: u32,
    /// Consecutive steps the convergence (resp. fault) condition of the mode has held.
    converged_for: u32,
    faulty_for: u32,
    rate_high_for: u32,
    blind_for: u32,
    /// Consecutive steps a wheel has been above `momentum_trip_fraction` (not reset by
    /// a mode switch: one event per excursion).
    momentum_high_for: u32,
    /// Consecutive steps of the keep-up and gimbal conditions, and their persistence.
    keepup_for: u32,
    gimbal_for: u32,
    slow_steps: u32,
    /// Transitions so far (saturating).
    pub transitions: u16,
    /// Momentum FDIR events so far (saturating).
    pub momentum_events: u16,
    /// "Unloading cannot keep up" events so far (saturating; flag only).
    pub keepup_events: u16,
    /// CMG gimbal-saturation events so far (saturating; flag only).
    pub gimbal_events: u16,
}

fn steps_for(seconds: f32, dt_s: f32) -> u32 {
    let n = libm::ceilf(seconds / dt_s);
    // Validated inputs keep this finite and positive; float → integer `as` saturates
    // (negative → 0) anyway.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    if n.is_finite() { n as u32 } else { u32::MAX }
}

impl ModeManager {
    /// `None` if the initial mode has no parameter set or `dt_s` is not positive.
    pub fn new(params: ModeManagerParams, configured: [bool; MODE_COUNT], dt_s: f32) -> Option<Self> {
        if !configured.get(params.initial.index()).copied().unwrap_or(false) || !(dt_s > 0.0) {
            return None;
        }
        Some(Self {
            params,
            mode: params.initial,
            reason: Reason::Armed,
            locked: false,
            configured,
            dwell_steps: steps_for(params.dwell_s, dt_s).max(1),
            trigger_steps: steps_for(params.trigger_persistence_s, dt_s).max(1),
            converged_for: 0,
            faulty_for: 0,
            rate_high_for: 0,
            blind_for: 0,
            momentum_high_for: 0,
            keepup_for: 0,
            gimbal_for: 0,
            slow_steps: steps_for(params.slow_fdir_persistence_s, dt_s).max(1),
            transitions: 0,
            momentum_events: 0,
            keepup_events: 0,
            gimbal_events: 0,
        })
    }

    fn is_configured(&self, m: Mode) -> bool {
        self.configured.get(m.index()).copied().unwrap_or(false)
    }

    /// The first configured mode after `m` in the nominal sequence.
    fn next_after(&self, m: Mode) -> Option<Mode> {
        Mode::SEQUENCE.iter().copied().filter(|x| x.rank() > m.rank()).find(|x| self.is_configured(*x))
    }

    fn switch(&mut self, to: Mode, why: Reason) -> Option<(Mode, Reason)> {
        self.mode = to;
        self.reason = why;
        self.converged_for = 0;
        self.faulty_for = 0;
        self.rate_high_for = 0;
        self.blind_for = 0;
        self.transitions = self.transitions.saturating_add(1);
        Some((to, why))
    }

    /// The momentum FDIR condition has persisted (reported as `MOMENTUM_SATURATION`).
    pub fn momentum_alarm(&self) -> bool {
        self.params.momentum_trip_fraction > 0.0 && self.momentum_high_for >= self.trigger_steps
    }

    /// Momentum FDIR: counts the event and returns the fallback mode when a pointing mode
    /// must leave. Runs even when locked (the event is still counted; no switch).
    fn momentum_fdir(&mut self, x: &ModeInputs) -> Option<Mode> {
        let trip = self.params.momentum_trip_fraction;
        if trip <= 0.0 {
            return None;
        }
        let high = x.wheel_speed_fraction > trip;
        self.momentum_high_for = if high { self.momentum_high_for.saturating_add(1) } else { 0 };
        if self.momentum_high_for == self.trigger_steps {
            self.momentum_events = self.momentum_events.saturating_add(1);
        }
        let pointing = self.mode.rank() > Mode::SunSafe.rank();
        if self.locked || !pointing || !self.momentum_alarm() {
            return None;
        }
        [Mode::SunSafe, Mode::Detumble].into_iter().find(|m| self.is_configured(*m))
    }

    /// The slow monitors (flag only, every mode, locked or not): stored momentum above
    /// the keep-up fraction, a gimbal saturated, each held for `slow_fdir_persistence_s`,
    /// count one event per excursion.
    fn slow_fdir(&mut self, x: &ModeInputs) {
        let p = &self.params;
        if p.slow_fdir_persistence_s <= 0.0 {
            return;
        }
        let high = p.momentum_keepup_fraction > 0.0 && x.stored_momentum_fraction > p.momentum_keepup_fraction;
        self.keepup_for = if high { self.keepup_for.saturating_add(1) } else { 0 };
        if self.keepup_for == self.slow_steps {
            self.keepup_events = self.keepup_events.saturating_add(1);
        }
        self.gimbal_for = if x.gimbal_saturated { self.gimbal_for.saturating_add(1) } else { 0 };
        if self.gimbal_for == self.slow_steps {
            self.gimbal_events = self.gimbal_events.saturating_add(1);
        }
    }

    /// A slow monitor's condition has persisted (reported as `MOMENTUM_SATURATION`).
    pub fn slow_alarm(&self) -> bool {
        self.params.slow_fdir_persistence_s > 0.0
            && (self.keepup_for >= self.slow_steps || self.gimbal_for >= self.slow_steps)
    }

    fn momentum_recovered(&self, x: &ModeInputs) -> bool {
        let p = &self.params;
        p.momentum_trip_fraction <= 0.0 || x.wheel_speed_fraction < p.momentum_recover_fraction
    }

    /// Apply a ground command. `false` (and nothing changes) if the mode has no slot.
    pub fn command(&mut self, r: ModeRequest) -> bool {
        match r {
            ModeRequest::Auto => {
                self.locked = false;
                true
            }
            ModeRequest::Enter(m) | ModeRequest::Lock(m) => {
                if !self.is_configured(m) {
                    return false;
                }
                self.locked = matches!(r, ModeRequest::Lock(_));
                if m != self.mode {
                    self.switch(m, Reason::Commanded);
                }
                true
            }
        }
    }

    /// One step of the automatic logic; returns the new mode and why when it changed.
    /// Non-finite inputs count as "not converged" and never trigger a fault on their own
    /// (`!(x < y)` / `x > y` comparisons), so a bad estimate cannot switch modes.
    pub fn update(&mut self, x: &ModeInputs) -> Option<(Mode, Reason)> {
        self.slow_fdir(x);
        if let Some(to) = self.momentum_fdir(x) {
            return self.switch(to, Reason::MomentumHigh);
        }
        if self.locked {
            return None;
        }
        let p = self.params;
        let sat = |c: u32, on: bool| if on { c.saturating_add(1) } else { 0 };
        let ok = |m: Mode| x.inputs_ok.get(m.index()).copied().unwrap_or(false);
        if self.mode != Mode::Detumble && self.is_configured(Mode::Detumble) {
            self.rate_high_for = sat(self.rate_high_for, x.rate_rad_s > p.detumble_enter_rate_rad_s);
            if self.rate_high_for >= self.trigger_steps {
                return self.switch(Mode::Detumble, Reason::RateHigh);
            }
        }
        // Inputs lost: sun-safe if it has a slot and can run, else detumble.
        let fallback = [Mode::SunSafe, Mode::Detumble]
            .into_iter()
            .filter(|m| m.rank() < self.mode.rank())
            .find(|m| self.is_configured(*m) && ok(*m));
        if let Some(to) = fallback {
            self.blind_for = sat(self.blind_for, !ok(self.mode));
            if self.blind_for >= self.trigger_steps {
                return self.switch(to, Reason::InputLost);
            }
        } else {
            self.blind_for = 0;
        }
        let next_ok = self.next_after(self.mode).is_some_and(ok);
        let (converged, fault) = match self.mode {
            Mode::Detumble => (x.rate_rad_s < p.detumble_exit_rate_rad_s, false),
            // Fine determination is back: every input of the next mode is present.
            // … and, with the momentum monitor on, the wheels are below the recovery level.
            Mode::SunSafe => (next_ok && self.momentum_recovered(x), false),
            Mode::Stabilise => {
                (x.error_rad < p.stabilise_exit_error_rad && x.rel_rate_rad_s < p.stabilise_exit_rate_rad_s, false)
            }
            Mode::Manoeuvre => {
                (x.error_rad < p.hold_enter_error_rad && x.rel_rate_rad_s < p.hold_enter_rate_rad_s, false)
            }
            Mode::Hold => (false, x.error_rad > p.hold_exit_error_rad),
        };
        self.converged_for = sat(self.converged_for, converged);
        self.faulty_for = sat(self.faulty_for, fault);
        if self.faulty_for >= self.trigger_steps && self.is_configured(Mode::Manoeuvre) {
            return self.switch(Mode::Manoeuvre, Reason::OffTarget);
        }
        if self.converged_for >= self.dwell_steps {
            let why = match self.mode {
                Mode::Detumble => Reason::Detumbled,
                Mode::SunSafe => Reason::EstimateValid,
                Mode::Stabilise => Reason::Stabilised,
                _ => Reason::OnTarget,
            };
            let next = match self.mode {
                Mode::Manoeuvre => Some(Mode::Hold).filter(|m| self.is_configured(*m)),
                m => self.next_after(m),
            }
            // Never into a mode that could not run on this frame.
            .filter(|m| ok(*m));
            if let Some(n) = next {
                return self.switch(n, why);
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::ParamReason;

    fn params() -> ModeManagerParams {
        ModeManagerParams {
            slots: 0b1111,
            initial: Mode::Detumble,
            detumble_enter_rate_rad_s: 0.05,
            detumble_exit_rate_rad_s: 0.01,
            stabilise_exit_error_rad: 0.1,
            stabilise_exit_rate_rad_s: 0.002,
            hold_enter_error_rad: 0.01,
            hold_enter_rate_rad_s: 0.001,
            hold_exit_error_rad: 0.03,
            dwell_s: 1.0,
            trigger_persistence_s: 0.2,
            momentum_trip_fraction: 0.0,
            momentum_recover_fraction: 0.0,
            momentum_keepup_fraction: 0.0,
            gimbal_singularity_min: 0.0,
            slow_fdir_persistence_s: 0.0,
        }
    }

    const DT: f32 = 0.1;
    /// The four modes before sun-safe existed.
    const FOUR: [bool; MODE_COUNT] = [true, true, true, true, false];

    fn run(m: &mut ModeManager, x: ModeInputs, steps: usize) -> Vec<(usize, Mode, Reason)> {
        (0..steps).filter_map(|k| m.update(&x).map(|(a, b)| (k, a, b))).collect()
    }

    fn inputs(rate: f32, error: f32) -> ModeInputs {
        ModeInputs {
            rate_rad_s: rate,
            rel_rate_rad_s: rate,
            error_rad: error,
            inputs_ok: [true; MODE_COUNT],
            wheel_speed_fraction: 0.0,
            stored_momentum_fraction: 0.0,
            gimbal_saturated: false,
        }
    }

    #[test]
    fn keepup_and_gimbal_monitors_count_persistent_excursions_without_switching() {
        let p = ModeManagerParams {
            initial: Mode::Hold,
            slots: 0b1_1111,
            momentum_keepup_fraction: 0.6,
            gimbal_singularity_min: 0.1,
            slow_fdir_persistence_s: 1.0, // 10 steps at DT
            ..params()
        };
        let mut m = ModeManager::new(p, [true; MODE_COUNT], DT).unwrap();
        let at = |h: f32, g: bool| ModeInputs { stored_momentum_fraction: h, gimbal_saturated: g, ..inputs(0.0, 0.0) };
        // Below, NaN, or above for one step short of the persistence: nothing.
        assert!(run(&mut m, at(0.59, false), 100).is_empty());
        assert!(run(&mut m, at(f32::NAN, false), 100).is_empty());
        assert!(run(&mut m, at(0.7, false), 9).is_empty());
        assert_eq!((m.keepup_events, m.slow_alarm()), (0, false));
        // The 10th step counts one event, flags it, and switches nothing (flag only).
        assert!(run(&mut m, at(0.7, false), 1).is_empty());
        assert_eq!((m.keepup_events, m.slow_alarm(), m.mode), (1, true, Mode::Hold));
        // One event per excursion: staying high counts no more; a new excursion counts.
        assert!(run(&mut m, at(0.7, false), 500).is_empty());
        assert_eq!(m.keepup_events, 1);
        run(&mut m, at(0.1, false), 1);
        assert!(!m.slow_alarm());
        run(&mut m, at(0.7, false), 10);
        assert_eq!(m.keepup_events, 2);
        // The gimbal monitor is separate: its own counter, the speed trip untouched.
        run(&mut m, at(0.1, true), 10);
        assert_eq!((m.gimbal_events, m.keepup_events, m.momentum_events), (1, 2, 0));
        // Locked: still counted.
        m.command(ModeRequest::Lock(Mode::Hold));
        run(&mut m, at(0.1, false), 1);
        run(&mut m, at(0.1, true), 10);
        assert_eq!(m.gimbal_events, 2);
        // Persistence 0 turns both off.
        let mut off =
            ModeManager::new(ModeManagerParams { slow_fdir_persistence_s: 0.0, ..p }, [true; MODE_COUNT], DT).unwrap();
        run(&mut off, at(0.9, true), 100);
        assert_eq!((off.keepup_events, off.gimbal_events, off.slow_alarm()), (0, 0, false));
        // Validation.
        let e = |q: ModeManagerParams| q.validate().unwrap_err().reason;
        assert_eq!(e(ModeManagerParams { momentum_keepup_fraction: 1.5, ..p }), ParamReason::OutOfRange);
        assert_eq!(e(ModeManagerParams { momentum_keepup_fraction: -0.1, ..p }), ParamReason::OutOfRange);
        assert_eq!(e(ModeManagerParams { gimbal_singularity_min: f32::NAN, ..p }), ParamReason::NotFinite);
        assert_eq!(e(ModeManagerParams { slow_fdir_persistence_s: -1.0, ..p }), ParamReason::OutOfRange);
    }

    #[test]
    fn momentum_fdir_counts_one_event_per_excursion_and_falls_back_to_sun_safe() {
        let p = ModeManagerParams {
            initial: Mode::Hold,
            slots: 0b1_1111,
            momentum_trip_fraction: 0.9,
            momentum_recover_fraction: 0.5,
            ..params()
        };
        let mut m = ModeManager::new(p, [true; MODE_COUNT], DT).unwrap();
        let at = |f: f32| ModeInputs { wheel_speed_fraction: f, ..inputs(0.0, 0.0) };
        // Below the trip (and NaN) nothing happens, however long.
        assert!(run(&mut m, at(0.89), 500).is_empty());
        assert!(run(&mut m, at(f32::NAN), 500).is_empty());
        assert_eq!(m.momentum_events, 0);
        // Above: after the 2-step persistence, one event and sun-safe.
        assert_eq!(run(&mut m, at(0.95), 50), vec![(1, Mode::SunSafe, Reason::MomentumHigh)]);
        assert_eq!(m.momentum_events, 1);
        assert!(m.momentum_alarm());
        // Sun-safe waits for the recovery level (between recover and trip: stays) …
        assert!(run(&mut m, at(0.7), 100).is_empty());
        assert!(!m.momentum_alarm());
        assert_eq!(m.momentum_events, 1);
        // … and hands back below it after the dwell.
        assert_eq!(run(&mut m, at(0.4), 10), vec![(9, Mode::Stabilise, Reason::EstimateValid)]);
        // Without a sun-safe slot the fallback is detumble; a second excursion counts twice.
        let mut m = ModeManager::new(p, [true, true, true, true, false], DT).unwrap();
        assert_eq!(run(&mut m, at(0.95), 5), vec![(1, Mode::Detumble, Reason::MomentumHigh)]);
        m.command(ModeRequest::Lock(Mode::Hold));
        assert!(run(&mut m, at(0.2), 3).is_empty());
        // Locked: counted and reported, no switch.
        assert!(run(&mut m, at(0.95), 5).is_empty());
        assert_eq!(m.momentum_events, 2);
        // Validation: recover below trip, trip at most 1.
        let e = |q: ModeManagerParams| q.validate().unwrap_err().reason;
        assert_eq!(e(ModeManagerParams { momentum_recover_fraction: 0.95, ..p }), ParamReason::OutOfRange);
        assert_eq!(e(ModeManagerParams { momentum_trip_fraction: 1.5, ..p }), ParamReason::OutOfRange);
        assert_eq!(e(ModeManagerParams { momentum_trip_fraction: f32::NAN, ..p }), ParamReason::NotFinite);
    }

    #[test]
    fn nominal_sequence_with_dwell_times() {
        let mut m = ModeManager::new(params(), FOUR, DT).unwrap();
        // Still tumbling: stays in detumble however long.
        assert!(run(&mut m, inputs(0.03, 1.0), 500).is_empty());
        // Rate below the exit threshold: leaves after exactly dwell_s / dt = 10 steps.
        assert_eq!(run(&mut m, inputs(0.005, 1.0), 20), vec![(9, Mode::Stabilise, Reason::Detumbled)]);
        assert_eq!(run(&mut m, inputs(0.001, 0.05), 20), vec![(9, Mode::Manoeuvre, Reason::Stabilised)]);
        assert_eq!(run(&mut m, inputs(0.0005, 0.005), 20), vec![(9, Mode::Hold, Reason::OnTarget)]);
        assert_eq!(m.transitions, 3);
        // A new target: the error jumps; hold → manoeuvre after the 2-step persistence.
        assert_eq!(run(&mut m, inputs(0.0005, 0.5), 5), vec![(1, Mode::Manoeuvre, Reason::OffTarget)]);
    }

    #[test]
    fn hysteresis_band_never_switches_and_noise_cannot_chatter() {
        let mut m = ModeManager::new(ModeManagerParams { initial: Mode::Hold, ..params() }, FOUR, DT).unwrap();
        // Error between hold_enter (0.01) and hold_exit (0.03): hold stays hold.
        assert!(run(&mut m, inputs(0.0, 0.02), 1000).is_empty());
        // Error alternating across hold_exit every step never persists for 2 steps.
        let mut switched = 0;
        for k in 0..1000 {
            let e = if k % 2 == 0 { 0.04 } else { 0.02 };
            switched += usize::from(m.update(&inputs(0.0, e)).is_some());
        }
        assert_eq!(switched, 0);
        // Same for the rate trigger around detumble_enter.
        for k in 0..1000 {
            let r = if k % 2 == 0 { 0.06 } else { 0.04 };
            switched += usize::from(m.update(&inputs(r, 0.0)).is_some());
        }
        assert_eq!(switched, 0);
    }

    #[test]
    fn rate_trigger_returns_to_detumble_from_any_mode() {
        for start in [Mode::Stabilise, Mode::Manoeuvre, Mode::Hold] {
            let mut m = ModeManager::new(ModeManagerParams { initial: start, ..params() }, FOUR, DT).unwrap();
            assert_eq!(run(&mut m, inputs(0.2, 0.0), 3), vec![(1, Mode::Detumble, Reason::RateHigh)]);
        }
    }

    #[test]
    fn missing_slots_are_skipped_and_commands_respect_them() {
        let cfg = [true, false, true, false, false];
        let mut m = ModeManager::new(params(), cfg, DT).unwrap();
        assert_eq!(run(&mut m, inputs(0.005, 1.0), 20), vec![(9, Mode::Manoeuvre, Reason::Detumbled)]);
        // No hold slot: manoeuvre is terminal.
        assert!(run(&mut m, inputs(0.0, 0.0), 100).is_empty());
        assert!(!m.command(ModeRequest::Enter(Mode::Hold)));
        assert_eq!(m.mode, Mode::Manoeuvre);
        assert!(ModeManager::new(ModeManagerParams { initial: Mode::Hold, ..params() }, cfg, DT).is_none());
    }

    #[test]
    fn lock_suspends_and_auto_resumes() {
        let mut m = ModeManager::new(params(), FOUR, DT).unwrap();
        assert!(m.command(ModeRequest::Lock(Mode::Manoeuvre)));
        assert_eq!((m.mode, m.reason), (Mode::Manoeuvre, Reason::Commanded));
        // Locked: neither convergence nor a high rate moves it.
        assert!(run(&mut m, inputs(1.0, 0.0), 100).is_empty());
        assert!(m.command(ModeRequest::Auto));
        assert_eq!(run(&mut m, inputs(1.0, 0.0), 3), vec![(1, Mode::Detumble, Reason::RateHigh)]);
    }

    #[test]
    fn nan_inputs_never_switch() {
        let mut m = ModeManager::new(ModeManagerParams { initial: Mode::Hold, ..params() }, FOUR, DT).unwrap();
        assert!(run(&mut m, inputs(f32::NAN, f32::NAN), 100).is_empty());
        let mut m = ModeManager::new(params(), FOUR, DT).unwrap();
        assert!(run(&mut m, inputs(f32::NAN, f32::NAN), 100).is_empty());
    }

    #[test]
    fn validation_requires_an_open_hysteresis_band() {
        assert_eq!(params().validate(), Ok(()));
        let e = |p: ModeManagerParams| p.validate().unwrap_err().reason;
        assert_eq!(e(ModeManagerParams { hold_exit_error_rad: 0.01, ..params() }), ParamReason::OutOfRange);
        assert_eq!(e(ModeManagerParams { detumble_enter_rate_rad_s: 0.01, ..params() }), ParamReason::OutOfRange);
        assert_eq!(e(ModeManagerParams { dwell_s: f32::NAN, ..params() }), ParamReason::NotFinite);
        assert_eq!(e(ModeManagerParams { dwell_s: -1.0, ..params() }), ParamReason::OutOfRange);
        assert_eq!(e(ModeManagerParams { slots: 0b1110, ..params() }), ParamReason::OutOfRange);
        assert_eq!(e(ModeManagerParams { slots: 0b10_0000, ..params() }), ParamReason::OutOfRange);
        assert_eq!(ModeManagerParams { slots: 0b1_1111, ..params() }.validate(), Ok(()));
    }

    #[test]
    fn lost_inputs_fall_back_to_detumble_which_waits_for_the_next_modes_inputs() {
        let mut m = ModeManager::new(ModeManagerParams { initial: Mode::Hold, ..params() }, FOUR, DT).unwrap();
        // Star tracker blind: hold cannot run, detumble (gyro + magnetometer) can.
        let blind = ModeInputs { inputs_ok: [true, false, false, false, false], ..inputs(0.02, f32::NAN) };
        assert_eq!(run(&mut m, blind, 3), vec![(1, Mode::Detumble, Reason::InputLost)]);
        // Slow enough to leave detumble, but stabilise still lacks its inputs: wait.
        let slow_blind = ModeInputs { inputs_ok: [true, false, false, false, false], ..inputs(0.005, f32::NAN) };
        assert!(run(&mut m, slow_blind, 100).is_empty());
        assert_eq!(run(&mut m, inputs(0.005, 1.0), 1), vec![(0, Mode::Stabilise, Reason::Detumbled)]);
        // Detumble's own inputs missing too: stay (nothing better to go to).
        let mut m = ModeManager::new(ModeManagerParams { initial: Mode::Hold, ..params() }, FOUR, DT).unwrap();
        assert!(run(&mut m, ModeInputs { inputs_ok: [false; 5], ..inputs(0.02, f32::NAN) }, 100).is_empty());
    }

    #[test]
    fn sun_safe_sits_between_detumble_and_the_pointing_modes() {
        let all = [true; MODE_COUNT];
        let fine = |rate: f32, err: f32| inputs(rate, err);
        // Fine attitude missing: only detumble and sun-safe (gyro) can run.
        let coarse = |rate: f32| ModeInputs { inputs_ok: [true, false, false, false, true], ..inputs(rate, f32::NAN) };
        let mut m = ModeManager::new(params(), all, DT).unwrap();
        // Detumbled → sun-safe (not stabilise) after the dwell, even with the tracker blind.
        assert_eq!(run(&mut m, coarse(0.005), 20), vec![(9, Mode::SunSafe, Reason::Detumbled)]);
        // Sun-safe waits for the fine attitude however long…
        assert!(run(&mut m, coarse(0.005), 1000).is_empty());
        // … and leaves for stabilise once it has been back for the dwell.
        assert_eq!(run(&mut m, fine(0.005, 1.0), 20), vec![(9, Mode::Stabilise, Reason::EstimateValid)]);
        // Fine attitude lost in a pointing mode: back to sun-safe after the persistence.
        assert_eq!(run(&mut m, coarse(0.005), 5), vec![(1, Mode::SunSafe, Reason::InputLost)]);
        // A tumble from sun-safe: detumble.
        assert_eq!(run(&mut m, coarse(0.2), 5), vec![(1, Mode::Detumble, Reason::RateHigh)]);
        // Without a sun-safe slot the old behaviour holds: input loss → detumble.
        let mut m = ModeManager::new(ModeManagerParams { initial: Mode::Hold, ..params() }, FOUR, DT).unwrap();
        assert_eq!(run(&mut m, coarse(0.005), 5), vec![(1, Mode::Detumble, Reason::InputLost)]);
        // Sun-safe as the initial mode with the estimate never coming back: stays.
        let mut m = ModeManager::new(ModeManagerParams { initial: Mode::SunSafe, ..params() }, all, DT).unwrap();
        assert!(run(&mut m, coarse(0.001), 10_000).is_empty());
    }
}
