//! The spacecraft's sensors as one suite that produces the flight code's `SensorFrame`:
//! rate gyro (ARW, bias random walk, Gauss–Markov bias instability, bias, scale factor,
//! misalignment, range, LSB), attitude sensor (star tracker / AHRS small-rotation noise and
//! bias, cross/about-boresight noise, Sun and Earth-limb exclusion), magnetometer (noise,
//! bias, misalignment, coupling to the torquers' dipole), sun sensor (noise, field of
//! view, eclipse), coarse sun sensors (cosine heads, eclipse, Earth albedo, noise), GNSS
//! receiver (position / velocity / time fixes at its rate with white noise and outages;
//! without `[sensors.gnss]` the ideal orbit state on every frame), gimbal encoders and
//! wheel tachometers (white noise).
//!
//! One file per sensor, each a small type built from its model's specification
//! (`…Model`, which the scenario's `[sensors]` table gives: `crate::scenario::Sensors`)
//! with one sample step `update(t, truth…)`: [`gyro`],
//! [`star_tracker`], [`magnetometer`], [`sun_sensor`], [`css`], [`gnss`], [`encoders`].
//! Shared by them: the sample grid with its phase and jitter ([`clock`]), the noise streams
//! ([`noise`]) and the transport delay in seconds ([`latency`]). [`suite`] offers them the
//! truth at every dynamics substep, each samples on its own clock, time-tagged, and it
//! assembles at each control step the frame of the newest samples that have arrived (with
//! their times, and the gyro's integrated angle increment).
//!
//! Each sensor has its own sample clock and its own noise stream derived from the scenario
//! seed, so the same scenario and seed give the same bits and adding a sensor does not
//! change another's noise. Streams: 0 encoders and tachometers, 1 gyro, 2 attitude sensor,
//! 3 magnetometer, 4 sun sensor, 5 coarse sun sensors, 6 GNSS receiver; sub-streams of a
//! sensor's stream: 1 the gyro's bias instability, 2 every sensor's sample-time jitter, 3
//! the angle random walk of the gyro's angle increments, 4 and 5 the extra rate and
//! increment noise of an injected gyro `noise` fault (drawn only while one is in force).
//!
//! Conventions: Hamilton quaternions, `q_ib` rotates body → inertial; nalgebra's
//! `Quaternion` stores `[x, y, z, w]` (scalar last). Vectors are `[f64; 3]` or
//! [`crate::attitude::Vec3`], SI units.

pub mod clock;
pub mod css;
pub mod encoders;
pub mod faults;
pub mod gnss;
pub mod gyro;
pub mod latency;
pub mod magnetometer;
pub mod noise;
pub mod star_tracker;
pub mod suite;
pub mod sun_sensor;

pub use suite::{SensorSuite, SuiteSpec, j2000_days_seconds};
