//! Which rows of a run the replay page carries (docs/viewer.md, "Decimation"): every row
//! when they fit the bound, else the rows on both sides of every change of a step channel
//! (mode, eclipse, status, valves…), the first and last row of the run and, over equal
//! buckets of consecutive rows, each bucket's first and last row and the rows holding the
//! minimum and the maximum of every other channel. The bucket count is the largest a
//! bisection finds whose selection fits the bound, so the page's plots show the same
//! envelope as the full series at the bucket resolution, every transition at its exact
//! time and every extreme at its exact value.

/// The rows kept, ascending, and what it took.
#[derive(Clone, Debug, PartialEq)]
pub struct Selection {
    pub rows: Vec<usize>,
    /// Buckets of the extreme search (0: every row kept).
    pub buckets: usize,
    /// Rows kept because a step channel changed there (before or after the change).
    pub transition_rows: usize,
    /// Transition rows that did not fit in half the bound (counted, shown on the page).
    pub transition_rows_dropped: usize,
}

/// Two recorded values that are the same step level (bits; any NaN equals any NaN).
fn same_level(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

/// The rows on both sides of every change of any step channel, ascending, at most `cap`
/// (the earliest), and how many were left out.
fn transition_rows(n: usize, steps: &[&[f64]], cap: usize) -> (Vec<usize>, usize) {
    let mut mark = vec![false; n];
    for s in steps {
        for i in 1..n.min(s.len()) {
            if !same_level(s[i - 1], s[i]) {
                mark[i - 1] = true;
                mark[i] = true;
            }
        }
    }
    let all: Vec<usize> = (0..n).filter(|&i| mark[i]).collect();
    let dropped = all.len().saturating_sub(cap);
    (all.into_iter().take(cap).collect(), dropped)
}

/// Marks each bucket's first and last row and the rows of the minimum and maximum of every
/// signal (NaN ignored) over `buckets` equal buckets of `0..n`.
fn mark_buckets(n: usize, signals: &[&[f64]], buckets: usize, mark: &mut [bool]) {
    for b in 0..buckets {
        let (lo, hi) = (b * n / buckets, (b + 1) * n / buckets);
        if lo >= hi {
            continue;
        }
        mark[lo] = true;
        mark[hi - 1] = true;
        for s in signals {
            let (mut imin, mut imax) = (None::<usize>, None::<usize>);
            for i in lo..hi.min(s.len()) {
                let x = s[i];
                if x.is_nan() {
                    continue;
                }
                if imin.is_none_or(|j| x < s[j]) {
                    imin = Some(i);
                }
                if imax.is_none_or(|j| x > s[j]) {
                    imax = Some(i);
                }
            }
            for i in [imin, imax].into_iter().flatten() {
                mark[i] = true;
            }
        }
    }
}

/// The rows kept with `buckets` buckets over the fixed rows.
fn with_buckets(n: usize, fixed: &[usize], signals: &[&[f64]], buckets: usize) -> Vec<usize> {
    let mut mark = vec![false; n];
    for &i in fixed {
        mark[i] = true;
    }
    mark_buckets(n, signals, buckets, &mut mark);
    (0..n).filter(|&i| mark[i]).collect()
}

/// At most `max_rows` rows of `n` (`max_rows` ≥ 4 + 4 × signals, so one bucket always
/// fits beside the transitions, which take at most half of it).
pub fn select(n: usize, steps: &[&[f64]], signals: &[&[f64]], max_rows: usize) -> Selection {
    if n <= max_rows {
        return Selection { rows: (0..n).collect(), buckets: 0, transition_rows: 0, transition_rows_dropped: 0 };
    }
    let (mut fixed, dropped) = transition_rows(n, steps, max_rows / 2);
    let transition_rows = fixed.len();
    fixed.extend([0, n - 1]);
    // Each bucket adds at least its first row and at most 2 + 2 per signal: a bucket count
    // below `lo` always fits, one above `hi` never does.
    let per_bucket = 2 + 2 * signals.len();
    let room = max_rows.saturating_sub(fixed.len());
    let (mut lo, mut hi) = ((room / per_bucket).max(1), room.max(1));
    let mut best = with_buckets(n, &fixed, signals, lo);
    if best.len() > max_rows {
        // Only when the bound is below the documented minimum: the transitions alone.
        fixed.sort_unstable();
        fixed.dedup();
        fixed.truncate(max_rows);
        return Selection { rows: fixed, buckets: 0, transition_rows, transition_rows_dropped: dropped };
    }
    let mut buckets = lo;
    while lo < hi {
        let mid = lo + (hi - lo).div_ceil(2);
        let rows = with_buckets(n, &fixed, signals, mid);
        if rows.len() <= max_rows {
            (lo, best, buckets) = (mid, rows, mid);
        } else {
            hi = mid - 1;
        }
    }
    Selection { rows: best, buckets, transition_rows, transition_rows_dropped: dropped }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A long series: a mode that steps at irregular rows, a noisy signal with one spike
    /// and one dip, a ramp, and a signal that is NaN for a stretch.
    fn series(n: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>) {
        let mode: Vec<f64> = (0..n).map(|i| [1.0, 5.0, 2.0, 4.0, 3.0, 4.0][(i * 7 / n + i / 99_991) % 6]).collect();
        let mut rng = acs_test_support::rng::SplitMix64(7);
        let mut noisy: Vec<f64> = (0..n).map(|_| rng.normal()).collect();
        noisy[123_457] = 50.0;
        noisy[987_651] = -40.0;
        let ramp: Vec<f64> = (0..n).map(|i| i as f64).collect();
        let gappy: Vec<f64> =
            (0..n).map(|i| if (1000..5000).contains(&i) { f64::NAN } else { (i as f64).sin() }).collect();
        (mode, noisy, ramp, gappy)
    }

    #[test]
    fn short_runs_keep_every_row() {
        let x = [1.0, 2.0, 3.0];
        let s = select(3, &[&x], &[&x], 3);
        assert_eq!(s.rows, vec![0, 1, 2]);
        assert_eq!(s.buckets, 0);
    }

    #[test]
    fn transitions_extremes_and_bound_are_kept() {
        let n = 1_200_000;
        let (mode, noisy, ramp, gappy) = series(n);
        let max_rows = 20_000;
        let s = select(n, &[&mode], &[&noisy, &ramp, &gappy], max_rows);
        assert!(s.rows.len() <= max_rows, "{} rows", s.rows.len());
        // The bisection uses the room: at least half of the bound.
        assert!(s.rows.len() > max_rows / 2, "{} rows", s.rows.len());
        assert!(s.rows.windows(2).all(|w| w[0] < w[1]));
        assert_eq!((s.rows[0], *s.rows.last().unwrap()), (0, n - 1));
        // Every change of the mode: both rows present (independent scan of the input).
        let kept: std::collections::HashSet<usize> = s.rows.iter().copied().collect();
        let mut changes = 0;
        for i in 1..n {
            if mode[i] != mode[i - 1] {
                changes += 1;
                assert!(kept.contains(&(i - 1)) && kept.contains(&i), "transition at row {i} lost");
            }
        }
        assert!(changes > 10);
        assert_eq!(s.transition_rows_dropped, 0);
        // The mode sequence read from the kept rows has every level change of the full one.
        let levels = |rows: &mut dyn Iterator<Item = usize>| {
            let mut v: Vec<f64> = Vec::new();
            for i in rows {
                if v.last() != Some(&mode[i]) {
                    v.push(mode[i]);
                }
            }
            v
        };
        assert_eq!(levels(&mut (0..n)), levels(&mut s.rows.iter().copied()));
        // Global extremes of every signal, exactly.
        for sig in [&noisy, &ramp, &gappy] {
            let fin = |v: &mut dyn Iterator<Item = f64>| {
                v.filter(|x| !x.is_nan()).fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| (a.min(x), b.max(x)))
            };
            assert_eq!(fin(&mut sig.iter().copied()), fin(&mut s.rows.iter().map(|&i| sig[i])));
        }
        assert!(kept.contains(&123_457) && kept.contains(&987_651));
        // No gap between kept rows longer than a bucket.
        let bucket = n.div_ceil(s.buckets);
        assert!(s.rows.windows(2).all(|w| w[1] - w[0] <= bucket), "bucket {bucket}");
    }

    #[test]
    fn the_envelope_of_every_bucket_is_kept() {
        let n = 300_000;
        let (_, noisy, _, _) = series(n.max(1_000_000));
        let noisy = &noisy[..n];
        let s = select(n, &[], &[noisy], 3_000);
        assert!(s.buckets > 0);
        let kept: std::collections::HashSet<usize> = s.rows.iter().copied().collect();
        for b in 0..s.buckets {
            let (lo, hi) = (b * n / s.buckets, (b + 1) * n / s.buckets);
            let max_full = noisy[lo..hi].iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let min_full = noisy[lo..hi].iter().copied().fold(f64::INFINITY, f64::min);
            let in_bucket: Vec<f64> = (lo..hi).filter(|i| kept.contains(i)).map(|i| noisy[i]).collect();
            assert_eq!(in_bucket.iter().copied().fold(f64::NEG_INFINITY, f64::max), max_full);
            assert_eq!(in_bucket.iter().copied().fold(f64::INFINITY, f64::min), min_full);
        }
    }

    #[test]
    fn too_many_transitions_are_capped_and_counted() {
        let n = 10_000;
        let flicker: Vec<f64> = (0..n).map(|i| (i % 2) as f64).collect();
        let s = select(n, &[&flicker], &[], 1_000);
        assert!(s.rows.len() <= 1_000);
        assert_eq!(s.transition_rows, 500);
        assert_eq!(s.transition_rows_dropped, n - 500);
    }
}
