//! The page's data (docs/viewer.md, "Data layout"): one JSON document embedded in the
//! page, whose channels are little-endian typed arrays (Float64 for time, quaternions and
//! the directions the tests compare, Float32 for the rest) in base64, each with its name
//! and unit, so the page builds `Float64Array`/`Float32Array` views without parsing
//! numbers. Channels are found by name on the page: a column a later issue adds is carried
//! as it is and drawn once the page knows its name.

use serde::Serialize;

/// Element type of a channel on the page.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Dtype {
    F64,
    F32,
}

impl Dtype {
    pub fn bytes(self) -> usize {
        match self {
            Dtype::F64 => 8,
            Dtype::F32 => 4,
        }
    }
}

/// One channel: a value per kept row.
#[derive(Clone, Debug, PartialEq)]
pub struct Channel {
    pub name: String,
    pub unit: String,
    pub dtype: Dtype,
    pub values: Vec<f64>,
}

/// A channel as the page reads it.
#[derive(Clone, Debug, Serialize)]
pub struct Encoded {
    pub name: String,
    pub unit: String,
    pub dtype: Dtype,
    /// Little-endian values, base64 (RFC 4648, padded).
    pub data: String,
}

impl Channel {
    /// The channel's values as the page's typed array, little-endian, base64.
    pub fn encode(&self) -> Encoded {
        let mut bytes = Vec::with_capacity(self.values.len() * self.dtype.bytes());
        for &x in &self.values {
            match self.dtype {
                Dtype::F64 => bytes.extend_from_slice(&x.to_le_bytes()),
                Dtype::F32 => bytes.extend_from_slice(&(x as f32).to_le_bytes()),
            }
        }
        Encoded { name: self.name.clone(), unit: self.unit.clone(), dtype: self.dtype, data: base64(&bytes) }
    }
}

/// Page bytes of one row of these channels once encoded (base64: 4 characters per 3 bytes).
pub fn bytes_per_row(dtypes: impl IntoIterator<Item = Dtype>) -> usize {
    let raw: usize = dtypes.into_iter().map(Dtype::bytes).sum();
    raw.div_ceil(3) * 4
}

const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

/// Standard base64 with padding (RFC 4648 §4).
pub fn base64(bytes: &[u8]) -> String {
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [chunk[0], chunk.get(1).copied().unwrap_or(0), chunk.get(2).copied().unwrap_or(0)];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(ALPHABET[((n >> (18 - 6 * k)) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// The page with its data: the bundle's placeholder replaced by the JSON document, with
/// `<` escaped so no string in it (a scenario name, a failure message) can close the
/// script element.
pub fn fill_template(template: &str, json: &str) -> anyhow::Result<String> {
    const PLACEHOLDER: &str = "\"__ACS_REPLAY_DATA__\"";
    let n = template.matches(PLACEHOLDER).count();
    if n != 1 {
        anyhow::bail!("the viewer bundle has {n} data placeholders {PLACEHOLDER} (expected 1): rebuild it");
    }
    Ok(template.replacen(PLACEHOLDER, &json.replace('<', "\\u003c"), 1))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_matches_rfc_4648_test_vectors() {
        // RFC 4648 §10.
        for (plain, coded) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(base64(plain.as_bytes()), coded);
        }
        assert_eq!(base64(&[0xff, 0xfe, 0xfd]), "//79");
    }

    /// An independent decoder (the inverse, written from the alphabet).
    fn decode(s: &str) -> Vec<u8> {
        let val = |c: u8| ALPHABET.iter().position(|&a| a == c).unwrap() as u32;
        let mut out = Vec::new();
        for q in s.as_bytes().chunks(4) {
            let pad = q.iter().filter(|&&c| c == b'=').count();
            let n = q.iter().take(4 - pad).enumerate().fold(0u32, |n, (k, &c)| n | (val(c) << (18 - 6 * k)));
            out.extend_from_slice(&n.to_be_bytes()[1..4 - pad]);
        }
        out
    }

    #[test]
    fn channels_round_trip_bit_for_bit() {
        let values = vec![0.0, -0.0, 1.0 / 3.0, f64::MIN_POSITIVE, 1e300, f64::NAN, -7.25];
        let c = Channel { name: "q_x".into(), unit: "1".into(), dtype: Dtype::F64, values: values.clone() };
        let bytes = decode(&c.encode().data);
        let back: Vec<f64> = bytes.chunks(8).map(|b| f64::from_le_bytes(b.try_into().unwrap())).collect();
        assert_eq!(back.len(), values.len());
        assert!(back.iter().zip(&values).all(|(a, b)| a.to_bits() == b.to_bits()));
        let c = Channel { dtype: Dtype::F32, ..c };
        let bytes = decode(&c.encode().data);
        let back: Vec<f32> = bytes.chunks(4).map(|b| f32::from_le_bytes(b.try_into().unwrap())).collect();
        assert!(back.iter().zip(&values).all(|(a, b)| a.to_bits() == (*b as f32).to_bits()));
        assert_eq!(bytes_per_row([Dtype::F64, Dtype::F32]), 16);
        assert_eq!(c.encode().data.len(), bytes_per_row([Dtype::F32; 7]));
    }

    #[test]
    fn the_template_takes_the_data_once_and_escapes_markup() {
        let page =
            fill_template("<script>const D = \"__ACS_REPLAY_DATA__\";</script>", r#"{"n":"</script>"}"#).unwrap();
        assert_eq!(page, "<script>const D = {\"n\":\"\\u003c/script>\"};</script>");
        assert!(fill_template("no placeholder", "{}").is_err());
    }
}
