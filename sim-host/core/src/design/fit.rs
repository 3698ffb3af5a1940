//! Bounded Nelder–Mead minimiser (used to identify the model behind paper 003 eq 35).

/// Minimise `f` from `x0` with initial simplex steps `step`; at most `max_iter` iterations,
/// stops when the spread of the simplex values is below `ftol`. Returns `(x, f(x))`.
pub fn nelder_mead(f: impl Fn(&[f64]) -> f64, x0: &[f64], step: &[f64], max_iter: usize, ftol: f64) -> (Vec<f64>, f64) {
    let n = x0.len();
    let mut s: Vec<(Vec<f64>, f64)> = (0..=n)
        .map(|i| {
            let mut x = x0.to_vec();
            if i > 0 {
                x[i - 1] += step[i - 1];
            }
            let fx = f(&x);
            (x, fx)
        })
        .collect();
    let comb = |a: &[f64], b: &[f64], t: f64| a.iter().zip(b).map(|(p, q)| p + t * (q - p)).collect::<Vec<f64>>();
    for _ in 0..max_iter {
        s.sort_by(|a, b| a.1.total_cmp(&b.1));
        if (s[n].1 - s[0].1).abs() <= ftol * (s[0].1.abs() + ftol) {
            break;
        }
        let cen: Vec<f64> = (0..n).map(|k| s[..n].iter().map(|p| p.0[k]).sum::<f64>() / n as f64).collect();
        let worst = s[n].0.clone();
        let xr = comb(&cen, &worst, -1.0);
        let fr = f(&xr);
        if fr < s[0].1 {
            let xe = comb(&cen, &worst, -2.0);
            let fe = f(&xe);
            s[n] = if fe < fr { (xe, fe) } else { (xr, fr) };
        } else if fr < s[n - 1].1 {
            s[n] = (xr, fr);
        } else {
            let xc = comb(&cen, &worst, 0.5);
            let fc = f(&xc);
            if fc < s[n].1 {
                s[n] = (xc, fc);
            } else {
                let best = s[0].0.clone();
                for p in s.iter_mut().skip(1) {
                    p.0 = comb(&best, &p.0, 0.5);
                    p.1 = f(&p.0);
                }
            }
        }
    }
    s.sort_by(|a, b| a.1.total_cmp(&b.1));
    s.swap_remove(0)
}
