//! Draws: the random number stream of each (run, key), the distributions, and how a draw
//! acts on the addressed scenario value.
//!
//! **Seeds.** The stream of dispersion `key` in run `i` is seeded with
//! `mix(mix(mix(master) ^ i) ^ fnv1a(key))` (`mix` = SplitMix64's finaliser), so a
//! draw depends on the master seed, the run index and the key only: adding, removing or
//! reordering other dispersions changes none of it.
//!
//! **Rotations** act by the addressed key's form: `…euler_deg` (with the sibling
//! `euler_sequence`) and `…quaternion_xyzw` attitudes become `q ⊗ δq` (a body-frame
//! perturbation, so the principal angle to the nominal is δq's angle); a 3×3 matrix
//! (an inertia) becomes `δR M δRᵀ`; a rotation vector (`…_deg` or `…_rad`, 3 numbers)
//! becomes `log(δR exp(v))`; a list of rotation vectors gets one draw per element.

use super::path::KeyPath;
use super::spec::{Apply, Dispersion, Distribution};
use acs_flight::math::EulerSeq;
use anyhow::{Result, anyhow, bail};
use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha12Rng;
use rand_distr::{Distribution as _, StandardNormal};
use serde_json::json;
use sim_core::attitude::{Quat, euler_from_quat, from_xyzw, quat_from_euler, to_xyzw};
use toml::Value;

/// SplitMix64's output function (Steele, Lea & Flood 2014).
fn mix(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// FNV-1a, 64 bit.
fn fnv1a(s: &str) -> u64 {
    s.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01B3))
}

/// The seed of the stream of `key` in run `run` (see the module doc).
pub fn stream_seed(master: u64, run: u32, key: &str) -> u64 {
    mix(mix(mix(master) ^ u64::from(run)) ^ fnv1a(key))
}

pub type Rng = ChaCha12Rng;

pub fn stream(master: u64, run: u32, key: &str) -> Rng {
    Rng::seed_from_u64(stream_seed(master, run, key))
}

fn normal(rng: &mut Rng) -> f64 {
    StandardNormal.sample(rng)
}

/// Most rejections a truncated normal may need (the campaign refuses windows beyond
/// 5 sd, whose acceptance is ≥ 3e-7 only in the worst case; typical windows accept ≥ 5 %).
const MAX_REJECTIONS: u32 = 10_000_000;

/// One scalar draw.
pub fn scalar(dist: &Distribution, rng: &mut Rng) -> Result<f64> {
    Ok(match dist {
        Distribution::Uniform { low, high } => low + (high - low) * rng.random::<f64>(),
        Distribution::Normal { mean, sd } => mean + sd * normal(rng),
        Distribution::TruncatedNormal { mean, sd, low, high } => {
            let mut tries = 0;
            loop {
                let x = mean + sd * normal(rng);
                if (*low..=*high).contains(&x) {
                    break x;
                }
                tries += 1;
                if tries >= MAX_REJECTIONS {
                    bail!("truncated_normal: no sample in [{low}, {high}] after {MAX_REJECTIONS} tries");
                }
            }
        }
        Distribution::Lognormal { mu, sigma } => (mu + sigma * normal(rng)).exp(),
        _ => bail!("not a numeric distribution"),
    })
}

/// A uniformly distributed unit vector.
fn unit_vector(rng: &mut Rng) -> Vector3<f64> {
    loop {
        let v = Vector3::new(normal(rng), normal(rng), normal(rng));
        let n = v.norm();
        if n > 1e-12 {
            return v / n;
        }
    }
}

/// The angle θ ∈ [0, θmax] of a Haar-uniform rotation conditioned on θ ≤ θmax: its
/// density is ∝ 1 − cos θ, so F(θ) = (θ − sin θ) / (θmax − sin θmax), inverted by
/// bisection (F is increasing; 64 halvings reach f64 resolution).
pub fn haar_angle(u: f64, max_rad: f64) -> f64 {
    let g = |t: f64| t - t.sin();
    let target = u * g(max_rad);
    let (mut lo, mut hi) = (0.0, max_rad);
    for _ in 0..64 {
        let mid = 0.5 * (lo + hi);
        if g(mid) < target { lo = mid } else { hi = mid }
    }
    0.5 * (lo + hi)
}

/// One random rotation, as a rotation vector (rad).
pub fn rotation(max_deg: Option<f64>, sd_deg: Option<f64>, rng: &mut Rng) -> Vector3<f64> {
    match sd_deg {
        Some(sd) => Vector3::new(normal(rng), normal(rng), normal(rng)) * sd.to_radians(),
        None => {
            let max = max_deg.map_or(std::f64::consts::PI, |m| m.to_radians().min(std::f64::consts::PI));
            let axis = unit_vector(rng);
            axis * haar_angle(rng.random::<f64>(), max)
        }
    }
}

