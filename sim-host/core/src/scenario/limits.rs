//! One validation, shared with the flight code: what the loader accepts, the flight code
//! accepts. Three checks live here (documented in `docs/scenario.md`, "Ranges"):
//!
//! - input files are read with a size cap ([`read_capped`]);
//! - every TOML array has exactly the length its key takes ([`exact_lengths`]): the TOML
//!   reader fills a fixed-size field from the first N elements and silently drops the rest;
//! - sensor values the flight code's input validation ([`acs_flight::validation`])
//!   would refuse on every step are refused here, naming the key, with the flight code's
//!   own limits (no second copy of the numbers).

use super::{Controller, Scenario, bad};
use acs_flight::params::{ParamError, ParamField, ParamReason};
use acs_flight::validation::{MAX_FIELD_T, MAX_GIMBAL_ANGLE_RAD, MAX_RATE_RAD_S, MAX_WHEEL_SPEED_RAD_S};
use anyhow::{Context, Result, anyhow};
use std::io::Read;
use std::path::Path;
use toml::Value;

/// Largest scenario or campaign file read, bytes (16 MiB: the largest shipped file is a
/// few kB; a bigger one is a mistake such as `/dev/zero`).
pub const MAX_INPUT_BYTES: u64 = 16 << 20;

/// A 1σ noise figure may be at most this fraction of the flight code's limit on the
/// measured quantity: a sample beyond the limit is then a > 10σ event.
pub const NOISE_FRACTION_OF_LIMIT: f64 = 0.1;

/// Largest angle noise, bias or misalignment, deg: beyond half a turn an angle carries no
/// information (and the small-rotation sensor models stop meaning anything).
pub const MAX_ANGLE_NOISE_DEG: f64 = 180.0;

/// Largest gyro scale-factor error, ppm (magnitude, exclusive): at 100 % the gyro reads
/// nothing or twice the rate.
pub const MAX_SCALE_FACTOR_PPM: f64 = 1.0e6;

/// The text of `path`, refused when it exceeds [`MAX_INPUT_BYTES`] (read stops there) or
/// is not UTF-8; every error names the file.
pub fn read_capped(path: &Path) -> Result<String> {
    let name = || path.display().to_string();
    let f = std::fs::File::open(path).with_context(|| format!("reading {}", name()))?;
    let mut bytes = Vec::new();
    f.take(MAX_INPUT_BYTES + 1).read_to_end(&mut bytes).with_context(|| format!("reading {}", name()))?;
    if bytes.len() as u64 > MAX_INPUT_BYTES {
        return Err(anyhow!("reading {}: larger than {} MiB (the input size cap)", name(), MAX_INPUT_BYTES >> 20));
    }
    String::from_utf8(bytes).map_err(|_| anyhow!("reading {}: not UTF-8 text", name()))
}

/// Every array of the document `given` has the length of the same key in `kept` (the
/// parsed scenario written back out): a longer array given for a fixed-size field was cut
/// by the reader, so it is refused here, naming the key and the length it takes.
pub(super) fn exact_lengths(given: &toml::Table, kept: &toml::Table) -> Result<()> {
    for (name, g) in given {
        if let Some(k) = kept.get(name) {
            same_lengths(g, k, name)?;
        }
    }
    Ok(())
}

fn same_lengths(given: &Value, kept: &Value, key: &str) -> Result<()> {
    match (given, kept) {
        (Value::Table(g), Value::Table(k)) => {
            for (name, gv) in g {
                if let Some(kv) = k.get(name) {
                    same_lengths(gv, kv, &format!("{key}.{name}"))?;
                }
            }
        }
        (Value::Array(g), Value::Array(k)) => {
            if g.len() != k.len() {
                return Err(bad(key, format!("has {} elements, expected {}", g.len(), k.len())));
            }
            for (i, (gv, kv)) in g.iter().zip(k).enumerate() {
                same_lengths(gv, kv, &format!("{key}[{i}]"))?;
            }
        }
        // Different shapes (a value with its own serialised form): nothing to compare.
        _ => {}
    }
    Ok(())
}

