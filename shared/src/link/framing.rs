//! Framing of the host link: a frame on the wire is `COBS(postcard(msg) ‖ crc32_le) ‖ 0x00`.
//! The zero byte only ever appears as the delimiter, so a receiver that lost sync simply
//! waits for the next zero. [`FrameAccumulator`] does that, counts every bad frame by kind
//! and goes on.

use super::messages::MAX_PAYLOAD;
use crate::checksum::CRC32;
use serde::{Deserialize, Serialize};

/// Why a frame was dropped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FrameError {
    /// Longer than the receive buffer before a delimiter arrived.
    Oversize,
    /// Not valid COBS.
    Cobs,
    /// Shorter than a CRC.
    Short,
    /// CRC mismatch.
    Crc,
    /// CRC fine but the payload is not exactly one valid message (undecodable, or bytes
    /// left over after the message: a frame carries one message and nothing else).
    Decode,
    /// The output buffer is too small (encoder side).
    BufferTooSmall,
}

/// Counters of a receiver.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LinkStats {
    pub frames_ok: u32,
    pub oversize: u32,
    pub cobs: u32,
    pub short: u32,
    pub crc: u32,
    pub decode: u32,
}

impl LinkStats {
    pub fn dropped(&self) -> u32 {
        self.oversize
            .saturating_add(self.cobs)
            .saturating_add(self.short)
            .saturating_add(self.crc)
            .saturating_add(self.decode)
    }
}

/// Encode `msg` as one frame into `out`; returns the frame (delimiter included).
pub fn encode_frame<'a, T: Serialize>(msg: &T, out: &'a mut [u8]) -> Result<&'a [u8], FrameError> {
    let mut raw = [0u8; MAX_PAYLOAD + 4];
    let n = postcard::to_slice(msg, &mut raw).map_err(|_| FrameError::BufferTooSmall)?.len();
    let body = raw.get(..n).ok_or(FrameError::BufferTooSmall)?;
    let crc = CRC32.checksum(body).to_le_bytes();
    let total = n.saturating_add(4);
    let Some(dst) = raw.get_mut(n..total) else {
        return Err(FrameError::BufferTooSmall);
    };
    dst.copy_from_slice(&crc);
    let Some(src) = raw.get(..total) else {
        return Err(FrameError::BufferTooSmall);
    };
    if out.len() < cobs::max_encoding_length(total).saturating_add(1) {
        return Err(FrameError::BufferTooSmall);
    }
    // `cobs::encode` unwraps the same result (a panic path, found by tools/elf-check).
    let enc = cobs::try_encode(src, out).map_err(|_| FrameError::BufferTooSmall)?;
    let Some(delim) = out.get_mut(enc) else {
        return Err(FrameError::BufferTooSmall);
    };
    *delim = 0;
    out.get(..enc.saturating_add(1)).ok_or(FrameError::BufferTooSmall)
}

/// COBS decoding in place (Cheshire & Baker, IEEE/ACM Trans. Networking 7(2), 1999):
/// returns the decoded length, or `None` if `buf` is not valid COBS. Same results as
/// `cobs::decode_in_place` 0.5 (test `cobs_decoder_matches_the_cobs_crate`: it stops at a
/// zero byte, and a code running past the end is an error unless it is 1) but written with
/// checked accesses: the crate's version indexes, and its bounds checks were the panic
/// paths tools/elf-check found in the link task. Loops: at most `buf.len()` bytes in total.
fn cobs_decode_in_place(buf: &mut [u8]) -> Option<usize> {
    let end = buf.iter().position(|b| *b == 0).unwrap_or(buf.len());
    let (mut src, mut dst) = (0usize, 0usize);
    if end == 0 && buf.is_empty() {
        return None;
    }
    while src < end {
        let code = *buf.get(src)?;
        if src.saturating_add(usize::from(code)) > end && code != 1 {
            return None;
        }
        src = src.saturating_add(1);
        for _ in 1..code {
            let b = *buf.get(src)?;
            *buf.get_mut(dst)? = b;
            src = src.saturating_add(1);
            dst = dst.saturating_add(1);
        }
        if code != 0xFF && src < end {
            *buf.get_mut(dst)? = 0;
            dst = dst.saturating_add(1);
        }
    }
    Some(dst)
}

/// Receive side: push bytes one at a time; every delimiter yields a message or a counted
/// error, after which the accumulator is in sync again. `N` is the buffer size.
pub struct FrameAccumulator<const N: usize> {
    buf: [u8; N],
    len: usize,
    overflow: bool,
    pub stats: LinkStats,
}

