//! On/off thrusters (paper 004): geometry → effectiveness matrix, valve timing (minimum
//! on-time, opening/closing delays), failures, pulse count and propellant.
//!
//! Split between discrete and continuous parts:
//! - [`ThrusterSet::step`] is the **discrete** update, called once per dynamics step at its start `t`
//!   with the command the flight code holds over `[t, t+dt)`. It advances the valve
//!   schedule and returns the fraction of the step each valve is open.
//! - [`ThrusterSet::wrench`] is **pure**: force/torque for given open fractions. The
//!   RK4 stages of the step all use the same (step-averaged) wrench, so the impulse
//!   over the step is exact even when a valve opens or closes inside it; only the
//!   intra-step timing is smeared.
//!
//! Timing model (per thruster). Commands change only at step boundaries. A rising edge
//! of the command at `a` starts an *effective* command; a falling edge at `t` ends it at
//! `b = max(t, a + min_on_time)` — a command shorter than the minimum on-time is
//! **stretched** to it (the minimum impulse bit is `F · min_on_time`), never dropped.
//! A command that comes back on before a stretched pulse has ended continues that pulse
//! (no new edge). The valve is fully open on `[a + open_delay, b + close_delay)`
//! (rectangular thrust profile, no rise/tail), so a pulse delivers
//! `F (b - a + close_delay - open_delay)`: equal delays shift the impulse without
//! changing it. Failures override the valve from their time on, exactly inside the
//! step: `Off` closes it for good, `StuckOn` holds it open whatever the command.
//! Injected faults (`[[faults]]` `stuck_closed` / `stuck_open`, [`InjectedFailure`],
//! unknown to the flight code) override the same way over their window only, and over
//! the known failures; the latest in force in list order wins. Stuck open is full
//! thrust: `thrust_n`, the valve open over the whole of every step in the window.
//! Propellant: `ṁ = F / (Isp g0)` while open.

use crate::faults::Window;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

type Vec3 = Vector3<f64>;