/// `x` short: plain between 1e-4 and 1e6, else in exponent form.
pub(super) fn num(x: f64) -> String {
    if x == 0.0 || !x.is_finite() || (1e-4..1e6).contains(&x.abs()) { format!("{x}") } else { format!("{x:e}") }
}

/// Largest magnitude of any number in a scenario: the flight code's `f32` range (a value
/// beyond it becomes an infinity on board; no physical key comes near it).
pub const MAX_MAGNITUDE: f64 = f32::MAX as f64;

/// Every number of the parsed scenario (`kept`, defaults included) is finite and within
/// ±[`MAX_MAGNITUDE`]; a refusal names the key.
pub(super) fn finite_numbers(v: &Value, key: &str) -> Result<()> {
    match v {
        Value::Float(x) if !(x.is_finite() && x.abs() <= MAX_MAGNITUDE) => {
            Err(bad(key, format!("{} must be finite and within ±{MAX_MAGNITUDE:e}", num(*x))))
        }
        Value::Array(a) => a.iter().enumerate().try_for_each(|(i, x)| finite_numbers(x, &format!("{key}[{i}]"))),
        Value::Table(t) => t
            .iter()
            .try_for_each(|(k, x)| finite_numbers(x, &if key.is_empty() { k.clone() } else { format!("{key}.{k}") })),
        _ => Ok(()),
    }
}

/// Old spellings still read (serde aliases), with the key that replaced them: one spelling
/// per quantity across tables (issue 22), without breaking files written before.
pub const DEPRECATED_KEYS: [(&str, &str); 2] = [
    ("sensors.gyro.arw_rad_s_rthz", "sensors.gyro.arw_rad_sqrt_s"),
    ("sensors.gyro.rrw_rad_s2_rthz", "sensors.gyro.rrw_rad_s_sqrt_s"),
];

/// The deprecated spellings `given` (the file as written) uses, as warnings; an error if a
/// file gives both spellings of one key (which one would win is not the user's choice).
pub(super) fn deprecated_spellings(given: &toml::Table) -> Result<Vec<String>> {
    let has = |path: &str| {
        let mut t = given;
        let mut parts = path.split('.').peekable();
        while let Some(p) = parts.next() {
            match (t.get(p), parts.peek()) {
                (Some(Value::Table(next)), Some(_)) => t = next,
                (Some(_), None) => return true,
                _ => return false,
            }
        }
        false
    };
    let mut warnings = Vec::new();
    for (old, new) in DEPRECATED_KEYS {
        if has(old) && has(new) {
            return Err(bad(old, format!("give `{new}` only (`{old}` is its deprecated spelling)")));
        }
        if has(old) {
            warnings.push(format!("`{old}` is deprecated: write `{new}` (same quantity and unit)"));
        }
    }
    Ok(warnings)
}

