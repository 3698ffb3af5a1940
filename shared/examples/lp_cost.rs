//! Host cost probe of one thruster allocation (paper 004 layout in the flight
//! software's 12-thruster capacity, 10 N thrusters), for `valgrind --tool=callgrind`:
//!
//! ```text
//! cargo build --release -p acs-flight --example lp_cost
//! valgrind --tool=callgrind --callgrind-out-file=/tmp/cg.out \
//!     --toggle-collect='*Allocator*direction_preserving*' \
//!     target/release/examples/lp_cost dp 0.3575 1.7206 -17.108 [failed thrusters, 1-based]
//! callgrind_annotate /tmp/cg.out | head
//! ```
//!
//! (`bodson` instead of `dp` for Bodson's method; toggle on `*Allocator*bodson*`.)
//! Prints the status, λ, LP iterations and commands of the call.
//!
//! `lp_cost sweep-dp|sweep-bodson [failed ids]` runs the method over a fixed set of
//! 4000 demands (seeded random directions, magnitudes 1e-3..1e3 N m) and prints the
//! worst and mean LP iterations; under callgrind, instructions / 4000 is the mean cost.
use acs_flight::allocation::thruster::paper::paper_allocator_in;
use acs_flight::allocation::thruster::{Allocator, Failures};
use acs_test_support::rng::Lcg64;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 4 && !args.first().is_some_and(|a| a.starts_with("sweep-")) {
        eprintln!("usage: lp_cost dp|bodson mx my mz [failed thruster ids, 1-based]");
        std::process::exit(2);
    }
    if let Some(method) = args[0].strip_prefix("sweep-") {
        return sweep(if method == "dp" { "dp" } else { "bodson" }, &args[1..]);
    }
    let num = |s: &String| s.parse::<f32>().unwrap_or_else(|_| panic!("not a number: {s}"));
    let m = [num(&args[1]), num(&args[2]), num(&args[3])];
    let failed: Vec<usize> = args[4..].iter().map(|s| s.parse().expect("thruster id")).collect();
    let al = allocator();
    let bd = al.bounds(None, Failures::off_1based(&failed));
    let r = match args[0].as_str() {
        "dp" => al.direction_preserving(std::hint::black_box(&m), &bd),
        "bodson" => al.bodson(std::hint::black_box(&m), &bd),
        other => panic!("unknown method {other}"),
    };
    println!("{:?} lambda {} iterations {} u {:?}", r.outcome.status, r.outcome.lambda, r.outcome.iterations, r.u);
}

fn sweep(method: &str, failed: &[String]) {
    let failed: Vec<usize> = failed.iter().map(|s| s.parse().expect("thruster id")).collect();
    let al = allocator();
    let bd = al.bounds(None, Failures::off_1based(&failed));
    let mut lcg = Lcg64(0x1234_5678_9abc_def0);
    let mut rnd = || lcg.symmetric();
    let (mut worst, mut sum, n) = (0u16, 0u64, 4000);
    for _ in 0..n {
        let d = [rnd(), rnd(), rnd()];
        let mag = 10f64.powf(3.0 * rnd());
        let m = d.map(|x| (x * mag) as f32);
        let r = if method == "dp" { al.direction_preserving(&m, &bd) } else { al.bodson(&m, &bd) };
        worst = worst.max(r.outcome.iterations);
        sum += u64::from(r.outcome.iterations);
    }
    println!("{method} over {n} demands: worst {worst} LP iterations, mean {:.2}", sum as f64 / n as f64);
}

fn allocator() -> Allocator<12, 13> {
    std::hint::black_box(paper_allocator_in(10.0))
}
