//! The frequencies the experiments use: every one leakage-free (an integer number `m` of
//! periods in an integer number `n` of control steps, so the DFT over whole blocks of `n`
//! steps sees nothing of the other frequencies and of a constant), the log-spaced grid
//! from the crossover estimate up to the control Nyquist frequency, and where the next
//! refinement frequency goes (docs/margins.md, "Grid").

use super::analysis::{C64, zero_crossings};
use std::f64::consts::PI;

/// A leakage-free frequency: `m` periods in `n` control steps, `ω = 2π m / (n T)`, `m/n`
/// in lowest terms and `m/n ≤ 1/2` (`m/n = 1/2` is the Nyquist frequency).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Freq {
    pub m: u64,
    pub n: u64,
}

fn gcd(a: u64, b: u64) -> u64 {
    if b == 0 { a } else { gcd(b, a % b) }
}

impl Freq {
    pub fn rad_s(&self, dt: f64) -> f64 {
        2.0 * PI * self.m as f64 / (self.n as f64 * dt)
    }

    pub fn is_nyquist(&self) -> bool {
        2 * self.m == self.n
    }

    /// The leakage-free frequency closest to `w` (rad/s) with at most 64 periods per block:
    /// the first `m` whose nearest `n` is within 2·10⁻⁴ of `w`, else the closest found.
    pub fn near(w: f64, dt: f64) -> Freq {
        let mut best: Option<(f64, Freq)> = None;
        for m in 1..=64u64 {
            let n = ((2.0 * PI * m as f64 / (w * dt)).round() as u64).max(2 * m);
            let g = gcd(m, n);
            let f = Freq { m: m / g, n: n / g };
            let err = (f.rad_s(dt) / w - 1.0).abs();
            if best.is_none_or(|(e, _)| err < e) {
                best = Some((err, f));
            }
            if err < 2e-4 {
                break;
            }
        }
        best.map_or(Freq { m: 1, n: 2 }, |(_, f)| f)
    }

    /// The sample phase `ω t_k` of step k, reduced exactly with integers: `2π ((k m) mod n)/n`.
    pub fn phase(&self, k: u64) -> f64 {
        2.0 * PI * ((k % self.n) * self.m % self.n) as f64 / self.n as f64
    }
}

/// The lowest frequency of a grid asked to start at `lo` (at most half the Nyquist
/// frequency).
pub fn lowest(lo: f64, dt: f64) -> f64 {
    lo.min(PI / dt / 2.0)
}

/// `count` leakage-free frequencies log-spaced from `lo` to the Nyquist frequency `π/T`
/// (the last one exactly Nyquist), duplicates removed, ascending.
pub fn log_grid(lo: f64, count: usize, dt: f64) -> Vec<Freq> {
    let hi = PI / dt;
    let lo = lowest(lo, dt);
    let mut out: Vec<Freq> = (0..count)
        .map(|i| {
            if i + 1 == count {
                return Freq { m: 1, n: 2 };
            }
            let x = if count > 1 { i as f64 / (count - 1) as f64 } else { 0.0 };
            Freq::near(lo * (hi / lo).powf(x), dt)
        })
        .collect();
    out.sort_by(|a, b| a.rad_s(dt).total_cmp(&b.rad_s(dt)));
    out.dedup();
    out
}

/// The next frequency at which to measure so that a zero of `g` (sampled at ascending `w`)
/// is located better: the secant point (in `ln ω`) of each bracket `[w_k, w_k+1]` that is
/// still wider than `rel_width`. Returns rad/s values.
pub fn refine_zeros(w: &[f64], g: &[f64], rel_width: f64) -> Vec<f64> {
    zero_crossings(g)
        .into_iter()
        .filter(|(k, _)| w[k + 1] / w[*k] - 1.0 > rel_width)
        .map(|(k, f)| {
            // Keep the new point inside the bracket, away from its ends.
            let f = f.clamp(0.1, 0.9);
            (w[k].ln() + f * (w[k + 1].ln() - w[k].ln())).exp()
        })
        .collect()
}

/// The next frequency for a peak of `y` (sampled at ascending `w`): the vertex of the
/// parabola (in `ln ω`) through the largest sample and its neighbours, when it is farther
/// than `rel_width` from the nearest sample.
pub fn refine_peak(w: &[f64], y: &[f64], rel_width: f64) -> Option<f64> {
    let k = (0..y.len()).filter(|k| y[*k].is_finite()).max_by(|a, b| y[*a].total_cmp(&y[*b]))?;
    if k == 0 || k + 1 >= y.len() {
        return None;
    }
    let x = [w[k - 1].ln(), w[k].ln(), w[k + 1].ln()];
    let v = [y[k - 1], y[k], y[k + 1]];
    let d1 = (v[1] - v[0]) / (x[1] - x[0]);
    let d2 = (v[2] - v[1]) / (x[2] - x[1]);
    let curv = (d2 - d1) / (x[2] - x[0]);
    if curv >= 0.0 {
        return None;
    }
    let xv = (0.5 * (x[0] + x[1]) - d1 / (2.0 * curv)).clamp(x[0], x[2]);
    let wv = xv.exp();
    let nearest = w[k - 1..=k + 1].iter().map(|s| (wv / s - 1.0).abs()).fold(f64::INFINITY, f64::min);
    (nearest > rel_width).then_some(wv)
}

/// `ln |l|` of a loop, the function whose zeros are its crossovers.
pub fn log_gain(l: &[C64]) -> Vec<f64> {
    l.iter().map(|z| z.norm().ln()).collect()
}

/// `Im l / |l|` where `Re l < 0` (NaN elsewhere): zeros are phase crossings at −180°.
pub fn phase_sine(l: &[C64]) -> Vec<f64> {
    l.iter().map(|z| if z.re < 0.0 { z.im / z.norm() } else { f64::NAN }).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frequencies_are_leakage_free_and_close_to_the_request() {
        let dt = 0.1;
        for w in [0.003, 0.07, 1.0, 10.0, 25.0, 31.0] {
            let f = Freq::near(w, dt);
            assert!((f.rad_s(dt) / w - 1.0).abs() < 1e-3, "{w}: {f:?}");
            assert!(2 * f.m <= f.n);
            // A whole block of the sine sums to zero (no leakage into DC).
            let s: f64 = (0..f.n).map(|k| f.phase(k).sin()).sum();
            assert!(s.abs() < 1e-9, "{f:?}: {s}");
        }
        let g = log_grid(0.01, 40, dt);
        assert_eq!(*g.last().unwrap(), Freq { m: 1, n: 2 });
        assert!(g.windows(2).all(|p| p[0].rad_s(dt) < p[1].rad_s(dt)));
    }

    #[test]
    fn refinement_points_fall_inside_their_brackets() {
        let w = [1.0, 2.0, 4.0];
        let p = refine_zeros(&w, &[1.0, -1.0, -2.0], 1e-3);
        assert_eq!(p.len(), 1);
        assert!(p[0] > 1.0 && p[0] < 2.0);
        let v = refine_peak(&[1.0, 2.0, 4.0, 8.0], &[0.0, 1.0, 0.8, 0.1], 1e-3).unwrap();
        assert!(v > 1.0 && v < 4.0);
    }
}
