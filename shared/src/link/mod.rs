//! The host link: wire messages ([`messages`]), their COBS + CRC framing ([`framing`]) and
//! the flight side of a session ([`session`]). Depends on [`crate::types`]; no algorithm
//! depends on this module.

pub mod framing;
pub mod messages;
pub mod session;

pub use framing::{FrameAccumulator, FrameError, LinkStats, encode_frame};
pub use messages::*;