/// A TOML error the reader could not pin on a key (a value inside a table read as a
/// whole, such as `[controller]` with its `type` tag or `[initial]`): the key is found by
/// taking the keys of the table at the error one at a time out of the document, and the
/// first whose removal changes the error is named.
pub(super) fn parse_error(text: &str, e: toml::de::Error) -> anyhow::Error {
    let whole = match did_you_mean(e.message()) {
        Some(hint) => anyhow!("{e}{hint}"),
        None => anyhow!("{e}"),
    };
    let Some(span) = e.span() else { return whole };
    let Some(header) = text.get(span).map(str::trim).filter(|h| h.starts_with('[')) else { return whole };
    let path: Vec<&str> = header.trim_matches(|c| c == '[' || c == ']').split('.').map(str::trim).collect();
    // A required key left out: name it, not a key that is there (issue 38: removing any
    // key before it changes serde's message too, so the probe below would blame that one).
    if let Some(missing) = e.message().strip_prefix("missing field `").and_then(|m| m.split('`').next()) {
        return anyhow!(
            "missing key `{}.{missing}`: the [{}] table needs it (docs/scenario.md)",
            path.join("."),
            path.join(".")
        );
    }
    let Ok(doc) = toml::from_str::<toml::Table>(text) else { return whole };
    let mut table = &doc;
    for p in &path {
        match table.get(*p) {
            Some(Value::Table(t)) => table = t,
            _ => return whole,
        }
    }
    let reparse = |doc: toml::Table| Value::Table(doc).try_into::<Scenario>().err().map(|e| e.message().to_string());
    let Some(baseline) = reparse(doc.clone()) else { return whole };
    for key in table.keys().filter(|k| k.as_str() != "type") {
        let mut probe = doc.clone();
        let mut t = &mut probe;
        for p in &path {
            let Some(Value::Table(next)) = t.get_mut(*p) else { return whole };
            t = next;
        }
        t.remove(key);
        if reparse(probe).as_deref() != Some(baseline.as_str()) {
            let hint = did_you_mean(e.message()).unwrap_or_default();
            return anyhow!("invalid value for `{}.{key}`: {}{hint}", path.join("."), e.message());
        }
    }
    whole
}

/// For serde's "unknown field `x`, expected one of `a`, `b`, …": the closest expected
/// name, as "did you mean `a`?" — when it is within a third of the name's length in edits
/// (at least two), so that a typo is named and an unrelated key is not.
fn did_you_mean(message: &str) -> Option<String> {
    let rest = message.strip_prefix("unknown field `")?;
    let (given, rest) = rest.split_once('`')?;
    let expected = rest.split_once("expected")?.1;
    let candidates = expected.split('`').skip(1).step_by(2);
    let (best, d) = candidates.map(|c| (c, edit_distance(given, c))).min_by_key(|(_, d)| *d)?;
    let limit = (given.chars().count() / 3).max(2);
    (d <= limit).then(|| format!("\ndid you mean `{best}`?"))
}

/// Levenshtein distance between `a` and `b` in characters (insert, delete, substitute).
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diagonal = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let substitute = diagonal + usize::from(ca != *cb);
            diagonal = row[j + 1];
            row[j + 1] = substitute.min(row[j] + 1).min(diagonal + 1);
        }
    }
    row[b.len()]
}

/// Each `|x|` within `limit` (and finite), else refused naming `key` and `why`.
fn within(key: &str, xs: &[f64], limit: f64, why: &str) -> Result<()> {
    match xs.iter().find(|x| !(x.is_finite() && x.abs() <= limit)) {
        Some(x) => Err(bad(key, format!("{} is beyond ±{} ({why})", num(*x), num(limit)))),
        None => Ok(()),
    }
}

/// Physical ranges of the plant's disturbance keys: generous for any spacecraft, and
/// small enough that the plant stays finite (a 1e30 value used to drive it to NaN).
pub const MAX_LENGTH_M: f64 = 100.0;
pub const MAX_AREA_M2: f64 = 1.0e4;
pub const MAX_DIPOLE_AM2: f64 = 1.0e4;
pub const MAX_DISTURBANCE_TORQUE_NM: f64 = 1.0e3;
/// Sea-level air density, kg/m³: no orbit sees more.
pub const MAX_DENSITY_KG_M3: f64 = 1.3;
/// Largest orbit size (altitude or semi-major axis), km: beyond the Moon.
pub const MAX_ORBIT_KM: f64 = 1.0e6;

/// A 1σ noise figure: finite, >= 0 and at most `limit`.
fn noise(key: &str, x: f64, limit: f64, why: &str) -> Result<()> {
    if x.is_finite() && (0.0..=limit).contains(&x) {
        Ok(())
    } else {
        Err(bad(key, format!("{} must be in [0, {}] ({why})", num(x), num(limit))))
    }
}

