//! Host-side LQR/LQG design tools (f64): gains and filters computed here are exported to
//! the flight crate's `f32` matrices (see [`export`] and `acs_flight::estimation::kalman`).
//!
//! - [`riccati`]: CARE/DARE by structure-preserving doubling, LQR gains, residuals.
//! - [`discretize`]: exact ZOH (`c2d`) and Van Loan process noise via `expm`.
//! - [`linearize`]: central-difference Jacobians of any `f(x, u)`.
//! - [`models`]: papers 002 (LVLH + gravity gradient + CMG pyramid) and 003 (air-bearing
//!   rig with pendulum torque), nonlinear and analytic linear.
//! - [`kalman`]: steady-state Kalman gain by the dual DARE.
//! - [`export`]: conversion of gains to the flight crate's `f32` static matrices.
//!
//! Conventions: Hamilton quaternions stored scalar-last; Euler `[roll φ, pitch θ, yaw ψ]`,
//! sequence 3-2-1 (see [`models`]).

pub mod discretize;
pub mod export;
pub mod fit;
pub mod kalman;
pub mod linearize;
pub mod models;
pub mod riccati;

pub use discretize::{c2d, c2d_noise, expm};
pub use kalman::steady_state_kalman;
pub use linearize::linearize;
pub use riccati::{care, care_residual_rel, dare, dare_residual_rel, dlqr, dlqr_gain, lqr, lqr_gain};
