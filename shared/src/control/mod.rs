//! Control laws. Each produces a desired body torque (N m, body axes) from the attitude
//! estimate; allocation turns it into actuator commands. [`law`] puts them behind one
//! interface ([`AttitudeLaw`]) with their state.

pub mod bdot;
pub mod dcm_pd;
pub mod dmcs;
pub mod euler_pd;
pub mod law;
pub mod lqr;
pub mod momentum;
pub mod quaternion_feedback;
pub mod rate_damping;
pub mod sun_safe;
pub use bdot::{Bdot, BdotGains};
pub use dcm_pd::{DcmPdGains, dcm_pd};
pub use dmcs::{Dmcs, DmcsGains};
pub use euler_pd::{EulerPdGains, euler_pd};
pub use law::{AttitudeLaw, Law, LawInputs, LawOutput, LawStatus};
pub use lqr::{LqrGains, lqr, lqr_from_state, lqr_state, state_feedback};
pub use quaternion_feedback::{QuaternionFeedback, QuaternionFeedbackGains};
pub use rate_damping::{RateDampingGains, rate_damping};

use crate::math::Vec3;

/// Scale `u` so that `|u_i| <= limit_i` on every axis, keeping its direction.
/// Returns the scaled vector and whether scaling happened. Non-positive or non-finite
/// limits leave that axis unconstrained (validated parameters never contain them).
pub fn scale_to_box(u: &Vec3, limit: &Vec3) -> (Vec3, bool) {
    let mut s = 1.0f32;
    for (x, l) in u.iter().zip(limit.iter()) {
        let a = libm::fabsf(*x);
        if *l > 0.0 && a > *l {
            s = s.min(*l / a);
        }
    }
    if s < 1.0 { (u * s, true) } else { (*u, false) }
}
