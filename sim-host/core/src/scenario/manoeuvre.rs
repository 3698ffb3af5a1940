//! `[manoeuvre]`: planned slews and keep-out cones (docs/scenario.md, "[manoeuvre]"; the
//! flight side: `acs_flight::guidance::manoeuvre`, docs/guidance.md "Planned slews and
//! keep-out cones"). Present: every change of pointing is a rate- and
//! acceleration-limited slew that keeps each boresight out of its cones; the same set for
//! the mission and for every mode.
//!
//! ```toml
//! [manoeuvre]
//! max_rate_deg_s = 1.5
//! max_accel_deg_s2 = 0.1
//! planning_margin_deg = 2.0
//! [[manoeuvre.keepout]]
//! name = "tracker"
//! boresight_body = [0, 1, 0]
//! sun_half_angle_deg = 35.0
//! earth_margin_deg = 10.0
//! ```
//! A boresight inside a cone (truth) fails the run from `keepout_enforced_from_s` on
//! (default 0).
//! Every value is checked here naming its key; the flight's validation of the built
//! [`ManoeuvreParams`] is the last line of defence.

use super::{bad, finite};
use acs_flight::params::guidance::{MAX_KEEPOUT_CONES, MAX_PLANNING_MARGIN_RAD};
use acs_flight::params::{KeepOutCone, ManoeuvreParams};
use anyhow::Result;
use serde::{Deserialize, Serialize};

/// Largest slew rate limit, deg/s, and acceleration limit, deg/s² (the flight's 1 rad/s,
/// 1 rad/s²).
pub const MAX_SLEW_RATE_DEG_S: f64 = 57.0;
pub const MAX_SLEW_ACCEL_DEG_S2: f64 = 57.0;
/// How far a boresight may be from unit length (it is normalised).
pub const BORESIGHT_UNIT_TOL: f64 = 1e-3;

#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ManoeuvreSpec {
    pub max_rate_deg_s: f64,
    pub max_accel_deg_s2: f64,
    #[serde(default)]
    pub planning_margin_deg: f64,
    #[serde(default)]
    pub keepout: Vec<KeepOutSpec>,
    /// From this time on, s, a boresight inside one of its cones (truth) fails the run
    /// (`run_status` "keepout_violated", exit 3). Default 0: always. The flight code plans
    /// the slews between pointings, not the first capture from the initial state, so a
    /// scenario that starts pointing elsewhere sets the time its capture ends.
    #[serde(default)]
    pub keepout_enforced_from_s: f64,
}

/// One boresight and its cones.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct KeepOutSpec {
    /// Names its columns and summary keys (letters, digits, `_`).
    pub name: String,
    pub boresight_body: [f64; 3],
    /// Half-angle of the cone about the Sun, deg, in (0, 90] (absent: no Sun cone).
    #[serde(default)]
    pub sun_half_angle_deg: Option<f64>,
    /// Margin beyond the Earth's disc, deg, in [0, 90] (absent: no Earth cone).
    #[serde(default)]
    pub earth_margin_deg: Option<f64>,
}

impl ManoeuvreSpec {
    /// The flight parameters, every value checked naming its key (`key`: "manoeuvre").
    pub fn params(&self, key: &str) -> Result<ManoeuvreParams> {
        let k = |f: &str| format!("{key}.{f}");
        let range = |f: &str, x: f64, lo: f64, hi: f64, open_lo: bool| -> Result<f32> {
            finite(&k(f), &[x])?;
            if x > hi || x < lo || (open_lo && x <= lo) {
                let open = if open_lo { "(" } else { "[" };
                return Err(bad(&k(f), format!("{x} is outside {open}{lo}, {hi}]")));
            }
            Ok(x.to_radians() as f32)
        };
        let mut p = ManoeuvreParams {
            enabled: true,
            max_rate_rad_s: range("max_rate_deg_s", self.max_rate_deg_s, 0.0, MAX_SLEW_RATE_DEG_S, true)?,
            max_accel_rad_s2: range("max_accel_deg_s2", self.max_accel_deg_s2, 0.0, MAX_SLEW_ACCEL_DEG_S2, true)?,
            planning_margin_rad: range(
                "planning_margin_deg",
                self.planning_margin_deg,
                0.0,
                MAX_PLANNING_MARGIN_RAD.to_degrees() as f64 - 1e-4,
                false,
            )?,
            ..ManoeuvreParams::OFF
        };
        if self.keepout.len() > MAX_KEEPOUT_CONES {
            return Err(bad(&k("keepout"), format!("{} boresights, at most {MAX_KEEPOUT_CONES}", self.keepout.len())));
        }
        for (i, (c, slot)) in self.keepout.iter().zip(p.cones.iter_mut()).enumerate() {
            *slot = c.cone(&k(&format!("keepout[{i}]")))?;
            if self.keepout.iter().take(i).any(|o| o.name == c.name) {
                return Err(bad(&k(&format!("keepout[{i}].name")), format!("`{}` is used twice", c.name)));
            }
        }
        p.cone_count = self.keepout.len() as u8;
        finite(&k("keepout_enforced_from_s"), &[self.keepout_enforced_from_s])?;
        if self.keepout_enforced_from_s < 0.0 {
            return Err(bad(&k("keepout_enforced_from_s"), format!("{} is negative", self.keepout_enforced_from_s)));
        }
        p.validate().map_err(|e| bad(key, format!("refused by the flight code: {e:?}")))?;
        Ok(p)
    }
}

