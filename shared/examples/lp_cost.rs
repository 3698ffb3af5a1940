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
use acs_flight::allocation::thruster::paper::paper_b;
use acs_flight::allocation::thruster::{Allocator, Failures};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 4 {
        eprintln!("usage: lp_cost dp|bodson mx my mz [failed thruster ids, 1-based]");
        std::process::exit(2);
    }
    let num = |s: &String| s.parse::<f32>().unwrap_or_else(|_| panic!("not a number: {s}"));
    let m = [num(&args[1]), num(&args[2]), num(&args[3])];
    let failed: Vec<usize> = args[4..].iter().map(|s| s.parse().expect("thruster id")).collect();
    let b8 = paper_b(10.0);
    let mut b = [[0.0f32; 12]; 3];
    for (r, r8) in b.iter_mut().zip(b8.iter()) {
        r[..8].copy_from_slice(r8);
    }
    let mut u_max = [0.0f32; 12];
    u_max[..8].fill(1.0);
    let al = std::hint::black_box(Allocator::<12, 13>::new(b, [0.0; 12], u_max));
    let bd = al.bounds(None, Failures::off_1based(&failed));
    let r = match args[0].as_str() {
        "dp" => al.direction_preserving(std::hint::black_box(&m), &bd),
        "bodson" => al.bodson(std::hint::black_box(&m), &bd),
        other => panic!("unknown method {other}"),
    };
    println!("{:?} lambda {} iterations {} u {:?}", r.outcome.status, r.outcome.lambda, r.outcome.iterations, r.u);
}