impl Scenario {
    /// Sensor values the flight code's frame validation would refuse on every step
    /// (`bad_input` from the first step to the last), refused at load time instead.
    pub(super) fn validate_input_limits(&self) -> Result<()> {
        self.validate_rate_limits()?;
        self.validate_field_and_actuator_limits()?;
        self.validate_angle_noise()?;
        self.validate_plant_ranges()
    }

    /// The disturbance and orbit keys' documented ranges (`docs/scenario.md`).
    fn validate_plant_ranges(&self) -> Result<()> {
        let sc = &self.spacecraft;
        let why = "the documented range";
        within("spacecraft.cp_offset_m", &sc.cp_offset_m, MAX_LENGTH_M, why)?;
        if let Some(b) = &sc.box_m {
            within("spacecraft.box_m", b, MAX_LENGTH_M, why)?;
        }
        if let Some(a) = sc.drag_area_m2 {
            within("spacecraft.drag_area_m2", &[a], MAX_AREA_M2, why)?;
        }
        within("spacecraft.residual_dipole_am2", &sc.residual_dipole_am2, MAX_DIPOLE_AM2, why)?;
        within("spacecraft.external_torque_nm", &sc.external_torque_nm, MAX_DISTURBANCE_TORQUE_NM, why)?;
        if let Some(h) = &sc.harmonic_torque {
            within("spacecraft.harmonic_torque.amplitude_nm", &h.amplitude_nm, MAX_DISTURBANCE_TORQUE_NM, why)?;
        }
        if let Some(rho) = self.environment.density_kg_m3 {
            within("environment.density_kg_m3", &[rho], MAX_DENSITY_KG_M3, "sea-level air")?;
        }
        match self.orbit.as_ref().and_then(|o| o.elements().ok()) {
            Some(super::OrbitKind::Circular { altitude_km, .. }) => {
                within("orbit.altitude_km", &[altitude_km], MAX_ORBIT_KM, why)
            }
            Some(super::OrbitKind::Kepler { a_km, .. }) => within("orbit.a_km", &[a_km], MAX_ORBIT_KM, why),
            _ => Ok(()),
        }
    }

    fn validate_rate_limits(&self) -> Result<()> {
        let w = f64::from(MAX_RATE_RAD_S);
        let gyro = "the flight code refuses body rates beyond this";
        let noisy = "1σ at most a tenth of the flight code's rate limit";
        within("initial.rate_rad_s", &self.initial.rate_rad_s, w, gyro)?;
        within("sensors.rate_bias_rad_s", &self.sensors.rate_bias_rad_s, w, gyro)?;
        noise("sensors.rate_noise_rad_s", self.sensors.rate_noise_rad_s, w * NOISE_FRACTION_OF_LIMIT, noisy)?;
        if let Some(g) = &self.sensors.gyro {
            within("sensors.gyro.bias_rad_s", &g.bias_rad_s, w, gyro)?;
            // Per-sample 1σ of the white noise: ARW × √(sample rate).
            let fs = g.timing.rate_hz.unwrap_or(self.timing.control_rate_hz);
            let arw_limit = w * NOISE_FRACTION_OF_LIMIT / fs.sqrt();
            noise("sensors.gyro.arw_rad_sqrt_s", g.arw_rad_sqrt_s, arw_limit, "per-sample 1σ = ARW × √rate_hz")?;
            // The random-walk bias after the whole run: RRW × √duration.
            let rrw_limit = w * NOISE_FRACTION_OF_LIMIT / self.duration_s.sqrt();
            noise("sensors.gyro.rrw_rad_s_sqrt_s", g.rrw_rad_s_sqrt_s, rrw_limit, "bias 1σ = RRW × √duration_s")?;
            noise("sensors.gyro.bias_instability_rad_s", g.bias_instability_rad_s, w * NOISE_FRACTION_OF_LIMIT, noisy)?;
            if !(g.scale_factor_ppm.is_finite() && g.scale_factor_ppm.abs() < MAX_SCALE_FACTOR_PPM) {
                return Err(bad(
                    "sensors.gyro.scale_factor_ppm",
                    format!("{} must be within ±{MAX_SCALE_FACTOR_PPM} (exclusive)", g.scale_factor_ppm),
                ));
            }
        }
        Ok(())
    }

