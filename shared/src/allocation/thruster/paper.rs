//! Paper 004 data: the 8-thruster layout (table 2) and modulator constants (table 3).

use super::lp::Allocator;
use super::pwpf::PwpfParams;

/// Radial arm `r` (m), table 2.
pub const R_ARM: f32 = 0.73;
/// Height from the centre of mass `d` (m), table 2.
pub const D_HEIGHT: f32 = 0.73;
/// The third moment-arm entry printed in table 2 (m).
pub const ARM_043: f32 = 0.43;

/// Table 2, per unit thrust (N·m per N):
/// `B = (1/√2) [[ r, 0, r, -0.43, -r, 0, -r, 0.43],
///              [ d, -0.43, -d, 0, -d, 0.43, d, 0],
///              [ d, -d, d, -d, d, -d, d, -d]]`,
/// times `thrust` (the paper does not print the thrust level).
pub fn paper_b(thrust: f32) -> [[f32; 8]; 3] {
    let k = thrust * core::f32::consts::FRAC_1_SQRT_2;
    let (r, d, e) = (R_ARM, D_HEIGHT, ARM_043);
    let rows = [[r, 0.0, r, -e, -r, 0.0, -r, e], [d, -e, -d, 0.0, -d, e, d, 0.0], [d, -d, d, -d, d, -d, d, -d]];
    let mut out = [[0.0f32; 8]; 3];
    for (o, row) in out.iter_mut().zip(rows.iter()) {
        for (x, v) in o.iter_mut().zip(row.iter()) {
            *x = k * v;
        }
    }
    out
}

/// The paper's allocator: 8 on/off thrusters, `u ∈ [0, 1]` (fraction of full thrust,
/// i.e. the PWPF duty-cycle command), moments in N·m for `thrust` N per thruster.
pub type PaperAllocator = Allocator<8, 9>;

pub fn paper_allocator(thrust: f32) -> PaperAllocator {
    Allocator::new(paper_b(thrust), [0.0; 8], [1.0; 8])
}

/// The paper's 8 thrusters in the first slots of an allocator built for `N ≥ 8` (the
/// firmware's capacity is 12): the other columns are zero with `u_max = 0`, i.e. not
/// fitted. Used to check that the spare capacity changes neither answer nor cost.
pub fn paper_allocator_in<const N: usize, const NP1: usize>(thrust: f32) -> Allocator<N, NP1> {
    let mut b = [[0.0f32; N]; 3];
    for (row, row8) in b.iter_mut().zip(paper_b(thrust).iter()) {
        for (x, v) in row.iter_mut().zip(row8.iter()) {
            *x = *v;
        }
    }
    let mut u_max = [0.0f32; N];
    for x in u_max.iter_mut().take(8) {
        *x = 1.0;
    }
    Allocator::new(b, [0.0; N], u_max)
}

/// Table 3: `Km = 4.5, Tm = 0.15 s, Uon = 0.45, Uoff = 0.15`, unit output.
pub const PAPER_PWPF: PwpfParams = PwpfParams { km: 4.5, tm: 0.15, u_on: 0.45, u_off: 0.15, u_m: 1.0 };
