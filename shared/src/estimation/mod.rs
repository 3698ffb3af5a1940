//! Estimation: state estimators for the flight code.
//!
//! - [`kalman`]: linear Kalman filter `KalmanFilter<N, M, P>` (Joseph-form covariance mode
//!   and a fixed-gain steady-state mode, the gain designed on the host by
//!   `sim_host::design::steady_state_kalman`) and LQR state feedback [`kalman::lqr_apply`].

pub mod kalman;
