//! Estimation: state estimators for the flight code.
//!
//! - [`kalman`]: linear Kalman filter `KalmanFilter<N, M, P>` (Joseph-form covariance mode
//!   and a fixed-gain steady-state mode, the gain designed on the host by
//!   `sim_host::design::steady_state_kalman`);
//! - [`lqg`]: [`LqgEstimator`], that filter on the LQR state (steady-state or time-varying).
//!   The LQR feedback itself is [`crate::control::lqr`];
//! - attitude determination: [`mekf`] (attitude + gyro bias), [`triad`], [`quest`],
//!   [`css`] (Sun direction from coarse sun sensors);
//! - [`navigation`]: GNSS fixes carried forward between fixes, LVLH;
//! - [`references`]: the Sun and field reference directions at the rate they change (the
//!   field evaluated at nodes, spread over the steps, interpolated in between);
//! - [`history`]: delayed fusion, each sample fused at its own time ([`history::MekfHistory`]);
//! - [`waiting`]: samples newer than the gyro, waiting for it to catch up;
//! - [`determination`]: the estimation stage of `Fsw::step` that runs them every step;
//! - [`status`]: what that stage reports per step ([`status::EstimateStatus`]; `Fsw::step`
//!   packs it for the wire).

pub mod css;
pub mod determination;
pub mod history;
pub mod kalman;
pub mod lqg;
pub mod mekf;
pub mod navigation;
pub mod quest;
pub mod references;
pub mod status;
pub mod triad;
pub mod waiting;
pub use lqg::LqgEstimator;