/// Standard gravity used in `ṁ = F / (Isp g0)`, m/s².
pub const G0_M_S2: f64 = 9.80665;
/// Paper 004 prints neither thrust level nor specific impulse; this Isp (typical
/// hydrazine monopropellant) is an assumption used by [`ThrusterSet::paper004`].
pub const PAPER004_ASSUMED_ISP_S: f64 = 220.0;

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ThrusterSpec {
    /// Nozzle position, body axes, m.
    pub position_m: [f64; 3],
    /// Unit direction of the force on the body.
    pub direction: [f64; 3],
    pub thrust_n: f64,
    pub isp_s: f64,
    pub min_on_time_s: f64,
    pub open_delay_s: f64,
    pub close_delay_s: f64,
    /// Torque per newton of thrust about the CG (m), when only an effectiveness matrix
    /// is known ([`ThrusterSet::from_torque_matrix`]). When `Some`, it replaces
    /// `position × direction` and the thruster exerts **no force** (positions unknown).
    #[serde(default)]
    pub torque_per_n_m: Option<[f64; 3]>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Failure {
    /// Valve closed for good (no thrust whatever the command).
    Off,
    /// Valve open for good (full thrust whatever the command).
    StuckOn,
}

/// A valve failure injected over a window (`[[faults]]`, issue 42).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InjectedFailure {
    /// Thruster index, 0-based.
    pub index: usize,
    pub window: Window,
    pub failure: Failure,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ThrusterSet {
    pub thrusters: Vec<ThrusterSpec>,
    /// `(thruster index (0-based), time s, failure)`. For a thruster with several
    /// entries the latest one whose time has passed applies.
    pub failures: Vec<(usize, f64, Failure)>,
    /// Injected faults, in list order (plant only; not part of a thruster description).
    #[serde(skip)]
    pub injected: Vec<InjectedFailure>,
    /// Centre of mass, body axes, m (torques are taken about it).
    pub cg_m: [f64; 3],
}

impl ThrusterSet {
    /// Torque column of thruster `i` per unit open fraction, N m.
    fn torque_col(&self, i: usize) -> Vec3 {
        let t = &self.thrusters[i];
        match t.torque_per_n_m {
            Some(c) => Vec3::from(c) * t.thrust_n,
            None => {
                let r = Vec3::from(t.position_m) - Vec3::from(self.cg_m);
                r.cross(&(Vec3::from(t.direction) * t.thrust_n))
            }
        }
    }

    fn force_col(&self, i: usize) -> Vec3 {
        let t = &self.thrusters[i];
        match t.torque_per_n_m {
            Some(_) => Vec3::zeros(),
            None => Vec3::from(t.direction) * t.thrust_n,
        }
    }

    /// Effectiveness matrix B (3×N, one column per thruster): torque in N m for a fully
    /// open valve (unit command), `(r_i - r_cg) × F_i d_i`.
    pub fn torque_matrix(&self) -> Vec<[f64; 3]> {
        (0..self.thrusters.len()).map(|i| self.torque_col(i).into()).collect()
    }

    /// Build from an effectiveness matrix given as torque per newton of thrust (m), one
    /// column per thruster, as in paper 004 table 2. Positions are unknown, so the set
    /// exerts torque only (force omitted); `position_m`/`direction` are zero.
    pub fn from_torque_matrix(
        cols: &[[f64; 3]],
        thrust_n: f64,
        isp_s: f64,
        min_on_time_s: f64,
        open_delay_s: f64,
        close_delay_s: f64,
    ) -> Self {
        let thrusters = cols
            .iter()
            .map(|c| ThrusterSpec {
                position_m: [0.0; 3],
                direction: [0.0; 3],
                thrust_n,
                isp_s,
                min_on_time_s,
                open_delay_s,
                close_delay_s,
                torque_per_n_m: Some(*c),
            })
            .collect();
        Self { thrusters, failures: Vec::new(), injected: Vec::new(), cg_m: [0.0; 3] }
    }

    /// Paper 004 table 2 (r = d = 0.73 m), B × thrust. Isp = [`PAPER004_ASSUMED_ISP_S`]
    /// (not in the paper), no minimum on-time, no delays; edit the fields to change.
    /// Paper thruster k is index k-1 (e.g. "thrusters 1 and 4 failed" = indices 0, 3).
    pub fn paper004(thrust_n: f64) -> Self {
        let (r, d, k) = (0.73, 0.73, std::f64::consts::FRAC_1_SQRT_2);
        let rows = [
            [r, 0.0, r, -0.43, -r, 0.0, -r, 0.43],
            [d, -0.43, -d, 0.0, -d, 0.43, d, 0.0],
            [d, -d, d, -d, d, -d, d, -d],
        ];
        let cols: Vec<[f64; 3]> = (0..8).map(|j| [k * rows[0][j], k * rows[1][j], k * rows[2][j]]).collect();
        Self::from_torque_matrix(&cols, thrust_n, PAPER004_ASSUMED_ISP_S, 0.0, 0.0, 0.0)
    }

    /// Pure: force (N) and torque about the CG (N m), body axes, for open fractions in
    /// `[0, 1]` (as returned by [`ThrusterSet::step`]).
    pub fn wrench(&self, open: &[f64]) -> ([f64; 3], [f64; 3]) {
        let (mut f, mut tq) = (Vec3::zeros(), Vec3::zeros());
        for (i, &u) in open.iter().enumerate().take(self.thrusters.len()) {
            f += self.force_col(i) * u;
            tq += self.torque_col(i) * u;
        }
        (f.into(), tq.into())
    }

    /// Failure in force at time `tau` for thruster `i`: the latest injected fault in force,
    /// else the known failure.
    fn failure_at(&self, i: usize, tau: f64) -> Option<Failure> {
        let injected = self.injected.iter().rfind(|f| f.index == i && f.window.active(tau));
        injected.map(|f| f.failure).or_else(|| self.known_failure_at(i, tau))
    }

    /// Known failure (`failures`) in force at time `tau` for thruster `i`.
    fn known_failure_at(&self, i: usize, tau: f64) -> Option<Failure> {
        let mut best: Option<(f64, Failure)> = None;
        for &(j, tf, kind) in &self.failures {
            if j == i && tf <= tau && best.is_none_or(|(tb, _)| tf >= tb) {
                best = Some((tf, kind));
            }
        }
        best.map(|(_, k)| k)
    }
}

/// One effective command pulse, absolute times (s). `cmd_off_s` is +∞ while held.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Pulse {
    cmd_on_s: f64,
    cmd_off_s: f64,
}

