//! GNSS receiver: position, velocity and time fixes.
//!
//! Input: the true position (m) and velocity (m/s), inertial. Output: a fix
//! ([`GnssFix`]) at each point of the receiver's sample grid outside its outages, nothing
//! otherwise (the suite holds the last fix in the frames with its validity time, so the
//! flight code tells a new fix from a held one).
//!
//! Error model: white noise per axis on position and velocity (six normals at every grid
//! point, outage or not, so an outage does not shift the later noise); no clock or
//! ionospheric error model.

use super::clock::Clock;
use super::noise::{gauss3, sensor_rng};
use crate::attitude::Vec3;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GnssModel {
    pub rate_hz: f64,
    /// 1σ white noise per axis of the position fix, m.
    pub position_noise_m: f64,
    /// 1σ white noise per axis of the velocity fix, m/s.
    pub velocity_noise_m_s: f64,
    /// Intervals `[start, end]` (s, closed) without a fix.
    pub outages_s: Vec<[f64; 2]>,
}

/// One navigation fix (same frame as the truth given, inertial).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssFix {
    pub t_s: f64,
    pub pos_m: [f64; 3],
    pub vel_m_s: [f64; 3],
}

/// GNSS receiver: a fix `r + n_r`, `v + n_v` (white, per axis) at each point of its sample
/// grid outside the outages, nothing otherwise (the suite holds the last fix, with its
/// time). Six normals are drawn at every grid point, outage or not, so an outage does not
/// shift the later noise.
#[derive(Clone, Debug)]
pub struct GnssReceiver {
    pub spec: GnssModel,
    rng: ChaCha8Rng,
    /// The sample clock (the suite sets its phase and jitter and asks it whether a
    /// sample is due before it builds the truth the sample needs).
    pub(crate) clock: Clock,
}

impl GnssReceiver {
    pub fn new(spec: GnssModel, scenario_seed: u64, index: u32) -> Self {
        Self { clock: Clock::new(spec.rate_hz), spec, rng: sensor_rng(scenario_seed, index) }
    }

    /// True when `t_s` is inside an outage.
    pub fn in_outage(&self, t_s: f64) -> bool {
        self.spec.outages_s.iter().any(|[a, b]| (*a..=*b).contains(&t_s))
    }

    /// Discrete: true position and velocity at `t`; `Some(fix)` on a grid point outside
    /// the outages.
    pub fn update(&mut self, t_s: f64, r_m: &[f64; 3], v_m_s: &[f64; 3]) -> Option<GnssFix> {
        self.clock.due(t_s)?;
        let nr = gauss3(&mut self.rng, &[self.spec.position_noise_m; 3]);
        let nv = gauss3(&mut self.rng, &[self.spec.velocity_noise_m_s; 3]);
        if self.in_outage(t_s) {
            return None;
        }
        Some(GnssFix { t_s, pos_m: (Vec3::from(*r_m) + nr).into(), vel_m_s: (Vec3::from(*v_m_s) + nv).into() })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gnss_fix_noise_statistics_and_outages() {
        let spec = GnssModel { rate_hz: 1.0, position_noise_m: 5.0, velocity_noise_m_s: 0.05, outages_s: vec![] };
        let mut g = GnssReceiver::new(spec.clone(), 3, 6);
        let (r, v) = ([7.0e6, -1.0e5, 2.0e5], [10.0, 7500.0, -30.0]);
        let n = 20_000;
        let (mut sr, mut sr2, mut sv, mut sv2) = (0.0, 0.0, 0.0, 0.0);
        for k in 0..n {
            let fix = g.update(k as f64, &r, &v).expect("fix every second");
            for i in 0..3 {
                let (er, ev) = (fix.pos_m[i] - r[i], fix.vel_m_s[i] - v[i]);
                sr += er;
                sr2 += er * er;
                sv += ev;
                sv2 += ev * ev;
            }
        }
        let m = 3.0 * n as f64;
        let (sd_r, sd_v) = ((sr2 / m - (sr / m).powi(2)).sqrt(), (sv2 / m - (sv / m).powi(2)).sqrt());
        println!("gnss noise: position sd / σ = {:.4}, velocity sd / σ = {:.4}", sd_r / 5.0, sd_v / 0.05);
        // 60 000 samples: 1σ of the sd estimate 0.3 %; tolerance 2 %.
        assert!((sd_r / 5.0 - 1.0).abs() < 0.02 && (sd_v / 0.05 - 1.0).abs() < 0.02);
        assert!((sr / m).abs() < 4.0 * 5.0 / m.sqrt() && (sv / m).abs() < 4.0 * 0.05 / m.sqrt());
        // Outage: the same noise before and after it (draws continue inside).
        let out = GnssModel { outages_s: vec![[10.0, 19.5]], ..spec.clone() };
        let (mut a, mut b) = (GnssReceiver::new(spec, 4, 6), GnssReceiver::new(out, 4, 6));
        for k in 0..40 {
            let (fa, fb) = (a.update(k as f64, &r, &v), b.update(k as f64, &r, &v));
            if (10..=19).contains(&k) {
                assert!(fb.is_none(), "{k}");
            } else {
                assert_eq!(fa, fb, "{k}");
            }
        }
    }
}
