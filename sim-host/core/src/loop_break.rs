//! Where a stability-margin measurement breaks the flight loop (`[margins] loop`,
//! `sim-host margins --loop`; docs/margins.md): shared by the scenario (the request) and
//! the recorder (the `summary.json` `margins` it fills), below both.

use serde::{Deserialize, Serialize};

/// Where the loop is broken.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum LoopPoint {
    /// At the actuator command: body torque added to the flight's command through the
    /// actuators' effectiveness.
    #[default]
    Input,
    /// At the attitude measurement: a small rotation added to the attitude sample.
    Output,
}