/// `k` distinct items of `1..=n`, sorted (partial Fisher–Yates).
pub fn k_of_n(n: u32, k: u32, rng: &mut Rng) -> Vec<u32> {
    let mut items: Vec<u32> = (1..=n).collect();
    let k = (k as usize).min(items.len());
    for i in 0..k {
        let j = rng.random_range(i..items.len());
        items.swap(i, j);
    }
    let mut picked = items[..k].to_vec();
    picked.sort_unstable();
    picked
}

/// Applies one dispersion to the scenario `root`; returns what was drawn (for the
/// manifest: the number(s), the rotation vector(s) in deg, the chosen value, the items).
pub fn apply(d: &Dispersion, root: &mut Value, rng: &mut Rng) -> Result<serde_json::Value> {
    let key = &d.key;
    match &d.dist {
        Distribution::Choice { values, weights } => {
            let i = match weights {
                Some(w) => {
                    let total: f64 = w.iter().sum();
                    let mut u = rng.random::<f64>() * total;
                    let mut pick = w.len() - 1;
                    for (i, wi) in w.iter().enumerate() {
                        if u < *wi {
                            pick = i;
                            break;
                        }
                        u -= wi;
                    }
                    pick
                }
                None => rng.random_range(0..values.len()),
            };
            let v = values[i].clone();
            *replaceable(key, root)? = v.clone();
            Ok(serde_json::to_value(&v)?)
        }
        Distribution::Seed => {
            let s = rng.random::<u32>();
            *replaceable(key, root)? = Value::Integer(i64::from(s));
            Ok(json!(s))
        }
        Distribution::KOfN { n, k, item } => {
            let ks = k.values();
            let kk = ks[rng.random_range(0..ks.len())];
            let picked = k_of_n(*n, kk, rng);
            let as_value = |i: u32| match item {
                Some(name) => {
                    let mut t = toml::value::Table::new();
                    t.insert(name.clone(), Value::Integer(i64::from(i)));
                    Value::Table(t)
                }
                None => Value::Integer(i64::from(i)),
            };
            *replaceable(key, root)? = Value::Array(picked.iter().map(|i| as_value(*i)).collect());
            Ok(json!(picked))
        }
        Distribution::Rotation { max_deg, sd_deg } => rotate(key, root, rng, *max_deg, *sd_deg),
        _ => numeric(d, root, rng),
    }
}

/// The addressed value, for a draw that sets it whole (a missing last key is created for
/// the planner's parse check to judge). A table is never replaced: a draw that would put
/// a number, a string or a list in place of a scenario section is refused here.
fn replaceable<'a>(key: &KeyPath, root: &'a mut Value) -> Result<&'a mut Value> {
    let v = key.get_mut(root, true)?;
    if v.is_table() {
        bail!("key `{key}` holds a table (a scenario section): a draw must not replace it; address one of its keys");
    }
    Ok(v)
}

/// Uniform, normal, truncated normal, lognormal: set, scale or offset every number of the
/// addressed value, with one draw or one per element.
fn numeric(d: &Dispersion, root: &mut Value, rng: &mut Rng) -> Result<serde_json::Value> {
    let target = d.key.get_mut(root, d.apply == Apply::Set)?;
    if d.apply == Apply::Set && matches!(target, Value::Boolean(false)) {
        *target = Value::Float(0.0); // a key created by `set`: a number
    }
    let mut leaves: Vec<&mut f64> = Vec::new();
    collect_floats(target, &mut leaves).map_err(|e| anyhow!("key `{}`: {e}", d.key))?;
    if leaves.is_empty() {
        bail!("key `{}` holds no number", d.key);
    }
    let one = if d.per_element { None } else { Some(scalar(&d.dist, rng)?) };
    let mut drawn = Vec::with_capacity(leaves.len());
    for x in leaves {
        let r = match one {
            Some(r) => r,
            None => scalar(&d.dist, rng)?,
        };
        let v = match d.apply {
            Apply::Set => r,
            Apply::Scale => *x * r,
            Apply::Offset => *x + r,
        };
        // An overflowing draw (or product, or sum) is refused at planning, not flown.
        if !v.is_finite() {
            bail!(
                "key `{}`: the draw {r} {} gives {v}, not a finite number",
                d.key,
                match d.apply {
                    Apply::Set => "set".to_owned(),
                    Apply::Scale => format!("times {x}"),
                    Apply::Offset => format!("plus {x}"),
                }
            );
        }
        *x = v;
        drawn.push(r);
    }
    Ok(if drawn.len() == 1 || !d.per_element { json!(drawn[0]) } else { json!(drawn) })
}

fn collect_floats<'a>(v: &'a mut Value, out: &mut Vec<&'a mut f64>) -> Result<()> {
    match v {
        Value::Float(x) => out.push(x),
        Value::Array(a) => {
            for e in a {
                collect_floats(e, out)?;
            }
        }
        Value::Integer(_) => bail!("holds an integer (disperse it with choice or seed)"),
        other => bail!("holds a {}, not numbers", other.type_str()),
    }
    Ok(())
}