impl<const N: usize> Default for FrameAccumulator<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> FrameAccumulator<N> {
    pub const fn new() -> Self {
        Self {
            buf: [0; N],
            len: 0,
            overflow: false,
            stats: LinkStats { frames_ok: 0, oversize: 0, cobs: 0, short: 0, crc: 0, decode: 0 },
        }
    }

    /// Feed one byte. Returns `None` mid-frame (and for empty frames, which senders may
    /// use to flush a half-received frame at the other end).
    pub fn push<T: for<'de> Deserialize<'de>>(&mut self, byte: u8) -> Option<Result<T, FrameError>> {
        if byte != 0 {
            match self.buf.get_mut(self.len) {
                Some(slot) => {
                    *slot = byte;
                    self.len = self.len.saturating_add(1);
                }
                None => self.overflow = true,
            }
            return None;
        }
        let len = core::mem::replace(&mut self.len, 0);
        if core::mem::replace(&mut self.overflow, false) {
            self.stats.oversize = self.stats.oversize.saturating_add(1);
            return Some(Err(FrameError::Oversize));
        }
        if len == 0 {
            return None;
        }
        let r = self.decode(len);
        match r {
            Ok(_) => self.stats.frames_ok = self.stats.frames_ok.saturating_add(1),
            Err(e) => {
                let c = match e {
                    FrameError::Cobs => &mut self.stats.cobs,
                    FrameError::Short => &mut self.stats.short,
                    FrameError::Crc => &mut self.stats.crc,
                    _ => &mut self.stats.decode,
                };
                *c = c.saturating_add(1);
            }
        }
        Some(r)
    }

    fn decode<T: for<'de> Deserialize<'de>>(&mut self, len: usize) -> Result<T, FrameError> {
        let frame = self.buf.get_mut(..len).ok_or(FrameError::Oversize)?;
        let n = cobs_decode_in_place(frame).ok_or(FrameError::Cobs)?;
        let data = frame.get(..n).ok_or(FrameError::Cobs)?;
        if n < 5 {
            return Err(FrameError::Short);
        }
        // Body and the trailing CRC-32 without an index that could panic.
        let (body, crc) = data.split_last_chunk::<4>().ok_or(FrameError::Short)?;
        if CRC32.checksum(body) != u32::from_le_bytes(*crc) {
            return Err(FrameError::Crc);
        }
        // `from_bytes` would ignore bytes after the message; a CRC-valid frame with
        // trailing junk is not a frame any sender built, so it is refused.
        match postcard::take_from_bytes(body) {
            Ok((msg, [])) => Ok(msg),
            _ => Err(FrameError::Decode),
        }
    }