#[derive(Clone, Debug, Default, PartialEq)]
struct Valve {
    /// Pulses whose valve interval may still reach the current or a later step.
    pulses: Vec<Pulse>,
    /// Valve open at the end of the previous step (for rising-edge counting).
    open_at_end: bool,
}

/// Discrete state of a [`ThrusterSet`] (per thruster).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ThrusterState {
    valves: Vec<Valve>,
    /// Number of valve openings (rising edges of the actual valve state, failures
    /// included: a stuck-on opening counts, a failed-off thruster adds none).
    pub pulses: Vec<u32>,
    /// Accumulated valve-open time, s.
    pub on_time_s: Vec<f64>,
    /// Propellant used, kg.
    pub propellant_kg: Vec<f64>,
}

impl ThrusterState {
    pub fn new(n: usize) -> Self {
        Self {
            valves: vec![Valve::default(); n],
            pulses: vec![0; n],
            on_time_s: vec![0.0; n],
            propellant_kg: vec![0.0; n],
        }
    }

    /// Valve of thruster `i` open at the end of the last step.
    pub fn is_open(&self, i: usize) -> bool {
        self.valves[i].open_at_end
    }

    pub fn total_propellant_kg(&self) -> f64 {
        self.propellant_kg.iter().sum()
    }
}

