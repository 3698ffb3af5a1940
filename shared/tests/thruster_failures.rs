//! Failure tolerance of the paper-004 layout, computed from B (not from the paper's claim).
//!
//! Three-axis authority with failed-off thrusters F is kept iff 0 is in the interior
//! of Z_F = {B u : u ∈ [0,1]⁸, u_F = 0}, i.e. iff min over unit facet normals n of
//! h_Z(n) > 0 (this min is the inscribed radius = min over unit demand directions of
//! the max attainable |m|). Lost ⇔ min <= 1e-9 (N·m per N of thrust), or the
//! remaining columns do not span R³.
#![allow(clippy::needless_range_loop, clippy::collapsible_if)]
#[path = "thruster_common/mod.rs"]
mod common;
use acs_flight::allocation::AllocStatus;
use acs_flight::allocation::thruster::Failures;
use acs_flight::allocation::thruster::paper::paper_allocator;
use common::*;

fn authority(failed: &[usize]) -> (bool, f64, [f64; 3]) {
    let al = paper_allocator(1.0);
    let bd = al.bounds(None, Failures::off_1based(failed));
    let z = zonotope_of(al.b(), &bd);
    if !z.full_rank() {
        return (false, 0.0, [0.0; 3]);
    }
    let (r, n) = z.min_authority();
    (r > 1e-9, r, n)
}

#[test]
fn failure_table() {
    let (ok0, r0, _) = authority(&[]);
    assert!(ok0);
    println!("no failure: inscribed radius {r0:.4} N·m per N");
    let mut lost = [Vec::new(), Vec::new(), Vec::new()];
    let mut total = [0usize; 3];
    let mut min_kept = [f64::INFINITY; 3];
    let mut rows = Vec::new();
    for mask in 1u32..256 {
        let k = mask.count_ones() as usize;
        if k > 3 {
            continue;
        }
        let ids: Vec<usize> = (0..8).filter(|i| mask & (1 << i) != 0).map(|i| i + 1).collect();
        let (ok, r, n) = authority(&ids);
        total[k - 1] += 1;
        if ok {
            min_kept[k - 1] = min_kept[k - 1].min(r);
        } else {
            lost[k - 1].push((ids.clone(), n));
        }
        rows.push((ids, ok, r));
    }
    println!("failed (1-based) | 3-axis authority | inscribed radius (N·m/N)");
    for (ids, ok, r) in &rows {
        println!("{ids:?} | {} | {r:.4}", if *ok { "kept" } else { "LOST" });
    }
    for k in 0..3 {
        println!(
            "{}-thruster failures: {} of {} lose authority {:?}; smallest radius among survivors {:.4}",
            k + 1,
            lost[k].len(),
            total[k],
            lost[k].iter().map(|(v, _)| v.clone()).collect::<Vec<_>>(),
            min_kept[k]
        );
    }
    // {1, 3, 7}
    let (ok, r, n) = authority(&[1, 3, 7]);
    println!(
        "{{1,3,7}}: authority {}, inscribed radius {r:.4}, witness direction n = {n:.4?} (no remaining thruster has n·b_k > 0)",
        if ok { "kept" } else { "LOST" }
    );
    // {1, 4} (the paper's simulated case)
    let (ok14, r14, _) = authority(&[1, 4]);
    println!("{{1,4}}: authority {}, inscribed radius {r14:.4}", if ok14 { "kept" } else { "LOST" });
    assert!(ok14);
    assert!(!ok, "B says {{1,3,7}} keeps authority");

    // The LP agrees: along each lost case's witness direction the allocator gets λ = 0.
    let al = paper_allocator(1.0);
    for (ids, n) in lost.iter().flatten() {
        let bd = al.bounds(None, Failures::off_1based(ids));
        for bodson in [false, true] {
            let m = to_f32(n);
            let r = if bodson { al.bodson(&m, &bd) } else { al.direction_preserving(&m, &bd) };
            assert!(r.lambda.abs() < 1e-5, "{ids:?}: λ {} along the witness", r.lambda);
            assert!(r.u.iter().all(|v| *v >= 0.0) && ids.iter().all(|i| r.u[i - 1] == 0.0));
        }
    }
}

#[test]
fn failures_1_and_4_still_allocate() {
    let al = paper_allocator(1.0);
    let bd = al.bounds(None, Failures::off_1based(&[1, 4]));
    let z = zonotope_of(al.b(), &bd);
    let (radius, _) = z.min_authority();
    let mut worst = 0.0f64;
    let mut n = 0;
    for d in sphere(3000) {
        // any demand within the inscribed ball is attainable
        let m = to_f32(&[d[0] * radius * 0.99, d[1] * radius * 0.99, d[2] * radius * 0.99]);
        for bodson in [false, true] {
            let r = if bodson { al.bodson(&m, &bd) } else { al.direction_preserving(&m, &bd) };
            assert_eq!(r.status, AllocStatus::Ok, "{m:?}");
            assert_eq!((r.u[0], r.u[3]), (0.0, 0.0));
            assert_eq!(r.sat_low & 0b1001, 0b1001);
            assert_eq!(r.sat_high & 0b1001, 0b1001);
            worst = worst.max(r.shortfall.iter().map(|v| v.abs() as f64).fold(0.0, f64::max));
            n += 1;
        }
        // and beyond it, direction kept with λ from the oracle
        let m2 = [d[0] * 2.0, d[1] * 2.0, d[2] * 2.0];
        let r = al.direction_preserving(&to_f32(&m2), &bd);
        let w = z.dp_lambda(&m2).unwrap();
        assert!((r.lambda as f64 - w).abs() <= 1e-4 * w.max(1e-2));
    }
    println!(
        "failures {{1,4}}: inscribed radius {radius:.4}; {n} demands inside it all Ok, max |shortfall| {worst:.2e}"
    );
}

#[test]
fn stuck_on_thruster() {
    // Thruster 2 stuck on: the allocator compensates with the others.
    let al = paper_allocator(1.0);
    let bd = al.bounds(None, Failures { failed: 0b10, stuck_on: 0b10 });
    assert_eq!((bd.lo[1], bd.hi[1]), (1.0, 1.0));
    let z = zonotope_of(al.b(), &bd);
    let mut counts = [0usize; 3];
    for d in sphere(500) {
        let m = [d[0] * 0.2, d[1] * 0.2, d[2] * 0.2];
        for bodson in [false, true] {
            let r = if bodson { al.bodson(&to_f32(&m), &bd) } else { al.direction_preserving(&to_f32(&m), &bd) };
            assert_eq!(r.u[1], 1.0);
            let want = z.dp_lambda(&m);
            match r.status {
                AllocStatus::Ok => {
                    counts[0] += 1;
                    assert!(r.shortfall.iter().all(|v| v.abs() < 1e-5));
                }
                AllocStatus::Scaled => {
                    counts[1] += 1;
                    let w = want.unwrap();
                    assert!((r.lambda as f64 - w).abs() <= 1e-4 * w.max(1e-2));
                }
                AllocStatus::Infeasible => {
                    counts[2] += 1;
                    assert!(want.is_none());
                }
                s => panic!("{s:?}"),
            }
        }
    }
    println!("thruster 2 stuck on, |m| = 0.2: ok/scaled/infeasible = {counts:?}");
}