fn floats(v: &Value, n: usize) -> Option<Vec<f64>> {
    let a = v.as_array()?;
    let xs: Vec<f64> = a.iter().filter_map(|e| e.as_float().or_else(|| e.as_integer().map(|i| i as f64))).collect();
    (xs.len() == n && a.len() == n).then_some(xs)
}

fn float_array(xs: &[f64]) -> Value {
    Value::Array(xs.iter().map(|x| Value::Float(*x)).collect())
}

fn quat_of(rv: &Vector3<f64>) -> Quat {
    *UnitQuaternion::from_scaled_axis(*rv).quaternion()
}

/// A random rotation composed with the addressed value (forms in the module doc).
fn rotate(
    key: &KeyPath,
    root: &mut Value,
    rng: &mut Rng,
    max_deg: Option<f64>,
    sd_deg: Option<f64>,
) -> Result<serde_json::Value> {
    let leaf = key.leaf_name().to_owned();
    let seq = match key.parent_table(root).and_then(|t| t.get("euler_sequence")).and_then(Value::as_str) {
        Some("123") => EulerSeq::Xyz123,
        _ => EulerSeq::Zyx321,
    };
    let target = key.get_mut(root, false)?;
    let deg = |rv: &Vector3<f64>| json!([rv.x.to_degrees(), rv.y.to_degrees(), rv.z.to_degrees()]);
    if leaf.ends_with("euler_deg") && !key.ends_in_index() {
        let e = floats(target, 3).ok_or_else(|| anyhow!("key `{key}`: an Euler rotation needs 3 numbers"))?;
        let rv = rotation(max_deg, sd_deg, rng);
        let q = quat_from_euler([e[0], e[1], e[2]].map(f64::to_radians), seq) * quat_of(&rv);
        *target = float_array(&euler_from_quat(&q, seq).map(f64::to_degrees));
        return Ok(deg(&rv));
    }
    if leaf.ends_with("quaternion_xyzw") && !key.ends_in_index() {
        let q = floats(target, 4).ok_or_else(|| anyhow!("key `{key}`: a quaternion needs 4 numbers"))?;
        let rv = rotation(max_deg, sd_deg, rng);
        let q = (from_xyzw([q[0], q[1], q[2], q[3]]) * quat_of(&rv)).normalize();
        *target = float_array(&to_xyzw(&q));
        return Ok(deg(&rv));
    }
    let unit = if leaf.ends_with("_deg") {
        Some(1f64.to_radians())
    } else if leaf.ends_with("_rad") {
        Some(1.0)
    } else {
        None
    };
    let compose = |v: &[f64], scale: f64, rv: &Vector3<f64>| {
        let r = Rotation3::new(*rv) * Rotation3::new(Vector3::new(v[0], v[1], v[2]) * scale);
        (r.scaled_axis() / scale).as_slice().to_vec()
    };
    match (unit, floats(target, 3)) {
        (Some(s), Some(v)) => {
            let rv = rotation(max_deg, sd_deg, rng);
            *target = float_array(&compose(&v, s, &rv));
            Ok(deg(&rv))
        }
        (Some(s), None) => {
            // A list of rotation vectors: one draw each.
            let items = target.as_array_mut().ok_or_else(|| anyhow!("key `{key}`: not a rotation vector"))?;
            let mut drawn = Vec::new();
            for it in items.iter_mut() {
                let v = floats(it, 3).ok_or_else(|| anyhow!("key `{key}`: rotation vectors need 3 numbers"))?;
                let rv = rotation(max_deg, sd_deg, rng);
                *it = float_array(&compose(&v, s, &rv));
                drawn.push(deg(&rv));
            }
            Ok(json!(drawn))
        }
        (None, _) => {
            let rows = target.as_array().filter(|a| a.len() == 3).and_then(|a| {
                let r: Vec<Vec<f64>> = a.iter().filter_map(|row| floats(row, 3)).collect();
                (r.len() == 3).then_some(r)
            });
            let m = rows.ok_or_else(|| {
                anyhow!(
                    "key `{key}`: a rotation acts on `…euler_deg`, `…quaternion_xyzw`, a 3×3 matrix or a \
                     rotation vector named `…_deg`/`…_rad`"
                )
            })?;
            let rv = rotation(max_deg, sd_deg, rng);
            let r = Rotation3::new(rv).into_inner();
            let mm = r * Matrix3::from_fn(|i, j| m[i][j]) * r.transpose();
            *target = Value::Array((0..3).map(|i| float_array(&[mm[(i, 0)], mm[(i, 1)], mm[(i, 2)]])).collect());
            Ok(deg(&rv))
        }
    }
}
