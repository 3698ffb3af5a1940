//! Sensor faults of `[[faults]]` (issue 42) applied to the readings as they are sampled:
//! gyro axis stuck, bias step, noisier or saturated, star tracker flipped about its boresight or frozen,
//! magnetometer axis stuck or biased, coarse sun sensor head dead, GNSS
//! position or velocity jump, wheel tachometer stuck. A fault acts on a sample whose time (the truth's, the tag) is
//! in its window; a frozen value is the first reading in the window. The models still
//! draw their noise as without the fault, so every other reading keeps its bits.

use crate::attitude::{Quat, Vec3};
use crate::faults::{CssFault, Fault, GnssFault, GyroFault, MagFault, TimedFault, TrackerFault, WheelFault};
use nalgebra::{Unit, UnitQuaternion};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// The gyro's white noise and the streams a noisier axis draws its extra noise from
/// (sub-streams of the gyro's own, drawn only while such a fault is in force, so every
/// other reading keeps its bits).
#[derive(Clone, Debug)]
pub struct GyroNoise {
    /// Per-sample 1σ of the rate's white noise per axis, rad/s (ARW × √rate).
    pub rate_sigma_rad_s: [f64; 3],
    /// Angle random walk per axis, rad/√s (the increments' σ is this × √interval).
    pub arw_rad_sqrt_s: [f64; 3],
    pub rate_rng: ChaCha8Rng,
    pub angle_rng: ChaCha8Rng,
}

fn normal(rng: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(rng)
}

/// One sensor fault and the value it froze (while its window is open).
#[derive(Clone, Debug)]
struct Entry {
    fault: TimedFault,
    held: Option<Held>,
}

#[derive(Clone, Copy, Debug)]
enum Held {
    Rate(f64),
    Attitude(Quat),
    Speed(f64),
    Field(f64),
}

/// The sensor faults of a run.
#[derive(Clone, Debug, Default)]
pub struct SensorFaults {
    entries: Vec<Entry>,
    /// The sum of the gyro bias steps in force at the last gyro sample, triad axes, rad/s
    /// (part of the true bias the estimator is scored against).
    bias_step_rad_s: [f64; 3],
    /// The gyro's noise, for the `noise` faults (`None`: no such fault).
    gyro_noise: Option<GyroNoise>,
    /// The tachometers' noise, for the `tach_noise` faults (`None`: no such fault).
    tach_noise: Option<TachNoise>,
}

/// The tachometers' white noise and the stream a noisier one draws its extra noise from.
#[derive(Clone, Debug)]
pub struct TachNoise {
    /// 1σ of a reading, rad/s.
    pub sigma_rad_s: f64,
    pub rng: ChaCha8Rng,
}

impl SensorFaults {
    /// The sensor faults among `list` (the others are the plant's and the actuation's).
    pub fn new(list: &[TimedFault]) -> Self {
        let sensor = |f: &&TimedFault| {
            matches!(
                f.fault,
                Fault::Gyro { .. }
                    | Fault::StarTracker(_)
                    | Fault::Magnetometer { .. }
                    | Fault::Css { .. }
                    | Fault::Gnss(_)
                    | Fault::Wheel {
                        kind: WheelFault::TachStuck | WheelFault::PowerOff | WheelFault::TachNoise { .. },
                        ..
                    }
            )
        };
        let entries = list.iter().filter(sensor).map(|f| Entry { fault: *f, held: None }).collect();
        Self { entries, bias_step_rad_s: [0.0; 3], gyro_noise: None, tach_noise: None }
    }

    /// The tachometers' noise (`noise`: the stream the suite derives for it).
    pub fn with_tach_noise(mut self, noise: TachNoise) -> Self {
        let noisy = |e: &Entry| matches!(e.fault.fault, Fault::Wheel { kind: WheelFault::TachNoise { .. }, .. });
        if self.entries.iter().any(noisy) {
            self.tach_noise = Some(noise);
        }
        self
    }

    /// The gyro's noise (`noise`: the streams the suite derives from the gyro's).
    pub fn with_gyro_noise(mut self, noise: GyroNoise) -> Self {
        let noisy = |e: &Entry| matches!(e.fault.fault, Fault::Gyro { kind: GyroFault::Noise { .. }, .. });
        if self.entries.iter().any(noisy) {
            self.gyro_noise = Some(noise);
        }
        self
    }

    /// The gyro bias steps in force at the last gyro sample, rad/s.
    pub fn bias_step_rad_s(&self) -> [f64; 3] {
        self.bias_step_rad_s
    }