    fn validate_field_and_actuator_limits(&self) -> Result<()> {
        let b = f64::from(MAX_FIELD_T);
        let field = "the flight code refuses field components beyond this, T";
        let noisy = |what| format!("1σ at most a tenth of the flight code's {what} limit");
        noise(
            "sensors.magnetometer_noise_t",
            self.sensors.magnetometer_noise_t,
            b * NOISE_FRACTION_OF_LIMIT,
            &noisy("field"),
        )?;
        if let Some(m) = &self.sensors.magnetometer {
            noise("sensors.magnetometer.noise_t", m.noise_t, b * NOISE_FRACTION_OF_LIMIT, &noisy("field"))?;
            within("sensors.magnetometer.bias_t", &m.bias_t, b, field)?;
            super::finite("sensors.magnetometer.coupling_t_per_am2", &m.coupling_t_per_am2.concat())?;
        }
        if let Some(l) = &self.environment.lab_field_t {
            within("environment.lab_field_t", l, b, field)?;
        }
        let g_deg = f64::from(MAX_GIMBAL_ANGLE_RAD).to_degrees();
        noise(
            "sensors.gimbal_noise_deg",
            self.sensors.gimbal_noise_deg,
            g_deg * NOISE_FRACTION_OF_LIMIT,
            &noisy("gimbal angle"),
        )?;
        if let Some(c) = &self.actuators.cmg {
            // The flight code's bound is strict (|angle| < limit): stay a hair inside it.
            let inside = (g_deg * (1.0 - 1e-6)).floor();
            within(
                "actuators.cmg.initial_gimbal_deg",
                &c.initial_gimbal_deg,
                inside,
                "the flight code refuses gimbal angles beyond this, deg",
            )?;
        }
        let wheel = f64::from(MAX_WHEEL_SPEED_RAD_S);
        noise(
            "sensors.wheel_speed_noise_rad_s",
            self.sensors.wheel_speed_noise_rad_s,
            wheel * NOISE_FRACTION_OF_LIMIT,
            &noisy("wheel speed"),
        )?;
        if let Some(w) = &self.actuators.wheels {
            let rpm = wheel * 30.0 / std::f64::consts::PI;
            let why = "the flight code refuses wheel speeds beyond this, rpm";
            within("actuators.wheels.initial_speed_rpm", &w.initial_speed_rpm, rpm, why)?;
            within("actuators.wheels.bias_speed_rpm", &w.bias_speed_rpm, rpm, why)?;
        }
        Ok(())
    }

    fn validate_angle_noise(&self) -> Result<()> {
        let a = MAX_ANGLE_NOISE_DEG;
        let why = "beyond half a turn an angle carries no information";
        let s = &self.sensors;
        noise("sensors.attitude_noise_deg", s.attitude_noise_deg, a, why)?;
        if let Some(t) = &s.star_tracker {
            noise("sensors.star_tracker.noise_deg", t.noise_deg, a, why)?;
            for (k, v) in [("noise_cross_deg", t.noise_cross_deg), ("noise_about_deg", t.noise_about_deg)] {
                if let Some(v) = v {
                    noise(&format!("sensors.star_tracker.{k}"), v, a, why)?;
                }
            }
            within("sensors.star_tracker.bias_deg", &t.bias_deg, a, why)?;
        }
        if let Some(sun) = &s.sun {
            noise("sensors.sun.noise_deg", sun.noise_deg, a, why)?;
        }
        if let Some(g) = &s.gyro {
            within("sensors.gyro.misalignment_deg", &g.misalignment_deg, a, why)?;
        }
        if let Some(m) = &s.magnetometer {
            within("sensors.magnetometer.misalignment_deg", &m.misalignment_deg, a, why)?;
        }
        Ok(())
    }
}

