//! k-of-n persistence: a test fires when at least `k` of the last `n` samples exceeded
//! their threshold.
//!
//! Why k-of-n and not one exceedance: a per-sample threshold at a false-alarm
//! probability `p` per sample fires every `1/p` samples on a healthy unit; requiring `k`
//! of `n` lowers that to the binomial tail `P(X ≥ k)`, `X ~ B(n, p)`, while a hard fault
//! (every sample exceeding) is still declared after exactly `k` samples. The window is the
//! bits of a `u32`, so the state is one word and a step costs a shift and a popcount.

pub use crate::params::fdir::{KOfN, MAX_WINDOW};

/// The bits of the last `n` outcomes; `None` for an invalid window.
fn mask(window: &KOfN) -> Option<u32> {
    if !window.valid() {
        return None;
    }
    // n in 1..=32: 2^n - 1 without overflow.
    u32::MAX.checked_shr(u32::from(MAX_WINDOW.saturating_sub(window.n)))
}

/// The window's state: the last outcomes, newest in bit 0.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Persistence {
    bits: u32,
}

impl Persistence {
    pub const fn new() -> Self {
        Self { bits: 0 }
    }

    /// Records one outcome (`true`: the sample exceeded its threshold) and returns whether
    /// at least `k` of the last `n` exceeded. An invalid window never fires (documented
    /// fallback; it cannot fly, the parameter-set check refuses it).
    pub fn push(&mut self, window: &KOfN, exceeded: bool) -> bool {
        let Some(mask) = mask(window) else { return false };
        self.bits = (self.bits.wrapping_shl(1) | u32::from(exceeded)) & mask;
        self.bits.count_ones() >= u32::from(window.k)
    }

    /// Exceedances among the last `n` samples (telemetry).
    pub fn count(&self) -> u32 {
        self.bits.count_ones()
    }

    /// Forgets every outcome (a unit re-enabled by the ground starts clean).
    pub fn clear(&mut self) {
        self.bits = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_hard_fault_fires_after_exactly_k_samples_and_a_cleared_window_starts_again() {
        for (k, n) in [(1u8, 1u8), (3, 10), (5, 5), (8, 32), (32, 32)] {
            let w = KOfN { k, n };
            let mut p = Persistence::default();
            let fired: Vec<bool> = (0..40).map(|_| p.push(&w, true)).collect();
            let first = fired.iter().position(|&f| f).unwrap();
            assert_eq!(first + 1, usize::from(k), "k {k} n {n}");
            assert!(fired[first..].iter().all(|&f| f));
            p.clear();
            assert_eq!(p.count(), 0);
            assert_eq!(p.push(&w, true), k == 1);
        }
    }

    #[test]
    fn exceedances_older_than_the_window_are_forgotten() {
        let w = KOfN { k: 2, n: 4 };
        let mut p = Persistence::default();
        assert!(!p.push(&w, true));
        for _ in 0..3 {
            assert!(!p.push(&w, false));
        }
        // The first exceedance is 4 samples old now: it leaves as this one enters.
        assert!(!p.push(&w, true));
        assert!(p.push(&w, true));
    }

    #[test]
    fn invalid_windows_never_fire_and_never_panic() {
        for (k, n) in [(0u8, 0u8), (0, 5), (6, 5), (1, 33), (255, 255)] {
            let w = KOfN { k, n };
            assert!(!w.valid());
            let mut p = Persistence::default();
            assert!((0..64).all(|_| !p.push(&w, true)), "k {k} n {n}");
        }
    }
}