    /// A gyro sample at `t_s`: its rate and its angle increment over `[t_s - interval_s, t_s]`.
    pub fn gyro(&mut self, t_s: f64, interval_s: f64, rate: &mut [f64; 3], angle: &mut [f64; 3]) {
        self.bias_step_rad_s = [0.0; 3];
        for e in &mut self.entries {
            let Fault::Gyro { axis, kind } = e.fault.fault else { continue };
            let (Some(r), Some(a)) = (rate.get_mut(axis), angle.get_mut(axis)) else { continue };
            let w = e.fault.window;
            match kind {
                GyroFault::BiasStep { rad_s } => {
                    *a += rad_s * w.overlap_s(t_s - interval_s, t_s);
                    if w.active(t_s) {
                        *r += rad_s;
                        self.bias_step_rad_s[axis] += rad_s;
                    }
                }
                GyroFault::Stuck if w.active(t_s) => {
                    let held = match e.held {
                        Some(Held::Rate(x)) => x,
                        _ => *r,
                    };
                    e.held = Some(Held::Rate(held));
                    *r = held;
                    *a = held * interval_s;
                }
                GyroFault::Stuck => e.held = None,
                GyroFault::Noise { factor } => {
                    let Some(n) = self.gyro_noise.as_mut() else { continue };
                    // σ_total² = σ² + σ_extra²: the extra's σ is σ √(factor² − 1).
                    let extra = (factor * factor - 1.0).max(0.0).sqrt();
                    let overlap_s = w.overlap_s(t_s - interval_s, t_s);
                    if overlap_s > 0.0 {
                        let arw = n.arw_rad_sqrt_s.get(axis).copied().unwrap_or(0.0);
                        *a += arw * extra * overlap_s.sqrt() * normal(&mut n.angle_rng);
                    }
                    if w.active(t_s) {
                        let sigma = n.rate_sigma_rad_s.get(axis).copied().unwrap_or(0.0);
                        *r += sigma * extra * normal(&mut n.rate_rng);
                    }
                }
                GyroFault::Saturation { rad_s } if w.active(t_s) => {
                    *r = r.clamp(-rad_s, rad_s);
                    let max_angle = rad_s * interval_s;
                    *a = a.clamp(-max_angle, max_angle);
                }
                GyroFault::Saturation { .. } => {}
            }
        }
    }

    /// A star-tracker sample at `t_s` (`q_ib` as measured, body → inertial).
    pub fn tracker(&mut self, t_s: f64, boresight_body: &Vec3, q_ib: &mut Quat) {
        for e in &mut self.entries {
            let Fault::StarTracker(kind) = e.fault.fault else { continue };
            if !e.fault.window.active(t_s) {
                e.held = None;
                continue;
            }
            match kind {
                TrackerFault::Flip => {
                    let flip =
                        UnitQuaternion::from_axis_angle(&Unit::new_normalize(*boresight_body), std::f64::consts::PI);
                    *q_ib *= flip.into_inner();
                }
                TrackerFault::Frozen => {
                    let held = match e.held {
                        Some(Held::Attitude(q)) => q,
                        _ => *q_ib,
                    };
                    e.held = Some(Held::Attitude(held));
                    *q_ib = held;
                }
            }
        }
    }

    /// A magnetometer sample at `t_s` (`b_t`: the reading in the sensor's axes, T).
    pub fn magnetometer(&mut self, t_s: f64, b_t: &mut [f64; 3]) {
        for e in &mut self.entries {
            let Fault::Magnetometer { axis, kind } = e.fault.fault else { continue };
            let Some(b) = b_t.get_mut(axis) else { continue };
            if !e.fault.window.active(t_s) {
                e.held = None;
                continue;
            }
            match kind {
                MagFault::Bias { t } => *b += t,
                MagFault::Stuck => {
                    let held = match e.held {
                        Some(Held::Field(x)) => x,
                        _ => *b,
                    };
                    e.held = Some(Held::Field(held));
                    *b = held;
                }
            }
        }
    }

    /// A coarse-sun-sensor sample at `t_s` (each head's normalised output).
    pub fn css(&self, t_s: f64, output: &mut [f64]) {
        for e in &self.entries {
            let Fault::Css { index, kind: CssFault::Dead } = e.fault.fault else { continue };
            if let Some(o) = output.get_mut(index)
                && e.fault.window.active(t_s)
            {
                *o = 0.0;
            }
        }
    }

    /// A GNSS fix at `t_s` (`r_true_m`, `v_true_m_s`: the true position and velocity, ECI,
    /// m, m/s): a position jump along the radial, a velocity jump along the velocity.
    pub fn gnss(&self, t_s: f64, (r_true_m, v_true_m_s): (&Vec3, &Vec3), pos_m: &mut [f64; 3], vel_m_s: &mut [f64; 3]) {
        let along = |x: &Vec3, by: f64| {
            let n = x.norm();
            if n > 0.0 && n.is_finite() { x * (by / n) } else { Vec3::zeros() }
        };
        for e in &self.entries {
            let Fault::Gnss(kind) = e.fault.fault else { continue };
            if !e.fault.window.active(t_s) {
                continue;
            }
            match kind {
                GnssFault::PositionJump { m } => *pos_m = (Vec3::from(*pos_m) + along(r_true_m, m)).into(),
                GnssFault::VelocityJump { m_s } => *vel_m_s = (Vec3::from(*vel_m_s) + along(v_true_m_s, m_s)).into(),
            }
        }
    }

    /// Wheel `wheel`'s tachometer reading at `t_s`.
    pub fn tach(&mut self, t_s: f64, wheel: usize, speed_rad_s: f64) -> f64 {
        let mut out = speed_rad_s;
        for e in &mut self.entries {
            let kind = match e.fault.fault {
                Fault::Wheel { index, kind } if index == wheel => kind,
                _ => continue,
            };
            if !e.fault.window.active(t_s) {
                e.held = None;
                continue;
            }
            match kind {
                WheelFault::PowerOff => {
                    out = 0.0;
                    continue;
                }
                WheelFault::TachNoise { factor } => {
                    if let Some(n) = self.tach_noise.as_mut() {
                        let extra: f64 = StandardNormal.sample(&mut n.rng);
                        out += n.sigma_rad_s * (factor * factor - 1.0).max(0.0).sqrt() * extra;
                    }
                    continue;
                }
                WheelFault::TachStuck => {}
                _ => continue,
            }
            let held = match e.held {
                Some(Held::Speed(x)) => x,
                _ => out,
            };
            e.held = Some(Held::Speed(held));
            out = held;
        }
        out
    }
}