impl KeepOutSpec {
    fn cone(&self, key: &str) -> Result<KeepOutCone> {
        let k = |f: &str| format!("{key}.{f}");
        if self.name.is_empty() || !self.name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
            return Err(bad(&k("name"), format!("`{}`: letters, digits and `_` only", self.name)));
        }
        finite(&k("boresight_body"), &self.boresight_body)?;
        let n = self.boresight_body.iter().map(|x| x * x).sum::<f64>().sqrt();
        if (n - 1.0).abs() > BORESIGHT_UNIT_TOL {
            return Err(bad(&k("boresight_body"), format!("norm {n}, must be 1 within {BORESIGHT_UNIT_TOL}")));
        }
        let deg = |f: &str, x: Option<f64>, open_lo: bool| -> Result<Option<f32>> {
            let Some(x) = x else { return Ok(None) };
            finite(&k(f), &[x])?;
            if !(0.0..=90.0).contains(&x) || (open_lo && x == 0.0) {
                return Err(bad(&k(f), format!("{x} is outside {}0, 90]", if open_lo { "(" } else { "[" })));
            }
            Ok(Some(x.to_radians() as f32))
        };
        let sun = deg("sun_half_angle_deg", self.sun_half_angle_deg, true)?;
        let earth = deg("earth_margin_deg", self.earth_margin_deg, false)?;
        if sun.is_none() && earth.is_none() {
            return Err(bad(key, "give sun_half_angle_deg, earth_margin_deg or both"));
        }
        Ok(KeepOutCone {
            boresight_body: self.boresight_body.map(|x| (x / n) as f32),
            sun_half_angle_rad: sun.unwrap_or(0.0),
            earth_margin_rad: earth.unwrap_or(-1.0),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec() -> ManoeuvreSpec {
        toml::from_str(
            r#"
            max_rate_deg_s = 1.5
            max_accel_deg_s2 = 0.1
            planning_margin_deg = 2.0
            [[keepout]]
            name = "tracker"
            boresight_body = [0, 1, 0]
            sun_half_angle_deg = 35.0
            [[keepout]]
            name = "radiator"
            boresight_body = [0, 0, -1]
            earth_margin_deg = 5.0
            "#,
        )
        .unwrap()
    }

    #[test]
    fn a_valid_set_becomes_the_flight_parameters() {
        let p = spec().params("manoeuvre").unwrap();
        assert!(p.enabled);
        assert!((p.max_rate_rad_s - 1.5f32.to_radians()).abs() < 1e-7);
        assert_eq!(p.cone_count, 2);
        assert_eq!(p.cones[0].earth_margin_rad, -1.0);
        assert_eq!(p.cones[1].sun_half_angle_rad, 0.0);
        assert!((p.cones[0].sun_half_angle_rad - 35f32.to_radians()).abs() < 1e-7);
    }

    /// Each bad value is refused naming its key.
    #[test]
    fn bad_values_name_their_key() {
        type Edit = fn(&mut ManoeuvreSpec);
        let cases: [(Edit, &str); 10] = [
            (|s| s.max_rate_deg_s = 0.0, "manoeuvre.max_rate_deg_s"),
            (|s| s.max_accel_deg_s2 = f64::NAN, "manoeuvre.max_accel_deg_s2"),
            (|s| s.planning_margin_deg = 11.0, "manoeuvre.planning_margin_deg"),
            (|s| s.keepout[1].boresight_body = [0.0, 0.0, -1.1], "manoeuvre.keepout[1].boresight_body"),
            (|s| s.keepout[0].sun_half_angle_deg = Some(95.0), "manoeuvre.keepout[0].sun_half_angle_deg"),
            (|s| s.keepout[1].earth_margin_deg = Some(-1.0), "manoeuvre.keepout[1].earth_margin_deg"),
            (|s| s.keepout[1].name = "tracker".into(), "manoeuvre.keepout[1].name"),
            (|s| s.keepout = vec![s.keepout[0].clone(); 5], "manoeuvre.keepout"),
            (|s| s.keepout_enforced_from_s = -1.0, "manoeuvre.keepout_enforced_from_s"),
            (|s| s.keepout_enforced_from_s = f64::NAN, "manoeuvre.keepout_enforced_from_s"),
        ];
        for (edit, key) in cases {
            let mut s = spec();
            edit(&mut s);
            let e = s.params("manoeuvre").unwrap_err().to_string();
            assert!(e.contains(&format!("`{key}`")) || e.contains(key), "{key}: {e}");
        }
    }
}
