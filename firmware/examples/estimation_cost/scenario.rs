//! A fixed, seeded, pure-f32 estimation workload: the firmware example
//! (`firmware/examples/estimation_cost/main.rs`, on the Cortex-M4F under QEMU) and the host
//! test (`tests/tests/estimation_target.rs`) compile this same file, run it, and compare
//! the fingerprint of every output bit; the example also times each call.
//!
//! Workload (10 Hz gyro, `STEPS` filter steps in a repeating cycle of four):
//! propagate; propagate + tracker update; propagate; propagate + Sun + field updates —
//! then `WAHBA_CALLS` TRIAD (Sun, field) and QUEST (Sun, field, a third direction) solves
//! at varying attitudes. Inputs come from SplitMix64 and f32 `+ − × ÷ √` only, so both
//! machines generate the same numbers (Rust never contracts to FMA).

// nalgebra's vector/quaternion operators are float arithmetic (no overflow, no panic); the
// firmware's `arithmetic_side_effects` denial is meant for integers (the workspace's
// clippy.toml allows these types; the firmware project has no such file).
#![allow(clippy::arithmetic_side_effects)]

use acs_flight::estimation::mekf::{Mekf, MekfConfig, MekfError, CHI2_2DOF_999, CHI2_3DOF_999};
use acs_flight::estimation::quest::{quest, Observation};
use acs_flight::estimation::triad::{triad, WahbaError};
use acs_flight::math::f32m::sqrt;
use acs_flight::math::{quat_normalized, rotate_ref_to_body, Mat3, Quat, Vec3};

/// Filter steps (a multiple of 4: 1/2 propagate only, 1/4 with the tracker, 1/4 with vectors).
pub const STEPS: u32 = 400;
/// TRIAD and QUEST calls each.
pub const WAHBA_CALLS: u32 = 100;

/// What one timed call did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Propagate = 0,
    PropagateTracker = 1,
    PropagateSunField = 2,
    Triad = 3,
    Quest3 = 4,
}

pub const KINDS: [Kind; 5] =
    [Kind::Propagate, Kind::PropagateTracker, Kind::PropagateSunField, Kind::Triad, Kind::Quest3];

impl Kind {
    pub fn name(self) -> &'static str {
        match self {
            Kind::Propagate => "propagate",
            Kind::PropagateTracker => "propagate+tracker",
            Kind::PropagateSunField => "propagate+sun+field",
            Kind::Triad => "triad",
            Kind::Quest3 => "quest3",
        }
    }
}

/// Per-kind cost in counter ticks.
#[derive(Clone, Copy, Debug, Default)]
pub struct Cost {
    pub calls: u32,
    pub sum_ticks: u64,
    pub max_ticks: u32,
}

/// Result of one run: fingerprint of every output bit, per-kind costs (index = `Kind as usize`).
pub struct Outcome {
    pub fingerprint: u64,
    pub costs: [Cost; 5],
    /// Updates rejected by the gate (expected 0: the stream is consistent).
    pub rejected: u32,
}

struct Rng(u64);