impl Scenario {
    /// A flight-parameter refusal as a scenario error naming the TOML key it came from:
    /// `controller` and `target` are the keys of the law's and the target's tables
    /// (`controller`, `target`, or a mode's `modes.<mode>.controller` …), `law` the law.
    pub(super) fn param_refusal(
        &self,
        e: ParamError,
        controller: &str,
        law: Option<&Controller>,
        target: &str,
    ) -> anyhow::Error {
        param_refusal(e, &self.param_key(e.field, controller, law, target))
    }

    fn param_key(&self, field: ParamField, controller: &str, law: Option<&Controller>, target: &str) -> String {
        use ParamField as F;
        let c = |k: &str| format!("{controller}{k}");
        let gsr = self.steering.as_ref().is_some_and(|s| s.gsr.is_some());
        match field {
            F::Version => "the parameter-set version (internal)".to_string(),
            F::ControlRate => "timing.control_rate_hz".into(),
            // The DMCS law carries its own model inertia; the body's was checked before.
            F::Inertia if matches!(law, Some(Controller::Dmcs { .. })) => c(".model_inertia_kgm2"),
            F::Inertia => "spacecraft.inertia_kgm2".into(),
            F::AttitudeGain | F::RateGain | F::IntegralGain | F::IntegralLimit | F::Controller => c(""),
            F::TorqueLimit => c(".torque_limit_nm"),
            F::CmgSkew => "actuators.cmg.skew_deg".into(),
            F::CmgMomentum => "actuators.cmg.h0_nms".into(),
            F::GimbalRateLimit => "actuators.cmg.max_gimbal_rate_deg_s".into(),
            F::GimbalAngleRange => "actuators.cmg.gimbal_limit_deg".into(),
            F::SteeringAlpha if gsr => "steering.gsr".into(),
            F::SteeringAlpha => "steering.alpha".into(),
            F::SingularThreshold => "steering.singular_threshold".into(),
            F::NullMotion => "steering.null_gain_per_s".into(),
            F::Target => target.into(),
            F::HoldAfterMissed => "hold_after_missed_frames (internal)".into(),
            F::WheelCount | F::WheelLimit => "actuators.wheels".into(),
            F::WheelAxis => "actuators.wheels.axes".into(),
            F::WheelNullSpace => "actuators.wheels.null_gain_per_s".into(),
            F::DipoleLimit if self.actuators.magnetorquers.as_ref().is_some_and(|m| m.min_dipole_am2.is_some()) => {
                "actuators.magnetorquers".into()
            }
            F::DipoleLimit => "actuators.magnetorquers.max_dipole_am2".into(),
            F::DeadBand => "actuators.magnetorquers.deadband_am2".into(),
            F::MinField => "actuators.magnetorquers".into(),
            F::ThrusterCount | F::ThrusterTorque => "actuators.thrusters".into(),
            F::Pwpf => "actuators.thrusters.pwpf".into(),
            F::ModeTable => "modes".into(),
            F::Estimation => "estimation".into(),
            F::Momentum => "momentum".into(),
            F::Fdir => "fdir".into(),
            F::RodMask => "actuators.magnetorquers.masked_rods".into(),
            F::MomentumDump => "momentum.dump_*".into(),
            F::Pointing => "guidance".into(),
            F::PointingAxes => "guidance.pointing (primary_body, secondary_body)".into(),
            F::Manoeuvre => "manoeuvre".into(),
        }
    }
}