impl ThrusterSet {
    /// Discrete update for the step `[t, t+dt)`: bit i of `cmd_mask` = thruster i commanded
    /// on over the step. Applies minimum on-time, delays and failures (see module doc),
    /// updates pulse counts, on-time and propellant, and returns the fraction of the step
    /// each valve is open. Call exactly once per step, with increasing `t`.
    pub fn step(&self, s: &mut ThrusterState, cmd_mask: u32, t: f64, dt: f64) -> Vec<f64> {
        let set = self;
        let n = set.thrusters.len();
        assert!(n <= 32, "command mask holds 32 thrusters");
        assert!(dt > 0.0);
        if s.valves.len() != n {
            *s = ThrusterState::new(n);
        }
        let t1 = t + dt;
        let mut open = vec![0.0; n];
        for (i, spec) in set.thrusters.iter().enumerate() {
            let v = &mut s.valves[i];
            // 1. Command state machine at the boundary t.
            let cmd = cmd_mask >> i & 1 == 1;
            let last = v.pulses.last_mut();
            match (cmd, last) {
                // Held on, or back on before a stretched pulse ended: same pulse.
                (true, Some(p)) if p.cmd_off_s >= t => p.cmd_off_s = f64::INFINITY,
                (true, _) => v.pulses.push(Pulse { cmd_on_s: t, cmd_off_s: f64::INFINITY }),
                (false, Some(p)) if p.cmd_off_s.is_infinite() => p.cmd_off_s = t.max(p.cmd_on_s + spec.min_on_time_s),
                (false, _) => {}
            }
            // 2. Valve open set over [t, t1): nominal schedule, overridden by failures
            //    piecewise between failure times falling inside the step.
            let mut cuts = vec![t];
            cuts.extend(set.failures.iter().filter(|&&(j, tf, _)| j == i && tf > t && tf < t1).map(|f| f.1));
            for f in set.injected.iter().filter(|f| f.index == i) {
                let edges = [Some(f.window.onset_s), f.window.end_s];
                cuts.extend(edges.into_iter().flatten().filter(|&x| x > t && x < t1));
            }
            cuts.push(t1);
            cuts.sort_by(f64::total_cmp);
            let mut iv: Vec<(f64, f64)> = Vec::new();
            for w in cuts.windows(2) {
                let (a, b) = (w[0], w[1]);
                match set.failure_at(i, a) {
                    Some(Failure::Off) => {}
                    Some(Failure::StuckOn) => iv.push((a, b)),
                    None => {
                        for p in &v.pulses {
                            let lo = (p.cmd_on_s + spec.open_delay_s).max(a);
                            let hi = (p.cmd_off_s + spec.close_delay_s).min(b);
                            if hi > lo {
                                iv.push((lo, hi));
                            }
                        }
                    }
                }
            }
            iv.sort_by(|x, y| x.0.total_cmp(&y.0));
            let mut merged: Vec<(f64, f64)> = Vec::new();
            for (lo, hi) in iv {
                match merged.last_mut() {
                    Some(m) if lo <= m.1 => m.1 = m.1.max(hi),
                    _ => merged.push((lo, hi)),
                }
            }
            // 3. Edges, on-time, propellant.
            let mut len = 0.0;
            for &(lo, hi) in &merged {
                if lo > t || !v.open_at_end {
                    s.pulses[i] += 1;
                }
                // A fully open step is exactly dt ((t + dt) - t may differ from dt by an ulp).
                len += if lo == t && hi == t1 { dt } else { hi - lo };
            }
            v.open_at_end = merged.last().is_some_and(|m| m.1 >= t1);
            s.on_time_s[i] += len;
            s.propellant_kg[i] += spec.thrust_n * len / (spec.isp_s * G0_M_S2);
            open[i] = (len / dt).clamp(0.0, 1.0);
            // 4. Forget pulses whose valve interval has ended.
            v.pulses.retain(|p| p.cmd_off_s + spec.close_delay_s > t1);
        }
        open
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn one(min_on: f64, od: f64, cd: f64) -> ThrusterSet {
        ThrusterSet {
            thrusters: vec![ThrusterSpec {
                position_m: [0.0, 1.0, 0.0],
                direction: [1.0, 0.0, 0.0],
                thrust_n: 10.0,
                isp_s: 220.0,
                min_on_time_s: min_on,
                open_delay_s: od,
                close_delay_s: cd,
                torque_per_n_m: None,
            }],
            failures: vec![],
            injected: vec![],
            cg_m: [0.0; 3],
        }
    }

    /// Run a command sequence (one bool per step); returns per-step open fractions.
    fn run(set: &ThrusterSet, s: &mut ThrusterState, cmds: &[u32], dt: f64) -> Vec<f64> {
        cmds.iter().enumerate().map(|(k, &c)| set.step(s, c, k as f64 * dt, dt)[0]).collect()
    }

    fn pattern(pulses: usize, on: usize, off: usize, tail: usize) -> Vec<u32> {
        let mut c = Vec::new();
        for _ in 0..pulses {
            c.extend(std::iter::repeat_n(1, on));
            c.extend(std::iter::repeat_n(0, off));
        }
        c.extend(std::iter::repeat_n(0, tail));
        c
    }

    #[test]
    fn propellant_of_n_pulses() {
        let set = one(0.010, 0.0, 0.0);
        let dt = 0.001;
        let (n, on) = (37, 20);
        let mut s = ThrusterState::new(1);
        run(&set, &mut s, &pattern(n, on, 13, 5), dt);
        let t_on = on as f64 * dt;
        let want = n as f64 * 10.0 * t_on / (220.0 * G0_M_S2);
        let rel = (s.propellant_kg[0] - want).abs() / want;
        println!("propellant {:.15e} kg, want {want:.15e}, rel {rel:.1e}", s.propellant_kg[0]);
        assert!(rel < 1e-12, "rel {rel:e}");
        assert_eq!(s.pulses[0], n as u32);
        assert!((s.on_time_s[0] - n as f64 * t_on).abs() < 1e-12);
    }

    #[test]
    fn minimum_impulse_bit() {
        // 1 ms command, 10 ms minimum on-time, 1 ms steps → one 10 ms pulse.
        let set = one(0.010, 0.0, 0.0);
        let mut s = ThrusterState::new(1);
        let f = run(&set, &mut s, &pattern(1, 1, 30, 0), 0.001);
        let open_s: f64 = f.iter().sum::<f64>() * 0.001;
        assert!((open_s - 0.010).abs() < 1e-15, "{open_s}");
        assert_eq!(f.iter().filter(|&&x| x > 0.0).count(), 10);
        assert_eq!(s.pulses[0], 1);
        // With 4 ms steps the 10 ms pulse ends mid-step: fractions 1, 1, 0.5.
        let mut s = ThrusterState::new(1);
        let f = run(&set, &mut s, &[1, 0, 0, 0, 0], 0.004);
        assert!((f[2] - 0.5).abs() < 1e-12 && f[3] == 0.0, "{f:?}");
        // Back on before the stretched pulse ends: one continuous pulse.
        let mut s = ThrusterState::new(1);
        let f = run(&set, &mut s, &[1, 0, 0, 1, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0], 0.001);
        assert_eq!(s.pulses[0], 1);
        assert!((f.iter().sum::<f64>() * 0.001 - 0.010).abs() < 1e-15);
    }

    #[test]
    fn delays_shift_but_keep_the_impulse() {
        let dt = 0.001;
        let cmds = pattern(3, 20, 15, 20);
        let mut s0 = ThrusterState::new(1);
        let f0 = run(&one(0.0, 0.0, 0.0), &mut s0, &cmds, dt);
        let mut s1 = ThrusterState::new(1);
        let f1 = run(&one(0.0, 0.0035, 0.0035), &mut s1, &cmds, dt);
        let (i0, i1) = (f0.iter().sum::<f64>(), f1.iter().sum::<f64>());
        println!("impulse steps: no delay {i0}, 3.5 ms delays {i1}");
        assert!((i0 - i1).abs() < 1e-12, "{i0} vs {i1}");
        assert!((s0.propellant_kg[0] - s1.propellant_kg[0]).abs() < 1e-15);
        // First pulse: valve opens at 3.5 ms → steps 0..3 closed, step 3 half open.
        assert_eq!(&f1[..3], &[0.0; 3]);
        assert!((f1[3] - 0.5).abs() < 1e-9 && (f1[23] - 0.5).abs() < 1e-9);
        // The impulse centroid moves by the delay.
        let c = |f: &[f64]| {
            let w: f64 = f.iter().sum();
            f.iter().enumerate().map(|(k, x)| x * k as f64).sum::<f64>() / w * dt
        };
        assert!((c(&f1) - c(&f0) - 0.0035).abs() < 1e-9);
        // Unequal delays change the pulse by close - open.
        let mut s2 = ThrusterState::new(1);
        let f2 = run(&one(0.0, 0.004, 0.001), &mut s2, &cmds, dt);
        assert!((f2.iter().sum::<f64>() * dt - 3.0 * (0.020 - 0.003)).abs() < 1e-12);
        assert_eq!(s2.pulses[0], 3);
    }

    #[test]
    fn failures() {
        let dt = 0.001;
        // Failed off at 10.5 ms while commanded on throughout.
        let mut set = one(0.0, 0.0, 0.0);
        set.failures.push((0, 0.0105, Failure::Off));
        let mut s = ThrusterState::new(1);
        let f = run(&set, &mut s, &[1; 40], dt);
        assert_eq!(&f[..10], &[1.0; 10]);
        assert!((f[10] - 0.5).abs() < 1e-9);
        assert!(f[11..].iter().all(|&x| x == 0.0));
        assert!((s.on_time_s[0] - 0.0105).abs() < 1e-12);
        // Stuck on at 5.25 ms with no command at all; a later command changes nothing.
        let mut set = one(0.010, 0.002, 0.002);
        set.failures.push((0, 0.00525, Failure::StuckOn));
        let mut s = ThrusterState::new(1);
        let mut cmds = vec![0; 8];
        cmds.extend(pattern(2, 3, 10, 10));
        let f = run(&set, &mut s, &cmds, dt);
        assert_eq!(&f[..5], &[0.0; 5]);
        assert!((f[5] - 0.75).abs() < 1e-9 && f[6..].iter().all(|&x| x == 1.0));
        assert_eq!(s.pulses[0], 1);
        // Repair by a later entry is not modelled, but the latest entry wins.
        let mut set = one(0.0, 0.0, 0.0);
        set.failures = vec![(0, 0.002, Failure::StuckOn), (0, 0.004, Failure::Off)];
        let mut s = ThrusterState::new(1);
        let f = run(&set, &mut s, &[0; 8], dt);
        assert_eq!(f, vec![0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0]);
    }

    #[test]
    fn injected_faults_override_the_valve_over_their_window_only() {
        let dt = 0.001;
        let w = |on: f64, end: Option<f64>| Window { onset_s: on, end_s: end };
        // Stuck open from 2.5 ms to 5.25 ms with no command: the open fraction of each
        // step is its overlap with the window over dt.
        let mut set = one(0.0, 0.0, 0.0);
        set.injected = vec![InjectedFailure { index: 0, window: w(0.0025, Some(0.00525)), failure: Failure::StuckOn }];
        let mut s = ThrusterState::new(1);
        let f = run(&set, &mut s, &[0; 8], dt);
        let want = [0.0, 0.0, 0.5, 1.0, 1.0, 0.25, 0.0, 0.0];
        assert!(f.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-9), "{f:?}");
        assert!((s.on_time_s[0] - 0.00275).abs() < 1e-15 && s.pulses[0] == 1);
        // Stuck closed from 3 ms under a held command: no thrust; the command resumes
        // after the window; a later entry in force wins over an earlier one and over a
        // known failure.
        set.injected = vec![InjectedFailure { index: 0, window: w(0.003, Some(0.005)), failure: Failure::Off }];
        let mut s = ThrusterState::new(1);
        assert_eq!(run(&set, &mut s, &[1; 7], dt), vec![1.0, 1.0, 1.0, 0.0, 0.0, 1.0, 1.0]);
        set.failures = vec![(0, 0.0, Failure::Off)];
        set.injected.push(InjectedFailure { index: 0, window: w(0.004, None), failure: Failure::StuckOn });
        let mut s = ThrusterState::new(1);
        assert_eq!(run(&set, &mut s, &[1; 7], dt), vec![0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0]);
        // Another thruster's fault does not touch this one.
        set.injected = vec![InjectedFailure { index: 1, window: w(0.0, None), failure: Failure::StuckOn }];
        set.failures.clear();
        let mut s = ThrusterState::new(1);
        assert_eq!(run(&set, &mut s, &[0; 3], dt), vec![0.0; 3]);
    }

