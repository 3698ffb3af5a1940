//! Statistics of a campaign: sample moments and quantiles, and one-sided lower
//! confidence bounds on a success probability from `k` successes in `n` trials.

/// Mean, sample standard deviation (n − 1), quantiles of a sample.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Moments {
    pub n: usize,
    pub mean: f64,
    pub sd: f64,
    pub min: f64,
    pub p50: f64,
    pub p95: f64,
    pub p99: f64,
    pub max: f64,
}

/// Quantile `p` of ascending-sorted `xs` by linear interpolation between order statistics
/// at rank `p (n − 1)` (Hyndman & Fan type 7, the default of R and NumPy).
pub fn quantile_sorted(xs: &[f64], p: f64) -> f64 {
    match xs.len() {
        0 => f64::NAN,
        1 => xs[0],
        n => {
            let h = p.clamp(0.0, 1.0) * (n - 1) as f64;
            let lo = h.floor() as usize;
            let hi = (lo + 1).min(n - 1);
            xs[lo] + (h - lo as f64) * (xs[hi] - xs[lo])
        }
    }
}

/// Moments of `xs` (in the given order: sums run in that order, so the same sample in the
/// same order gives the same bits). `None` for an empty sample.
pub fn moments(xs: &[f64]) -> Option<Moments> {
    let n = xs.len();
    if n == 0 {
        return None;
    }
    let mean = xs.iter().sum::<f64>() / n as f64;
    let sd = if n > 1 { (xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt() } else { 0.0 };
    let mut s = xs.to_vec();
    s.sort_by(f64::total_cmp);
    Some(Moments {
        n,
        mean,
        sd,
        min: s[0],
        p50: quantile_sorted(&s, 0.5),
        p95: quantile_sorted(&s, 0.95),
        p99: quantile_sorted(&s, 0.99),
        max: s[n - 1],
    })
}

/// `ln C(n, j)` for `j = 0..=n` by the recurrence `C(n, j) = C(n, j−1) (n − j + 1) / j`.
fn ln_binomials(n: u64) -> Vec<f64> {
    let mut out = Vec::with_capacity(n as usize + 1);
    let mut c = 0.0;
    out.push(c);
    for j in 1..=n {
        c += ((n - j + 1) as f64).ln() - (j as f64).ln();
        out.push(c);
    }
    out
}

/// `P(X >= k)` for `X ~ Binomial(n, p)`, summed in the log domain.
fn upper_tail(ln_c: &[f64], n: u64, k: u64, p: f64) -> f64 {
    if k == 0 {
        return 1.0;
    }
    if p <= 0.0 {
        return 0.0;
    }
    if p >= 1.0 {
        return 1.0;
    }
    let (lp, lq) = (p.ln(), (-p).ln_1p());
    let terms: Vec<f64> = (k..=n).map(|j| ln_c[j as usize] + j as f64 * lp + (n - j) as f64 * lq).collect();
    let m = terms.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    (m + terms.iter().map(|t| (t - m).exp()).sum::<f64>().ln()).exp()
}

/// Clopper–Pearson (exact) one-sided lower bound on the success probability after `k`
/// successes in `n` trials at `confidence`: the `p` with `P(X >= k | p) = 1 − confidence`
/// (0 when `k = 0`; `(1 − confidence)^(1/n)` when `k = n`). Found by bisection on the
/// binomial tail, which increases with `p`.
pub fn clopper_pearson_lower(k: u64, n: u64, confidence: f64) -> f64 {
    if n == 0 || k == 0 {
        return 0.0;
    }
    let alpha = 1.0 - confidence;
    let ln_c = ln_binomials(n);
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if upper_tail(&ln_c, n, k.min(n), mid) < alpha { lo = mid } else { hi = mid }
    }
    0.5 * (lo + hi)
}

/// Wilson score one-sided lower bound (Wilson 1927) at `confidence`.
pub fn wilson_lower(k: u64, n: u64, confidence: f64) -> f64 {
    if n == 0 {
        return 0.0;
    }
    let (nf, z) = (n as f64, normal_quantile(confidence));
    let p = k as f64 / nf;
    let z2 = z * z;
    let centre = p + z2 / (2.0 * nf);
    let half = z * (p * (1.0 - p) / nf + z2 / (4.0 * nf * nf)).sqrt();
    ((centre - half) / (1.0 + z2 / nf)).max(0.0)
}