/// A flight-parameter refusal as a scenario error naming `key`.
pub(super) fn param_refusal(e: ParamError, key: &str) -> anyhow::Error {
    let why = match e.reason {
        ParamReason::NotFinite => "not finite",
        ParamReason::OutOfRange => "out of the range the flight code accepts",
        ParamReason::NotSymmetric => "not symmetric",
        ParamReason::NotPositiveDefinite => "not positive definite",
        ParamReason::UnsupportedVersion => "unsupported version",
        ParamReason::NotUnitQuaternion => "not a unit quaternion",
        ParamReason::TooLarge => "too large",
    };
    bad(key, format!("the flight code refuses it: {why} ({:?})", e.field))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edit_distance_counts_single_character_edits() {
        for (a, b, d) in [("", "", 0), ("abc", "", 3), ("kitten", "sitting", 3), ("output_evry", "output_every", 1)] {
            assert_eq!((edit_distance(a, b), edit_distance(b, a)), (d, d), "{a} {b}");
        }
    }

    /// A misspelt key is refused at its own line, naming the key it was probably meant
    /// to be; a key that resembles none gets no guess.
    #[test]
    fn an_unknown_key_names_the_closest_known_one() {
        let base = "name = \"x\"\nduration_s = 10.0\n[timing]\ncontrol_rate_hz = 10.0\n";
        let e = Scenario::from_toml(&format!("{base}output_evry = 2\n")).unwrap_err().to_string();
        assert!(e.contains("line 5") && e.ends_with("did you mean `output_every`?"), "{e}");
        let e = Scenario::from_toml(&format!("{base}zzz = 2\n")).unwrap_err().to_string();
        assert!(e.contains("unknown field `zzz`") && !e.contains("did you mean"), "{e}");
    }

    /// In a sensor table (read in two halves: `scenario::sensors`'s `timed`) a misspelt key
    /// is named with its table and the closest known key, a timing key among them; a
    /// timing key of the wrong type is named too; a well-formed one arrives in `timing`.
    #[test]
    fn a_sensor_table_key_is_named_with_its_table() {
        let text =
            std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenarios/estimation/mekf-hold.toml"))
                .unwrap();
        let with = |line: &str| text.replacen("[sensors.gyro]\n", &format!("[sensors.gyro]\n{line}\n"), 1);
        assert_ne!(with("x = 1"), text);
        let e = Scenario::from_toml(&with("latncy_s = 0.1")).unwrap_err().to_string();
        assert!(e.contains("`sensors.gyro.latncy_s`") && e.ends_with("did you mean `latency_s`?"), "{e}");
        let e = Scenario::from_toml(&with("arw_rad_sqrt = 0.1")).unwrap_err().to_string();
        assert!(e.contains("`sensors.gyro.arw_rad_sqrt`") && e.ends_with("did you mean `arw_rad_sqrt_s`?"), "{e}");
        let e = Scenario::from_toml(&with("latency_s = \"x\"")).unwrap_err().to_string();
        assert!(e.contains("`sensors.gyro.latency_s`") && e.contains("expected f64"), "{e}");
        let s = Scenario::from_toml(&with("latency_s = 0.015\nphase_s = 0.002")).unwrap();
        let g = s.sensors.gyro.unwrap();
        assert_eq!((g.timing.latency_s, g.timing.phase_s, g.timing.rate_hz), (0.015, 0.002, None));
        assert_eq!(g.arw_rad_sqrt_s, 1.0e-4);
    }

    /// A required key left out is named as missing, not blamed on the table's first key
    /// (issue 38: `tracker_sigma_cross_deg` was reported against `gyro_arw_rad_sqrt_s`).
    #[test]
    fn a_missing_key_is_named() {
        let text =
            std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenarios/estimation/mekf-hold.toml"))
                .unwrap();
        let cut: String =
            text.lines().filter(|l| !l.starts_with("tracker_sigma_cross_deg")).map(|l| format!("{l}\n")).collect();
        assert_ne!(cut, text);
        let e = Scenario::from_toml(&cut).unwrap_err().to_string();
        assert!(e.contains("missing key `estimation.tracker_sigma_cross_deg`") && !e.contains("gyro_arw"), "{e}");
    }
}
