//! A frozen or stuck output: a sensor whose components repeat their previous value,
//! sample after sample, while its time tags stay fresh.
//!
//! Why exact repeats: a live sensor's reading carries noise, so two consecutive
//! samples are equal only when the noise falls in the same quantisation step twice; a
//! frozen output (a hung interface re-sending its last buffer) or a stuck axis repeats
//! forever. Per component, so a stuck gyro axis is isolated as that axis.
//!
//! False alarm: for a constant true value with i.i.d. Gaussian noise quantised in steps,
//! `p_k` the probability of step `k`, a run of `r` repeats at a given sample has
//! probability `Σ_k p_k^(r+1)` (a moving true value makes repeats rarer: the constant one
//! is the worst case); docs/fdir.md gives `r` per sensor.

/// Components beyond this are not reported (the verdict is a `u32` bit mask).
pub const MAX_COMPONENTS: usize = 32;

/// Repeats of each of `N` components.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Repeats<const N: usize> {
    last: [f32; N],
    run: [u16; N],
    primed: bool,
}

impl<const N: usize> Default for Repeats<N> {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl<const N: usize> Repeats<N> {
    /// No sample seen yet.
    pub const EMPTY: Self = Self { last: [0.0; N], run: [0; N], primed: false };

    /// Records one fresh sample (call only for a sample with a new time tag) and returns
    /// the components that have now repeated their value more than `max_repeats` times in
    /// a row (bit `i`: component `i`).
    pub fn push(&mut self, max_repeats: u16, sample: &[f32; N]) -> u32 {
        let mut stuck = 0u32;
        let components = sample.iter().zip(self.last.iter_mut()).zip(self.run.iter_mut());
        for (i, ((x, last), run)) in components.enumerate() {
            // Equal values (+0 = -0); NaN after NaN repeats too (a hung buffer of NaN).
            let same = *x == *last || (x.is_nan() && last.is_nan());
            *run = if self.primed && same { run.saturating_add(1) } else { 0 };
            *last = *x;
            if *run > max_repeats {
                stuck |= u32::try_from(i).ok().and_then(|i| 1u32.checked_shl(i)).unwrap_or(0);
            }
        }
        self.primed = true;
        stuck
    }

    /// The components whose last sample repeated the one before (bit `i`: component `i`).
    pub fn repeating(&self) -> u32 {
        let bit = |i: usize| u32::try_from(i).ok().and_then(|i| 1u32.checked_shl(i)).unwrap_or(0);
        self.run.iter().enumerate().filter(|(_, r)| **r > 0).fold(0, |m, (i, _)| m | bit(i))
    }

    /// The longest current run over the components (telemetry).
    pub fn longest_run(&self) -> u16 {
        self.run.iter().copied().max().unwrap_or(0)
    }

    /// Forgets the history (a unit re-enabled by the ground starts clean).
    pub fn clear(&mut self) {
        *self = Self::default();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stuck_axis_is_named_after_max_repeats_plus_one_equal_samples() {
        let mut r = Repeats::<3>::default();
        let mut fired_at = None;
        for k in 0..20u16 {
            let live = f32::from(k) * 1e-3;
            let stuck = r.push(4, &[live, 0.25, -live]);
            if stuck != 0 && fired_at.is_none() {
                fired_at = Some((k, stuck));
            }
        }
        // Sample 0 sets the value; samples 1..=5 repeat it: the 5th repeat exceeds 4.
        assert_eq!(fired_at, Some((5, 0b010)));
        assert_eq!(r.longest_run(), 19);
        r.clear();
        assert_eq!(r.push(0, &[1.0, 1.0, 1.0]), 0, "a cleared monitor has no previous sample");
    }

    #[test]
    fn nan_repeats_nan_and_signed_zeros_are_one_value() {
        let mut r = Repeats::<3>::default();
        r.push(0, &[f32::NAN, 0.0, 1.0]);
        // NaN again repeats (a hung buffer of NaN is frozen); -0 after +0 is the same value.
        assert_eq!(r.push(0, &[f32::NAN, -0.0, 2.0]), 0b011);
    }
}