    #[test]
    fn pulse_counter_counts_rising_edges() {
        let mut s = ThrusterState::new(1);
        run(&one(0.0, 0.0, 0.0), &mut s, &[0, 1, 1, 1, 0, 1, 0, 0, 1, 1, 0, 1], 0.01);
        assert_eq!(s.pulses[0], 4);
        // Delays longer than the gap merge two commanded pulses into one valve opening.
        let mut s = ThrusterState::new(1);
        run(&one(0.0, 0.0, 0.015), &mut s, &[1, 0, 1, 0, 0, 0], 0.01);
        assert_eq!(s.pulses[0], 1);
    }

    #[test]
    fn torque_matrix_from_geometry() {
        // Four thrusters on a ring of radius L at height h firing tangentially (a roll
        // couple about z), CG offset along z.
        let (l, h, f) = (0.5, 0.2, 2.0);
        let spec = |p: [f64; 3], d: [f64; 3]| ThrusterSpec {
            position_m: p,
            direction: d,
            thrust_n: f,
            isp_s: 200.0,
            min_on_time_s: 0.0,
            open_delay_s: 0.0,
            close_delay_s: 0.0,
            torque_per_n_m: None,
        };
        let mut set = ThrusterSet {
            thrusters: vec![
                spec([l, 0.0, h], [0.0, 1.0, 0.0]),
                spec([-l, 0.0, h], [0.0, -1.0, 0.0]),
                spec([0.0, l, h], [-1.0, 0.0, 0.0]),
                spec([0.0, -l, h], [1.0, 0.0, 0.0]),
            ],
            failures: vec![],
            injected: vec![],
            cg_m: [0.0, 0.0, 0.0],
        };
        // By hand, r × F with r = (x, y, h): (y Fz - h Fy, h Fx - x Fz, x Fy - y Fx).
        let want = [[-h * f, 0.0, l * f], [h * f, 0.0, l * f], [0.0, -h * f, l * f], [0.0, h * f, l * f]];
        assert_eq!(set.torque_matrix(), want);
        // An opposite pair is a pure couple.
        let (force, torque) = set.wrench(&[1.0, 1.0, 0.0, 0.0]);
        assert_eq!((force, torque), ([0.0; 3], [0.0, 0.0, 2.0 * l * f]));
        // Moving the CG up to the ring plane removes the x/y components.
        set.cg_m = [0.0, 0.0, h];
        for c in set.torque_matrix() {
            assert!(c[0].abs() < 1e-15 && c[1].abs() < 1e-15 && c[2] == l * f);
        }
    }

    #[test]
    fn paper004_matrix() {
        let set = ThrusterSet::paper004(10.0);
        let b = set.torque_matrix();
        let k = 10.0 / 2f64.sqrt();
        assert!((b[0][0] - k * 0.73).abs() < 1e-12 && (b[3][0] + k * 0.43).abs() < 1e-12);
        assert!((b[1][1] + k * 0.43).abs() < 1e-12 && (b[7][2] + k * 0.73).abs() < 1e-12);
        let (f, t) = set.wrench(&[1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        assert_eq!(f, [0.0; 3]);
        assert_eq!(t, b[0]);
    }
}
