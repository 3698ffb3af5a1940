//! The host link's wire layer: messages ([`messages`]) and their COBS + CRC framing
//! ([`framing`]). Depends on [`crate::types`] and [`crate::params`] (the upload messages);
//! the flight side of a session is [`crate::session`], above [`crate::fsw`].

pub mod framing;
pub mod messages;

pub use framing::{FrameAccumulator, FrameError, LinkStats, encode_frame};
pub use messages::*;
