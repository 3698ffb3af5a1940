//! Thruster control allocation for attitude control (paper 004).
//!
//! - [`simplex`]: a bounded-variable two-phase primal simplex on stack arrays
//!   (`min cᵀx, A x = b, 0 <= x <= h`, paper eq 11), deterministic anti-cycling
//!   pricing, documented iteration cap.
//! - [`lp`]: the allocators built on it, with one result type ([`AllocResult`](crate::allocation::AllocResult)):
//!   the paper's direction-preserving LP (eqs 12-18) plus a fuel stage, and Bodson's
//!   direction-preserving LP in its reduced, scaled-from-boundary form; rate limits
//!   folded into the bounds (eq 9) and a thruster-failure mask.
//! - `zonotope`: the exact geometric solve of the direction-preserving method and
//!   its fuel stage (facets of the attainable set), which [`lp`] tries first.
//! - [`pwpf`]: the pulse-width pulse-frequency modulator (paper fig 5, table 3).
//! - [`paper`]: the paper's 8-thruster effectiveness matrix (table 2) and constants.

pub mod lp;
pub mod paper;
pub mod pwpf;
pub mod simplex;
mod zonotope;

pub use lp::{Allocator, Failures, RateLimit};
pub use pwpf::{Pwpf, PwpfParams};
pub use simplex::{Basis, Fault, Lp, LpSolution, LpStatus, Pricing};

/// Per-call admissible thrust interval `[lo, hi]` (eq 8).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds<const N: usize> {
    pub lo: [f32; N],
    pub hi: [f32; N],
}