impl Rng {
    fn u64(&mut self) -> u64 {
        // SplitMix64 (Steele, Lea & Flood 2014).
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [−1, 1): a 24-bit integer converts to f32 exactly.
    fn uniform(&mut self) -> f32 {
        let m = u32::try_from(self.u64() >> 40).unwrap_or(0);
        (m as f32) * (1.0 / 8_388_608.0) - 1.0
    }

    /// Roughly normal, unit variance: sum of three uniforms (variance 3 × 1/3).
    fn normal(&mut self) -> f32 {
        self.uniform() + self.uniform() + self.uniform()
    }

    fn vec(&mut self, sigma: f32) -> Vec3 {
        Vec3::new(self.normal() * sigma, self.normal() * sigma, self.normal() * sigma)
    }
}

fn unit(v: Vec3) -> Vec3 {
    let n = sqrt(v.norm_squared());
    if n > 0.0 {
        v / n
    } else {
        Vec3::x()
    }
}

/// `q ⊗ [φ/2, 1]`, normalised: a small rotation `φ` (body axes).
fn rotate(q: &Quat, phi: &Vec3) -> Quat {
    quat_normalized(&(q * Quat::new(1.0, 0.5 * phi.x, 0.5 * phi.y, 0.5 * phi.z))).unwrap_or(*q)
}

/// FNV-1a over 32-bit words.
struct Hash(u64);

impl Hash {
    fn word(&mut self, w: u32) {
        for b in w.to_le_bytes() {
            self.0 = (self.0 ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01B3);
        }
    }
    fn f(&mut self, x: f32) {
        self.word(x.to_bits());
    }
    fn quat(&mut self, q: &Quat) {
        for x in q.coords.iter() {
            self.f(*x);
        }
    }
    fn filter(&mut self, m: &Mekf) {
        self.quat(&m.attitude());
        for x in m.bias_rad_s().iter() {
            self.f(*x);
        }
        for x in m.covariance().iter() {
            self.f(*x);
        }
    }
    fn mekf_result(&mut self, r: Result<f32, MekfError>) {
        match r {
            Ok(nis) => {
                self.word(0);
                self.f(nis);
            }
            Err(MekfError::Rejected { nis }) => {
                self.word(1);
                self.f(nis);
            }
            Err(_) => self.word(2),
        }
    }
    fn wahba(&mut self, r: Result<Quat, WahbaError>) {
        match r {
            Ok(q) => self.quat(&q),
            Err(WahbaError::BadInput) => self.word(3),
            Err(WahbaError::Degenerate) => self.word(4),
        }
    }
}

fn timed(kind: Kind, t0: u32, t1: u32, costs: &mut [Cost; 5]) {
    if let Some(c) = costs.get_mut(kind as usize) {
        let dt = t1.wrapping_sub(t0);
        c.calls = c.calls.saturating_add(1);
        c.sum_ticks = c.sum_ticks.saturating_add(u64::from(dt));
        c.max_ticks = c.max_ticks.max(dt);
    }
}

pub fn config() -> MekfConfig {
    MekfConfig {
        gyro_arw_rad_sqrt_s: 3e-5,
        gyro_rrw_rad_s_sqrt_s: 3e-8,
        initial_attitude_sigma_rad: 0.02,
        initial_bias_sigma_rad_s: 2e-4,
        max_dt_s: 1.0,
        gate_attitude: CHI2_3DOF_999,
        gate_vector: CHI2_2DOF_999,
    }
}

/// Run the workload; `counter()` is read just before and after every timed call (the
/// host passes a constant: costs are then zero and only the fingerprint matters).
pub fn run<C: FnMut() -> u32>(mut counter: C) -> Outcome {
    let mut rng = Rng(0x5EED_0010);
    let mut hash = Hash(0xCBF2_9CE4_8422_2325);
    let mut costs = [Cost::default(); 5];
    let mut rejected = 0_u32;

    let dt = 0.1_f32;
    let sun_ref = unit(Vec3::new(0.6, 0.8, 0.1));
    let mag_ref = unit(Vec3::new(0.1, 0.3, -0.95));
    let third_ref = unit(Vec3::new(-0.7, 0.2, 0.4));
    let (sigma_sun, sigma_mag, sigma_third) = (0.0035_f32, 0.017_f32, 0.01_f32);
    let sigma_tracker = 4.85e-5_f32;
    let r_tracker = Mat3::identity() * (sigma_tracker * sigma_tracker);

    let mut q_true = quat_normalized(&Quat::new(0.5, 0.1, -0.7, 0.3)).unwrap_or_else(Quat::identity);
    let bias_true = Vec3::new(1e-4, -2e-4, 5e-5);
    let mut filter = match Mekf::new(config(), rotate(&q_true, &Vec3::new(0.01, -0.02, 0.015)), Vec3::zeros()) {
        Ok(f) => f,
        Err(_) => {
            hash.word(0xDEAD);
            return Outcome { fingerprint: hash.0, costs, rejected };
        }
    };

    for k in 0..STEPS {
        let w = Vec3::new(0.01, 0.005, -0.008) + rng.vec(1e-3);
        let gyro = w + bias_true + rng.vec(3e-5 / sqrt(dt));
        q_true = rotate(&q_true, &(w * dt));
        let kind = match k % 4 {
            1 => Kind::PropagateTracker,
            3 => Kind::PropagateSunField,
            _ => Kind::Propagate,
        };
        // Measurements prepared before the timed section.
        let q_meas = rotate(&q_true, &rng.vec(sigma_tracker));
        let sun_b = unit(rotate_ref_to_body(&q_true, &sun_ref) + rng.vec(sigma_sun));
        let mag_b = unit(rotate_ref_to_body(&q_true, &mag_ref) + rng.vec(sigma_mag));

        let t0 = counter();
        let p = filter.propagate(&gyro, dt).map(|()| 0.0);
        let (u1, u2) = match kind {
            Kind::PropagateTracker => (Some(filter.update_attitude(&q_meas, &r_tracker)), None),
            Kind::PropagateSunField => (
                Some(filter.update_vector(&sun_b, &sun_ref, sigma_sun)),
                Some(filter.update_vector(&mag_b, &mag_ref, sigma_mag)),
            ),
            _ => (None, None),
        };
        let t1 = counter();
        timed(kind, t0, t1, &mut costs);

        hash.mekf_result(p);
        for r in [u1, u2].into_iter().flatten() {
            if matches!(r, Err(MekfError::Rejected { .. })) {
                rejected = rejected.saturating_add(1);
            }
            hash.mekf_result(r);
        }
        hash.filter(&filter);
    }

    for _ in 0..WAHBA_CALLS {
        q_true = rotate(&q_true, &rng.vec(0.5));
        let obs = [
            Observation {
                body: unit(rotate_ref_to_body(&q_true, &sun_ref) + rng.vec(sigma_sun)),
                reference: sun_ref,
                sigma_rad: sigma_sun,
            },
            Observation {
                body: unit(rotate_ref_to_body(&q_true, &mag_ref) + rng.vec(sigma_mag)),
                reference: mag_ref,
                sigma_rad: sigma_mag,
            },
            Observation {
                body: unit(rotate_ref_to_body(&q_true, &third_ref) + rng.vec(sigma_third)),
                reference: third_ref,
                sigma_rad: sigma_third,
            },
        ];
        let t0 = counter();
        let t = triad(&obs[0].body, &obs[1].body, &obs[0].reference, &obs[1].reference);
        let t1 = counter();
        timed(Kind::Triad, t0, t1, &mut costs);
        hash.wahba(t);

        let t0 = counter();
        let q = quest(&obs);
        let t1 = counter();
        timed(Kind::Quest3, t0, t1, &mut costs);
        hash.wahba(q);
    }

    Outcome { fingerprint: hash.0, costs, rejected }
}
