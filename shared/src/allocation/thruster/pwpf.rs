//! Pulse-width pulse-frequency (PWPF) modulator, paper 004 fig 5 / table 3.
//!
//! Per thruster: error `e = r - y`, first-order filter `Km / (Tm s + 1)` driven by
//! `e`, Schmitt trigger on the filter output `f`: `y = Um` once `f >= Uon`, `y = 0`
//! once `f <= Uoff`, unchanged in between. Thrusters are unidirectional, so the
//! trigger is one-sided and `r` is the normalised command `u / u_max ∈ [0, 1]`.
//!
//! Discretisation at step `dt` is exact for the filter under zero-order hold
//! (e is constant over a step): `f⁺ = a f + Km (1 - a) e`, `a = exp(-dt/Tm)`,
//! evaluated as `f⁺ = f + c (Km e - f)` with `c = 1 - a = -expm1(-dt/Tm)`: in f32,
//! `a` itself would lose the digits of `1 - a` for `dt << Tm` (a relative error of
//! ~1e-3 in the filter gain at dt = 1e-5 s), this form keeps the DC gain exactly Km.
//! The update is accumulated with Kahan compensation: for `dt << Tm` the increment
//! `c (Km e - f)` falls below half an ulp of `f` near the thresholds (at dt = 1e-5 s
//! a plain f32 filter stalls ~2e-4 below `Uon` and the off times drift by several
//! steps); the compensation term carries the lost low-order bits.
//! The trigger is evaluated at the sample instants, so every switching time is
//! quantised to the sample grid (each on/off time measured in whole steps, error
//! `< dt` per switch).
//!
//! Closed forms (continuous time, constant input `E`, `h = Uon - Uoff`), e.g.
//! Wie, *Space Vehicle Dynamics and Control*, §7 (PWPF):
//! - dead zone `E_d = Uon / Km` (no pulse for `E <= E_d`),
//! - saturation `E_s = Um + Uoff / Km` (always on for `E >= E_s`),
//! - on time `T_on = -Tm ln(1 - h / (Uon + Km (Um - E)))`,
//! - off time `T_off = -Tm ln(1 - h / (Km E - Uoff))`,
//! - duty cycle `T_on / (T_on + T_off)`, pulse frequency `1 / (T_on + T_off)`,
//! - minimum pulse width (E → E_d⁺) `Δ = -Tm ln(1 - h / (Km Um))`.

use libm::{expm1f, logf};

/// Modulator constants.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PwpfParams {
    /// Filter gain `Km`.
    pub km: f32,
    /// Filter time constant `Tm` (s).
    pub tm: f32,
    /// Trigger on level `Uon`.
    pub u_on: f32,
    /// Trigger off level `Uoff`.
    pub u_off: f32,
    /// Output level `Um` (1: full thrust, normalised).
    pub u_m: f32,
}

/// Inputs are clamped to `±INPUT_LIMIT · Um` (anything beyond is saturation anyway;
/// keeps the filter state finite for any finite input).
pub const INPUT_LIMIT: f32 = 10.0;

impl PwpfParams {
    /// All finite, `Km, Tm, Um > 0`, `Uon > Uoff`, `Uon > 0`.
    pub fn is_valid(&self) -> bool {
        let all_finite = [self.km, self.tm, self.u_on, self.u_off, self.u_m].iter().all(|v| v.is_finite());
        all_finite && self.km > 0.0 && self.tm > 0.0 && self.u_m > 0.0 && self.u_on > self.u_off && self.u_on > 0.0
    }
    /// Hysteresis width `h = Uon - Uoff`.
    pub fn hysteresis(&self) -> f32 {
        self.u_on - self.u_off
    }
    /// Dead zone `Uon / Km`.
    pub fn dead_zone(&self) -> f32 {
        self.u_on / self.km
    }
    /// Saturation level `Um + Uoff / Km`.
    pub fn saturation(&self) -> f32 {
        self.u_m + self.u_off / self.km
    }
    /// Minimum pulse width `-Tm ln(1 - h / (Km Um))`.
    pub fn min_pulse_width(&self) -> f32 {
        -self.tm * logf(1.0 - self.hysteresis() / (self.km * self.u_m))
    }
    /// Static on time for input `e` in `(dead_zone, saturation)`; NaN outside.
    pub fn on_time(&self, e: f32) -> f32 {
        if !(e > self.dead_zone() && e < self.saturation()) {
            return f32::NAN;
        }
        -self.tm * logf(1.0 - self.hysteresis() / (self.u_on + self.km * (self.u_m - e)))
    }
    /// Static off time for input `e` in `(dead_zone, saturation)`; NaN outside.
    pub fn off_time(&self, e: f32) -> f32 {
        if !(e > self.dead_zone() && e < self.saturation()) {
            return f32::NAN;
        }
        -self.tm * logf(1.0 - self.hysteresis() / (self.km * e - self.u_off))
    }
    /// Static duty cycle: 0 below the dead zone, 1 at/above saturation.
    pub fn duty_cycle(&self, e: f32) -> f32 {
        if !(e > self.dead_zone()) {
            return 0.0;
        }
        if e >= self.saturation() {
            return 1.0;
        }
        let on = self.on_time(e);
        on / (on + self.off_time(e))
    }
    /// Static pulse frequency (Hz): 0 outside `(dead_zone, saturation)`.
    pub fn frequency(&self, e: f32) -> f32 {
        if !(e > self.dead_zone() && e < self.saturation()) {
            return 0.0;
        }
        1.0 / (self.on_time(e) + self.off_time(e))
    }
}