/// Runs needed with no failure for the Clopper–Pearson bound to reach `p` at `confidence`:
/// the smallest `n` with `(1 − confidence)^(1/n) >= p`.
pub fn runs_to_demonstrate(p: f64, confidence: f64) -> Option<u64> {
    (p < 1.0).then(|| ((1.0 - confidence).ln() / p.ln()).ceil() as u64)
}

/// The standard normal quantile `Φ⁻¹(p)` (Acklam's rational approximation, relative
/// error < 1.2e-9).
pub fn normal_quantile(p: f64) -> f64 {
    if p <= 0.0 {
        return f64::NEG_INFINITY;
    }
    if p >= 1.0 {
        return f64::INFINITY;
    }
    const A: [f64; 6] = [
        -3.969683028665376e1,
        2.209460984245205e2,
        -2.759285104469687e2,
        1.383_577_518_672_69e2,
        -3.066479806614716e1,
        2.506628277459239,
    ];
    const B: [f64; 5] =
        [-5.447609879822406e1, 1.615858368580409e2, -1.556989798598866e2, 6.680131188771972e1, -1.328068155288572e1];
    const C: [f64; 6] = [
        -7.784894002430293e-3,
        -3.223964580411365e-1,
        -2.400758277161838,
        -2.549732539343734,
        4.374664141464968,
        2.938163982698783,
    ];
    const D: [f64; 4] = [7.784695709041462e-3, 3.224671290700398e-1, 2.445134137142996, 3.754408661907416];
    let tail = |q: f64| {
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    if p < 0.02425 {
        tail((-2.0 * p.ln()).sqrt())
    } else if p > 1.0 - 0.02425 {
        -tail((-2.0 * (1.0 - p).ln()).sqrt())
    } else {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_match_the_closed_form_of_an_arithmetic_sequence() {
        let xs: Vec<f64> = (0..=100).map(f64::from).collect();
        for p in [0.0, 0.5, 0.95, 0.99, 1.0] {
            assert!((quantile_sorted(&xs, p) - 100.0 * p).abs() < 1e-12);
        }
        // Type 7 between order statistics: [1, 2, 3, 4] at 0.5 -> 2.5, at 0.9 -> 3.7.
        let ys = [1.0, 2.0, 3.0, 4.0];
        assert!((quantile_sorted(&ys, 0.5) - 2.5).abs() < 1e-15);
        assert!((quantile_sorted(&ys, 0.9) - 3.7).abs() < 1e-12);
        let m = moments(&[2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0]).unwrap();
        assert!((m.mean - 5.0).abs() < 1e-15);
        assert!((m.sd - (32.0f64 / 7.0).sqrt()).abs() < 1e-14);
    }

    #[test]
    fn clopper_pearson_matches_closed_forms_and_tables() {
        // k = n: the bound is (1 - c)^(1/n).
        for (n, c) in [(10u64, 0.95), (299, 0.95), (1000, 0.99)] {
            let want = (1.0f64 - c).powf(1.0 / n as f64);
            assert!((clopper_pearson_lower(n, n, c) - want).abs() < 1e-12, "n={n}");
        }
        assert_eq!(clopper_pearson_lower(0, 50, 0.95), 0.0);
        // k = 1: P(X >= 1) = 1 - (1-p)^n = alpha  ->  p = 1 - (1 - alpha)^(1/n).
        let want = 1.0 - 0.95f64.powf(1.0 / 20.0);
        assert!((clopper_pearson_lower(1, 20, 0.95) - want).abs() < 1e-12);
        // Published two-sided 95 % exact interval for 5/10 is (0.1871, 0.8129): its lower
        // end is the one-sided 97.5 % bound.
        assert!((clopper_pearson_lower(5, 10, 0.975) - 0.187_086).abs() < 1e-5);
    }

    #[test]
    fn wilson_and_the_normal_quantile() {
        assert!((normal_quantile(0.975) - 1.959_963_984_540_054).abs() < 1e-8);
        assert!((normal_quantile(0.95) - 1.644_853_626_951_472).abs() < 1e-8);
        assert!((normal_quantile(0.001) + 3.090_232_306_167_813).abs() < 1e-8);
        // Wilson 95 % two-sided for 5/10: (0.2366, 0.7634) -> one-sided 97.5 % lower.
        assert!((wilson_lower(5, 10, 0.975) - 0.236_593).abs() < 1e-5);
        // Wilson is never below Clopper-Pearson at k = n by much, and both grow with n.
        assert!(wilson_lower(100, 100, 0.95) > clopper_pearson_lower(100, 100, 0.95));
        assert_eq!(runs_to_demonstrate(0.99, 0.95), Some(299));
    }
}