    /// Drop a partly received frame (e.g. after a link timeout).
    pub fn clear(&mut self) {
        self.len = 0;
        self.overflow = false;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::messages::*;
    use crate::params::FlightParams;

    fn sensor(seq: u32) -> HostMsg {
        HostMsg::Sensor(SensorFrame {
            q_ib_xyzw: [0.1, -0.2, 0.3, 0.927],
            rate_rad_s: [0.01, 0.0, -0.02],
            gimbal_angle_rad: [0.0, 0.5, -0.5, 0.0],
            wheel_speed_rad_s: [10.0, -20.0, 30.0, 0.0, 0.0, 0.0],
            mag_field_t: [2e-5, -1e-5, 3e-5],
            valid: valid::ALL,
            ..SensorFrame::empty(seq, 10_000 * seq as u64)
        })
    }

    fn enc(m: &HostMsg) -> std::vec::Vec<u8> {
        let mut out = [0u8; MAX_FRAME];
        encode_frame(m, &mut out).unwrap().to_vec()
    }

    fn feed(acc: &mut FrameAccumulator<MAX_FRAME>, bytes: &[u8]) -> std::vec::Vec<Result<HostMsg, FrameError>> {
        bytes.iter().filter_map(|b| acc.push::<HostMsg>(*b)).collect()
    }

    /// The examples of the COBS article (Wikipedia "Consistent Overhead Byte Stuffing",
    /// from Cheshire & Baker 1999) decode to their data; both encoders produce them.
    #[test]
    fn cobs_decoder_decodes_the_published_examples() {
        let cases: [(&[u8], &[u8]); 6] = [
            (&[0x00], &[0x01, 0x01]),
            (&[0x00, 0x00], &[0x01, 0x01, 0x01]),
            (&[0x00, 0x11, 0x00], &[0x01, 0x02, 0x11, 0x01]),
            (&[0x11, 0x22, 0x00, 0x33], &[0x03, 0x11, 0x22, 0x02, 0x33]),
            (&[0x11, 0x22, 0x33, 0x44], &[0x05, 0x11, 0x22, 0x33, 0x44]),
            (&[0x11, 0x00, 0x00, 0x00], &[0x02, 0x11, 0x01, 0x01, 0x01]),
        ];
        for (data, encoded) in cases {
            let mut buf = encoded.to_vec();
            let n = cobs_decode_in_place(&mut buf).unwrap();
            assert_eq!(&buf[..n], data);
            let mut out = [0u8; 16];
            let m = cobs::try_encode(data, &mut out).unwrap();
            assert_eq!(&out[..m], encoded);
        }
        // 254 non-zero bytes: one full 0xFF block, no trailing zero.
        let data: std::vec::Vec<u8> = (1..=254).collect();
        let mut buf = std::vec![0xFFu8];
        buf.extend(&data);
        let n = cobs_decode_in_place(&mut buf).unwrap();
        assert_eq!(&buf[..n], &data[..]);
    }

    /// Same accept/reject decision, length and bytes as `cobs::decode_in_place` (the
    /// reference implementation this replaces) on valid encodings of random data and on
    /// random garbage, including zero bytes and codes that run past the end.
    #[test]
    fn cobs_decoder_matches_the_cobs_crate() {
        let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
        let mut next = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        let (mut valid, mut invalid) = (0, 0);
        for case in 0..20_000 {
            let len = (next() % 600) as usize;
            let mut bytes: std::vec::Vec<u8> = (0..len).map(|_| next() as u8).collect();
            if case % 2 == 0 {
                // Sparse zeros make long runs (0xFF blocks).
                for b in bytes.iter_mut() {
                    if *b < 250 && next() % 4 != 0 {
                        *b = (*b).max(1);
                    }
                }
                let mut enc = std::vec![0u8; cobs::max_encoding_length(len) + 1];
                let n = cobs::try_encode(&bytes, &mut enc).unwrap();
                enc.truncate(n);
                bytes = enc;
            }
            let mut ours = bytes.clone();
            let mut theirs = bytes.clone();
            let a = cobs_decode_in_place(&mut ours);
            let b = cobs::decode_in_place(&mut theirs).ok();
            assert_eq!(a, b, "case {case}: {bytes:02x?}");
            if let Some(n) = a {
                assert_eq!(ours[..n], theirs[..n]);
                valid += 1;
            } else {
                invalid += 1;
            }
        }
        assert!(valid > 10_000 && invalid > 1_000, "valid {valid}, invalid {invalid}");
    }

    #[test]
    fn round_trip_every_message_kind() {
        let msgs = [
            HostMsg::Hello { protocol_version: PROTOCOL_VERSION, schema_hash: schema_hash() },
            HostMsg::UploadParams(FlightParams::default()),
            sensor(7),
            HostMsg::SetTarget { target_q_xyzw: [0.0, 0.0, 0.42, 0.9] },
            HostMsg::StartRealTime,
        ];
        let mut acc = FrameAccumulator::<MAX_FRAME>::new();
        for m in &msgs {
            let f = enc(m);
            assert_eq!(f.iter().filter(|b| **b == 0).count(), 1, "only the delimiter is zero");
            assert!(f.len() <= MAX_FRAME);
            let got = feed(&mut acc, &f);
            assert_eq!(got, vec![Ok(m.clone())]);
        }
        assert_eq!(acc.stats.frames_ok, msgs.len() as u32);
    }

    #[test]
    fn largest_messages_fit() {
        let mut raw = [0u8; 2048];
        let n = postcard::to_slice(&HostMsg::UploadParams(FlightParams::default()), &mut raw).unwrap().len();
        assert!(n <= MAX_PAYLOAD, "{n}");
        let step = FswMsg::Step(StepReport {
            cmd: ActuatorCommand { seq: u32::MAX, status: u16::MAX, ..Default::default() },
            step_cost_ticks: u32::MAX,
            deadline_misses: u32::MAX,
            frames_dropped: u32::MAX,
            seq_refused: u32::MAX,
            timeline: TimelineTelemetry { segments: u8::MAX, in_force: u8::MAX, met: u16::MAX, missed: u16::MAX },
        });
        assert!(postcard::to_slice(&step, &mut raw).unwrap().len() <= MAX_PAYLOAD);
    }

    #[test]
    fn every_single_bit_flip_is_dropped_and_the_next_frame_decodes() {
        let good = enc(&sensor(1));
        let next = enc(&sensor(2));
        let body_len = good.len() - 1;
        for byte in 0..body_len {
            for bit in 0..8 {
                let mut bad = good.clone();
                bad[byte] ^= 1 << bit;
                let mut acc = FrameAccumulator::<MAX_FRAME>::new();
                let mut stream = bad.clone();
                stream.extend_from_slice(&next);
                let got = feed(&mut acc, &stream);
                // A flip may create an extra zero (splitting the frame): every piece before
                // the good frame must be an error, and the good frame must come through.
                let (last, before) = got.split_last().unwrap();
                assert_eq!(last, &Ok(sensor(2)), "flip {byte}:{bit}");
                assert!(before.iter().all(|r| r.is_err()), "flip {byte}:{bit} produced a message");
                assert_eq!(acc.stats.dropped() as usize, before.len());
                assert!(acc.stats.dropped() >= 1 || bad[byte] == 0);
            }
        }
    }

    #[test]
    fn truncation_garbage_and_oversize_are_counted_then_resync() {
        let good = enc(&sensor(3));
        let mut acc = FrameAccumulator::<MAX_FRAME>::new();
        // Truncated frame followed by its delimiter.
        let mut s = good[..good.len() / 2].to_vec();
        s.push(0);
        // Garbage between frames (non-zero bytes, then a delimiter).
        s.extend_from_slice(&[0x55, 0xAA, 0x13, 0x37, 0x00]);
        // Oversize: more non-zero bytes than the buffer holds.
        s.extend(std::iter::repeat_n(0x42, MAX_FRAME + 10));
        s.push(0);
        s.extend_from_slice(&good);
        let got = feed(&mut acc, &s);
        assert_eq!(got.len(), 4);
        assert!(got[..3].iter().all(|r| r.is_err()));
        assert_eq!(got[2], Err(FrameError::Oversize));
        assert_eq!(got[3], Ok(sensor(3)));
        assert_eq!(acc.stats.dropped(), 3);
        assert_eq!(acc.stats.oversize, 1);
    }

    #[test]
    fn valid_crc_but_wrong_payload_is_a_decode_error() {
        // A frame with a correct CRC over bytes that are not a HostMsg (enum tag 200).
        let body = [200u8, 1, 2, 3];
        let mut raw = body.to_vec();
        raw.extend_from_slice(&CRC32.checksum(&body).to_le_bytes());
        let mut out = [0u8; 32];
        let n = cobs::encode(&raw, &mut out);
        let mut f = out[..n].to_vec();
        f.push(0);
        let mut acc = FrameAccumulator::<MAX_FRAME>::new();
        assert_eq!(feed(&mut acc, &f), vec![Err(FrameError::Decode)]);
        assert_eq!(acc.stats.decode, 1);
    }

    /// A valid Sensor message followed by 1, 2 or 17 junk bytes, all under a correct CRC:
    /// refused and counted as `decode` (one message per frame, nothing else); the same
    /// message without the junk, and the next frame, still decode.
    #[test]
    fn crc_valid_frame_with_trailing_junk_is_refused_and_counted() {
        let mut acc = FrameAccumulator::<MAX_FRAME>::new();
        let msg = sensor(7);
        let mut buf = [0u8; MAX_PAYLOAD];
        let body = postcard::to_slice(&msg, &mut buf).unwrap();
        for (k, junk) in [&[0x00u8][..], &[0xAB, 0xCD], &[0x5A; 17]].iter().enumerate() {
            let mut raw = [&*body, junk].concat();
            raw.extend_from_slice(&CRC32.checksum(&raw).to_le_bytes());
            let mut out = [0u8; MAX_FRAME];
            let n = cobs::encode(&raw, &mut out);
            let f = [&out[..n], &[0u8]].concat();
            assert_eq!(feed(&mut acc, &f), vec![Err(FrameError::Decode)], "junk {junk:?}");
            assert_eq!(acc.stats.decode, k as u32 + 1);
            assert_eq!(feed(&mut acc, &enc(&msg)), vec![Ok(msg.clone())]);
        }
        assert_eq!((acc.stats.dropped(), acc.stats.frames_ok), (3, 3));
    }

    #[test]
    fn schema_hash_is_stable_and_nonzero() {
        assert_eq!(schema_hash(), schema_hash());
        assert_ne!(schema_hash(), 0);
    }
}