/// `N` independent modulators (`N <= 32`, outputs as a bitmask).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pwpf<const N: usize> {
    p: PwpfParams,
    dt: f32,
    /// `c = 1 - exp(-dt/Tm)`.
    c: f32,
    f: [f32; N],
    /// Kahan compensation of `f` (lost low-order part, negated).
    comp: [f32; N],
    on: u32,
}

impl<const N: usize> Pwpf<N> {
    const DIMS_OK: () = assert!(N >= 1 && N <= 32, "Pwpf<N>: 1 <= N <= 32");

    /// `None` if the parameters are invalid or `dt` is not finite and positive.
    pub fn new(p: PwpfParams, dt: f32) -> Option<Self> {
        #[allow(clippy::let_unit_value)]
        let () = Self::DIMS_OK;
        if !(p.is_valid() && dt > 0.0 && dt.is_finite()) {
            return None;
        }
        let c = -expm1f(-dt / p.tm); // 1 - a, accurate for small dt/Tm
        if !(c.is_finite() && c > 0.0) {
            return None;
        }
        Some(Self { p, dt, c, f: [0.0; N], comp: [0.0; N], on: 0 })
    }

    pub fn params(&self) -> &PwpfParams {
        &self.p
    }
    pub fn dt(&self) -> f32 {
        self.dt
    }
    /// Filter outputs `f`.
    pub fn filter(&self) -> &[f32; N] {
        &self.f
    }
    /// Current on/off bitmask.
    pub fn state(&self) -> u32 {
        self.on
    }
    pub fn reset(&mut self) {
        self.f = [0.0; N];
        self.comp = [0.0; N];
        self.on = 0;
    }

    /// One step: returns the on/off bitmask to apply over `[t_k, t_k + dt)`, then
    /// advances the filters with the commands `r` (normalised, non-finite → 0,
    /// clamped to `±INPUT_LIMIT·Um`).
    pub fn step(&mut self, r: &[f32; N]) -> u32 {
        let mut mask = 0u32;
        let lim = INPUT_LIMIT * self.p.u_m;
        for (i, ((f, comp), ri)) in self.f.iter_mut().zip(self.comp.iter_mut()).zip(r.iter()).enumerate() {
            let bit = super::lp::bit_of(i);
            let was_on = self.on & bit != 0;
            let on = if *f >= self.p.u_on {
                true
            } else if *f <= self.p.u_off {
                false
            } else {
                was_on
            };
            let y = if on { self.p.u_m } else { 0.0 };
            let rin = if ri.is_finite() { super::simplex::clampf(*ri, -lim, lim) } else { 0.0 };
            // Kahan: f += c (Km e - f)
            let inc = self.c * (self.p.km * (rin - y) - *f) - *comp;
            let next = *f + inc;
            let lost = (next - *f) - inc;
            if next.is_finite() && lost.is_finite() {
                *comp = lost;
                *f = next;
            } else {
                *comp = 0.0;
                *f = 0.0;
            }
            if on {
                mask |= bit;
            }
        }
        self.on = mask;
        mask
    }
}
