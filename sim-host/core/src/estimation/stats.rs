//! Figures of the flight software's attitude determination over a run, against the
//! simulator's truth (the `summary.json` keys `estimation_error_rms_deg`,
//! `bias_error_final_deg_h`, `nees_mean`, `innovations_rejected`). Online: no history.
//!
//! Error convention of the flight MEKF (`acs_flight::estimation::mekf`): `q_true =
//! q_est ⊗ δq(δθ)` with `δθ = 2 vec(q_est* ⊗ q_true)` in body axes, `δb = b_true − b_est`;
//! NEES `= [δθ; δb]ᵀ P⁻¹ [δθ; δb]` with the flight filter's own 6×6 covariance (sent
//! every step as its upper triangle). For a consistent filter its mean is 6.

use crate::attitude::{Quat, Vec3, from_xyzw};
use crate::recorder::summary::SampleFusion;
use acs_flight::link::{EstimateTelemetry, FusionCounters, SampleAges, estimate_flags};
use nalgebra::{Matrix6, Vector6};

/// Running sums; steps count only while the MEKF runs.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EstimationStats {
    n: u64,
    sum_err2_deg2: f64,
    n_nees: u64,
    sum_nees: f64,
    max_err_deg: f64,
    last_bias_err_deg_h: Option<f64>,
    last: Option<EstimationSample>,
    rejected: u32,
    resets: u16,
    /// The flight code's sample ages of the last step and their largest values so far.
    ages: SampleAges,
    max_ages: SampleAges,
    fusion: FusionCounters,
}

/// One step's estimate against the truth (the `est_*` columns of `timeseries.csv`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EstimationSample {
    /// |δθ|, deg.
    pub error_deg: f64,
    /// √tr P_θθ, deg: the RMS of |δθ| the filter claims (a consistent filter's error
    /// stays mostly below 2–3 times it).
    pub sigma_deg: f64,
    /// |δb|, deg/h.
    pub bias_error_deg_h: f64,
    /// √tr P_bb, deg/h.
    pub bias_sigma_deg_h: f64,
    /// `[δθ; δb]ᵀ P⁻¹ [δθ; δb]` (`None` when P is not positive definite in f64).
    pub nees: Option<f64>,
}

/// The run's figures.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EstimationFigures {
    pub error_rms_deg: f64,
    pub error_max_deg: f64,
    pub error_final_deg: Option<f64>,
    pub bias_error_final_deg_h: Option<f64>,
    pub nees_mean: Option<f64>,
    /// Steps where the filter ran (the figures are over them).
    pub steps: u64,
    pub innovations_rejected: u32,
    pub resets: u16,
    pub sample_fusion: SampleFusion,
}

/// The 6×6 covariance from its row-major upper triangle.
pub fn covariance(upper: &[f32; 21]) -> Matrix6<f64> {
    let mut p = Matrix6::zeros();
    let mut k = 0;
    for i in 0..6 {
        for j in i..6 {
            p[(i, j)] = upper[k] as f64;
            p[(j, i)] = upper[k] as f64;
            k += 1;
        }
    }
    p
}

/// `[δθ; δb]` of an estimate against the truth (see the module docs).
pub fn error_state(q_true: &Quat, bias_true: &Vec3, t: &EstimateTelemetry) -> Vector6<f64> {
    let q_est = from_xyzw(t.q_est_xyzw.map(f64::from)).normalize();
    let mut e = q_est.conjugate() * q_true.normalize();
    if e.w < 0.0 {
        e = -e;
    }
    let dth = e.imag() * 2.0;
    let db = bias_true - Vec3::from(t.bias_est_rad_s.map(f64::from));
    Vector6::new(dth.x, dth.y, dth.z, db.x, db.y, db.z)
}

impl EstimationStats {
    /// One step's telemetry against the true attitude and gyro bias at the frame's time.
    pub fn push(&mut self, q_true: &Quat, bias_true: &Vec3, t: &EstimateTelemetry) {
        self.rejected = t.rejected;
        self.resets = t.resets;
        self.ages = t.sample_age_s;
        self.fusion = t.fusion;
        let a = &t.sample_age_s;
        let m = &mut self.max_ages;
        for (max, age) in [
            (&mut m.gyro, a.gyro),
            (&mut m.star_tracker, a.star_tracker),
            (&mut m.sun, a.sun),
            (&mut m.magnetometer, a.magnetometer),
        ] {
            *max = max.max(age);
        }
        if t.flags & estimate_flags::MEKF == 0 {
            self.last = None;
            return;
        }
        let x = error_state(q_true, bias_true, t);
        let err_deg = x.fixed_rows::<3>(0).norm().to_degrees();
        self.n += 1;
        self.sum_err2_deg2 += err_deg * err_deg;
        self.max_err_deg = crate::recorder::summary::nan_max(self.max_err_deg, err_deg);
        let bias_error_deg_h = x.fixed_rows::<3>(3).norm().to_degrees() * 3600.0;
        self.last_bias_err_deg_h = Some(bias_error_deg_h);
        let p = covariance(&t.covariance_upper);
        // NaN-propagating clamp: a NaN covariance must not read as a zero sigma.
        let trace = |k: usize| {
            crate::recorder::summary::nan_max(p[(k, k)] + p[(k + 1, k + 1)] + p[(k + 2, k + 2)], 0.0)
                .sqrt()
                .to_degrees()
        };
        let nees = p.cholesky().map(|ch| x.dot(&ch.solve(&x))).filter(|v| v.is_finite());
        if let Some(v) = nees {
            self.n_nees += 1;
            self.sum_nees += v;
        }
        self.last = Some(EstimationSample {
            error_deg: err_deg,
            sigma_deg: trace(0),
            bias_error_deg_h,
            bias_sigma_deg_h: trace(3) * 3600.0,
            nees,
        });
    }

