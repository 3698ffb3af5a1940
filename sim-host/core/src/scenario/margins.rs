//! `[margins]`: measure the stability margins of the flight loop after the run, and report
//! them in `summary.json` `margins` (docs/margins.md, "In runs and campaigns"). The table
//! is optional; present, `sim-host run`, campaign runs and the Python `acs.run` measure.
//! `sim-host margins` takes its defaults from it.
//!
//! ```toml
//! [margins]
//! at_s = 30.0          # operating point, s (default: duration_s)
//! loop = "input"       # where the loop is broken: "input" (actuator command) or "output"
//! grid_points = 40     # log-spaced frequencies before refinement
//! ```

use super::{Scenario, bad};
use anyhow::Result;
use serde::{Deserialize, Serialize};

pub use crate::loop_break::LoopPoint;

#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MarginsSpec {
    #[serde(default)]
    pub at_s: Option<f64>,
    #[serde(default, rename = "loop")]
    pub loop_point: LoopPoint,
    #[serde(default = "grid_points")]
    pub grid_points: usize,
}

fn grid_points() -> usize {
    40
}

impl Default for MarginsSpec {
    fn default() -> Self {
        Self { at_s: None, loop_point: LoopPoint::Input, grid_points: grid_points() }
    }
}

/// Fewest and most grid frequencies: below, no crossing can be bracketed; above, the
/// measurement costs minutes without a better margin (refinement adds points at crossings).
pub const GRID_POINTS: (usize, usize) = (5, 400);

/// The validated `[margins]` request.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MarginRequest {
    /// Operating point, s, in [0, duration_s].
    pub at_s: f64,
    pub point: LoopPoint,
    pub grid_points: usize,
}

impl Scenario {
    /// `[margins]`, validated (None without the table); errors name the key.
    pub fn margin_request(&self) -> Result<Option<MarginRequest>> {
        let Some(m) = &self.margins else { return Ok(None) };
        let at_s = m.at_s.unwrap_or(self.duration_s);
        if !(at_s.is_finite() && (0.0..=self.duration_s).contains(&at_s)) {
            return Err(bad(
                "margins.at_s",
                format!("must be in [0, duration_s = {}] s (got {at_s})", self.duration_s),
            ));
        }
        let (lo, hi) = GRID_POINTS;
        if !(lo..=hi).contains(&m.grid_points) {
            return Err(bad("margins.grid_points", format!("must be in [{lo}, {hi}] (got {})", m.grid_points)));
        }
        Ok(Some(MarginRequest { at_s, point: m.loop_point, grid_points: m.grid_points }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn with(table: &str) -> Result<Option<MarginRequest>> {
        let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenarios/paper000/test1.toml"))
            .unwrap();
        Scenario::from_toml(&format!("{text}\n{table}\n"))?.margin_request()
    }

    #[test]
    fn defaults_and_refusals_name_the_key() {
        assert_eq!(with("").unwrap(), None);
        let r = with("[margins]").unwrap().unwrap();
        assert_eq!((r.point, r.grid_points), (LoopPoint::Input, 40));
        assert!(r.at_s > 0.0);
        let r = with("[margins]\nat_s = 5.0\nloop = \"output\"\ngrid_points = 7").unwrap().unwrap();
        assert_eq!(r, MarginRequest { at_s: 5.0, point: LoopPoint::Output, grid_points: 7 });
        for (t, key) in [
            ("at_s = -1.0", "margins.at_s"),
            ("at_s = 1e9", "margins.at_s"),
            ("grid_points = 2", "margins.grid_points"),
        ] {
            let e = format!("{:#}", with(&format!("[margins]\n{t}")).unwrap_err());
            assert!(e.contains(key), "{t}: {e}");
        }
        assert!(with("[margins]\nloop = \"sideways\"").is_err());
    }
}