    /// The last step's estimate against the truth (`None` when the MEKF was not running
    /// then).
    pub fn last(&self) -> Option<&EstimationSample> {
        self.last.as_ref()
    }

    /// Innovations rejected and filter restarts so far (the flight code's counters).
    pub fn counters(&self) -> (u32, u16) {
        (self.rejected, self.resets)
    }

    /// The last step's sample ages (gyro, tracker, Sun, magnetometer; s, NaN without a
    /// sample) and the samples fused, fused late and refused so far.
    pub fn sample_columns(&self) -> [f64; 7] {
        let age = |a: f32| if a < 0.0 { f64::NAN } else { f64::from(a) };
        let (a, f) = (&self.ages, &self.fusion);
        let refused = f
            .too_old
            .saturating_add(f.from_the_future)
            .saturating_add(f.out_of_order)
            .saturating_add(f.bad_input)
            .saturating_add(f.dropped_waiting);
        [
            age(a.gyro),
            age(a.star_tracker),
            age(a.sun),
            age(a.magnetometer),
            f64::from(f.fused_now.saturating_add(f.fused_late)),
            f64::from(f.fused_late),
            f64::from(refused),
        ]
    }

    fn sample_fusion(&self) -> SampleFusion {
        let (m, f) = (&self.max_ages, &self.fusion);
        SampleFusion {
            fused: f.fused_now.saturating_add(f.fused_late),
            fused_late: f.fused_late,
            fused_after_wait: f.fused_after_wait,
            waiting_at_end: f.waiting,
            refused_dropped_waiting: f.dropped_waiting,
            refused_too_old: f.too_old,
            refused_from_the_future: f.from_the_future,
            refused_out_of_order: f.out_of_order,
            refused_bad_input: f.bad_input,
            max_replayed_nodes: f.max_replayed_nodes,
            max_age_gyro_s: m.gyro,
            max_age_tracker_s: m.star_tracker,
            max_age_sun_s: m.sun,
            max_age_mag_s: m.magnetometer,
        }
    }

    /// Attitude-estimation error of the last step, deg (`None` when the MEKF was not
    /// running then).
    pub fn last_error_deg(&self) -> Option<f64> {
        self.last.map(|s| s.error_deg)
    }

    /// `None` when the MEKF never ran.
    pub fn figures(&self) -> Option<EstimationFigures> {
        (self.n > 0).then(|| EstimationFigures {
            error_rms_deg: (self.sum_err2_deg2 / self.n as f64).sqrt(),
            error_max_deg: self.max_err_deg,
            error_final_deg: self.last_error_deg(),
            bias_error_final_deg_h: self.last_bias_err_deg_h,
            nees_mean: (self.n_nees > 0).then(|| self.sum_nees / self.n_nees as f64),
            steps: self.n,
            innovations_rejected: self.rejected,
            resets: self.resets,
            sample_fusion: self.sample_fusion(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    #[test]
    fn nees_of_a_known_error_is_its_weighted_square() {
        // Estimate = truth turned by δθ = (1, 0, 0) mrad, bias error (0, 2e-5, 0);
        // P = diag(1e-6, …, 4e-10, …): NEES = 1 + 1 = 2 (closed form).
        let q_true = UnitQuaternion::from_euler_angles(0.3, -0.2, 0.1).into_inner();
        let turn = UnitQuaternion::from_scaled_axis(Vec3::new(1e-3, 0.0, 0.0)).into_inner();
        let q_est = q_true * turn.conjugate();
        let mut t = EstimateTelemetry {
            q_est_xyzw: crate::attitude::to_xyzw(&q_est).map(|x| x as f32),
            flags: estimate_flags::MEKF,
            ..Default::default()
        };
        let diag = [1e-6f32, 1e-6, 1e-6, 4e-10, 4e-10, 4e-10];
        let mut k = 0;
        for i in 0..6 {
            for j in i..6 {
                t.covariance_upper[k] = if i == j { diag[i] } else { 0.0 };
                k += 1;
            }
        }
        let mut s = EstimationStats::default();
        s.push(&q_true, &Vec3::new(0.0, 2e-5, 0.0), &t);
        let f = s.figures().unwrap();
        assert!((f.nees_mean.unwrap() - 2.0).abs() < 1e-3, "{:?}", f.nees_mean);
        assert!((f.error_rms_deg - 1e-3f64.to_degrees()).abs() < 1e-6, "{}", f.error_rms_deg);
        assert!((f.bias_error_final_deg_h.unwrap() - 2e-5f64.to_degrees() * 3600.0).abs() < 1e-3);
        // Without the MEKF flag nothing counts.
        let mut s = EstimationStats::default();
        s.push(&q_true, &Vec3::zeros(), &EstimateTelemetry::default());
        assert!(s.figures().is_none());
    }
}
