//! Host ↔ flight-computer link: message types and framing.
//!
//! A frame on the wire is `COBS(postcard(msg) ‖ crc32_le) ‖ 0x00`. The zero byte only
//! ever appears as the delimiter, so a receiver that lost sync simply waits for the next
//! zero. [`FrameAccumulator`] does that, counts every bad frame by kind and goes on.
//!
//! Session: host sends `Hello` (protocol version and schema hash must match), then
//! `UploadParams` (validated; rejected with the offending field) — or, for a mode table,
//! one `UploadModeParams` per mode and `ArmModes` — then one `Sensor` frame per control
//! step; the flight side answers each with a `Step` report. Every other message gets
//! exactly one reply.
//!
//! Wire types are plain arrays of f32/u32 so that no layout depends on a math library.

use crate::modes::{Mode, ModeManagerParams, ModeRequest};
use crate::params::{CRC32, FlightParams, MAX_THRUSTERS, MAX_WHEELS, ParamError};
use postcard_schema::Schema;
use serde::{Deserialize, Serialize};

/// Bumped whenever a message changes; the schema hash catches forgotten bumps.
pub const PROTOCOL_VERSION: u16 = 9;

/// Largest postcard payload of any message (checked by a test).
pub const MAX_PAYLOAD: usize = 768;
/// Largest frame on the wire: COBS overhead + CRC + delimiter.
pub const MAX_FRAME: usize = MAX_PAYLOAD + 4 + MAX_PAYLOAD / 254 + 2;

/// `SensorFrame::valid` bits.
pub mod valid {
    pub const ATTITUDE: u16 = 1 << 0;
    pub const RATE: u16 = 1 << 1;
    pub const GIMBALS: u16 = 1 << 2;
    pub const WHEELS: u16 = 1 << 3;
    pub const MAG: u16 = 1 << 4;
    pub const SUN: u16 = 1 << 5;
    /// `q_ref_xyzw` and `ref_rate_rad_s` (navigation solution) are valid.
    pub const REFERENCE: u16 = 1 << 6;
    pub const ALL: u16 = ATTITUDE | RATE | GIMBALS | WHEELS | MAG | SUN | REFERENCE;
}

/// `ActuatorCommand::status` bits.
pub mod status {
    /// The torque demand exceeded its limit and was scaled (direction kept).
    pub const TORQUE_LIMITED: u16 = 1 << 0;
    /// Gimbal rates were scaled to the rate limit (direction kept).
    pub const RATE_SCALED: u16 = 1 << 1;
    /// At least one gimbal sat at its angle limit and its rate was zeroed.
    pub const ANGLE_LIMITED: u16 = 1 << 2;
    /// The steering matrix was singular for the chosen law (MP): safe zero rates.
    pub const SINGULAR: u16 = 1 << 3;
    /// The sensor frame was invalid (NaN, non-unit quaternion, flags): safe command held.
    pub const BAD_INPUT: u16 = 1 << 4;
    /// The realised torque differs from the demand by more than 1 % of its norm.
    pub const TORQUE_SHORTFALL: u16 = 1 << 5;
    /// The flight code is not configured (no accepted parameters): safe command.
    pub const NOT_CONFIGURED: u16 = 1 << 6;
    /// Real-time mode: no fresh sensor frame, the safe command is held.
    pub const HOLD: u16 = 1 << 7;
    /// The allocation failed (infeasible, iteration cap, non-finite): its documented
    /// safe fallback was commanded.
    pub const ALLOC_FALLBACK: u16 = 1 << 8;
    /// Some actuator cannot realise its command (magnetorquer dead band, wheel at its
    /// speed limit).
    pub const UNREALISED: u16 = 1 << 9;
    /// CMG cluster at its momentum envelope (saturation singularity): no more torque
    /// along the singular direction; momentum must be dumped.
    pub const MOMENTUM_SATURATION: u16 = 1 << 10;
    /// The control law produced a non-finite demand (overflow from extreme gains or
    /// states): zero torque was allocated and the law's state reset.
    pub const LAW_FAULT: u16 = 1 << 11;
}

/// One sample of everything the flight code reads, taken at `time_us`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SensorFrame {
    pub seq: u32,
    pub time_us: u64,
    /// Measured attitude `q_ib`, scalar-last.
    pub q_ib_xyzw: [f32; 4],
    /// Measured body rate, body axes.
    pub rate_rad_s: [f32; 3],
    /// Measured gimbal angles of the four CMGs.
    pub gimbal_angle_rad: [f32; 4],
    /// Measured wheel speeds relative to the body.
    pub wheel_speed_rad_s: [f32; MAX_WHEELS],
    /// Magnetometer, body axes, T.
    pub mag_field_t: [f32; 3],
    /// Sun direction, body axes (unit).
    pub sun_dir: [f32; 3],
    /// Navigation solution: the reference frame (e.g. LVLH) relative to inertial,
    /// scalar-last, and its angular velocity in inertial axes.
    pub q_ref_xyzw: [f32; 4],
    pub ref_rate_rad_s: [f32; 3],
    /// [`valid`] bits.
    pub valid: u16,
}

impl SensorFrame {
    /// A frame with nothing valid yet (identity attitudes, zeros).
    pub const fn empty(seq: u32, time_us: u64) -> Self {
        Self {
            seq,
            time_us,
            q_ib_xyzw: [0.0, 0.0, 0.0, 1.0],
            rate_rad_s: [0.0; 3],
            gimbal_angle_rad: [0.0; 4],
            wheel_speed_rad_s: [0.0; MAX_WHEELS],
            mag_field_t: [0.0; 3],
            sun_dir: [0.0; 3],
            q_ref_xyzw: [0.0, 0.0, 0.0, 1.0],
            ref_rate_rad_s: [0.0; 3],
            valid: 0,
        }
    }
}

/// What one control step decided, plus what it achieved.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ActuatorCommand {
    /// Sequence number of the sensor frame this answers.
    pub seq: u32,
    pub gimbal_rate_cmd_rad_s: [f32; 4],
    /// Motor torque on each wheel rotor (the body receives the reaction), N m.
    pub wheel_torque_cmd_nm: [f32; MAX_WHEELS],
    /// Magnetorquer dipole command, body axes, A m².
    pub dipole_cmd_am2: [f32; 3],
    /// Bit i: thruster i open during the next control period (after PWPF).
    pub thruster_on: u16,
    /// Allocated thrust level in [0, 1] per thruster (the PWPF input).
    pub thruster_level: [f32; MAX_THRUSTERS],
    /// Torque the control law asked for (after its own limit), body axes.
    pub torque_demand_nm: [f32; 3],
    /// Torque the commands produce according to the flight code's actuator model
    /// (CMG: eq 4 with `ω × h`; thrusters: the allocated level, before modulation).
    pub torque_realised_nm: [f32; 3],
    /// `det(J Jᵀ)` with unit rotor momentum.
    pub singularity_measure: f32,
    /// SR weight α used this step (0 for Moore-Penrose).
    pub steering_alpha: f32,
    /// Rotation angle of the attitude error, rad.
    pub attitude_error_rad: f32,
    /// Allocation iterations (simplex pivots, wheel re-allocation passes).
    pub alloc_iterations: u16,
    /// Internal state of the control law worth plotting (DMCS: the adaptive feed-forward
    /// gains Δk_u per axis; other laws: 0).
    pub law_telemetry: [f32; 3],
    /// Bit i: actuator i at a limit (either side).
    pub saturated: u32,
    /// [`status`] bits.
    pub status: u16,
    /// Mode in force ([`Mode::code`](crate::modes::Mode::code)); 0 without a mode table.
    pub mode: u8,
    /// Why it was entered ([`Reason`](crate::modes::Reason) as `u8`).
    pub mode_reason: u8,
    /// Mode transitions since the table was armed (saturating).
    pub mode_transitions: u16,
}

/// A step's command and what the flight computer measured while producing it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StepReport {
    pub cmd: ActuatorCommand,
    /// Cost of `Fsw::step` in ticks of the cost counter (see `HelloAck`); 0 = not measured.
    pub step_cost_ticks: u32,
    /// Real-time mode: control periods that ended before the step finished.
    pub deadline_misses: u32,
    /// Frames the flight side dropped so far (CRC, COBS, decode, oversize).
    pub frames_dropped: u32,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LinkError {
    ProtocolVersion {
        flight: u16,
    },
    SchemaHash {
        flight: u32,
    },
    NotConfigured,
    UnexpectedMessage,
    /// A target that is not a unit quaternion.
    BadTarget,
    /// A mode command without an armed table, or for a mode the table does not have.
    NoSuchMode,
}

/// Host → flight computer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum HostMsg {
    Hello {
        protocol_version: u16,
        schema_hash: u32,
    },
    /// A single parameter set (no mode manager). Reply: `ParamsAccepted`/`ParamsRejected`.
    UploadParams(FlightParams),
    Sensor(SensorFrame),
    /// New mission target (the manoeuvre/hold target with a mode table). Reply: `Ack`.
    SetTarget {
        target_q_xyzw: [f32; 4],
    },
    /// One mode's parameter set of a mode table (one message per mode keeps every message
    /// within `MAX_PAYLOAD`). Reply: `ParamsAccepted`/`ParamsRejected`.
    UploadModeParams {
        mode: Mode,
        params: FlightParams,
    },
    /// Arm the uploaded table with its transition thresholds. Reply: `ModesArmed`/`ParamsRejected`.
    ArmModes(ModeManagerParams),
    /// Ground mode command. Reply: `ModeAccepted`/`Error(NoSuchMode)`.
    CommandMode(ModeRequest),
    /// Real-time mode only: start pacing steps with the flight computer's own clock.
    StartRealTime,
}

/// Flight computer → host.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, Schema)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FswMsg {
    HelloAck {
        protocol_version: u16,
        schema_hash: u32,
        params_version: u16,
        /// Frequency of the counter `step_cost_ticks` is read from, Hz.
        cost_counter_hz: u32,
        /// 0 = in-process (host), 1 = QEMU mps2-an386, 2 = STM32F405.
        board: u8,
    },
    ParamsAccepted {
        checksum: u32,
    },
    ParamsRejected(ParamError),
    ModesArmed {
        checksum: u32,
    },
    ModeAccepted {
        mode: Mode,
    },
    /// Success of a message that has no other reply (`SetTarget`).
    Ack,
    Step(StepReport),
    Error(LinkError),
}

/// A `postcard::ser_flavors::Flavor` that only feeds a CRC digest.
struct CrcSink<'a>(crc::Digest<'a, u32>);

impl postcard::ser_flavors::Flavor for CrcSink<'_> {
    type Output = u32;
    fn try_push(&mut self, data: u8) -> postcard::Result<()> {
        self.0.update(&[data]);
        Ok(())
    }
    fn try_extend(&mut self, data: &[u8]) -> postcard::Result<()> {
        self.0.update(data);
        Ok(())
    }
    fn finalize(self) -> postcard::Result<u32> {
        Ok(self.0.finalize())
    }
}

/// CRC-32 of the postcard-schema description of both message enums: any change of a
/// field, type, order or name of a wire type changes it.
pub fn schema_hash() -> u32 {
    let mut d = CRC32.digest();
    for s in [HostMsg::SCHEMA, FswMsg::SCHEMA] {
        let sink = CrcSink(CRC32.digest());
        if let Ok(h) = postcard::serialize_with_flavor(s, sink) {
            d.update(&h.to_le_bytes());
        }
    }
    d.finalize()
}

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
    /// CRC fine but the payload is not a valid message.
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
    let (body, _) = raw.split_at_mut(n.min(MAX_PAYLOAD));
    let crc = CRC32.checksum(body).to_le_bytes();
    let total = n + 4;
    let Some(dst) = raw.get_mut(n..total) else {
        return Err(FrameError::BufferTooSmall);
    };
    dst.copy_from_slice(&crc);
    let Some(src) = raw.get(..total) else {
        return Err(FrameError::BufferTooSmall);
    };
    if out.len() < cobs::max_encoding_length(total) + 1 {
        return Err(FrameError::BufferTooSmall);
    }
    let enc = cobs::encode(src, out);
    let Some(delim) = out.get_mut(enc) else {
        return Err(FrameError::BufferTooSmall);
    };
    *delim = 0;
    out.get(..enc + 1).ok_or(FrameError::BufferTooSmall)
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
                    self.len += 1;
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
        let n = cobs::decode_in_place(frame).map_err(|_| FrameError::Cobs)?;
        let data = frame.get(..n).ok_or(FrameError::Cobs)?;
        if n < 5 {
            return Err(FrameError::Short);
        }
        let (body, crc) = data.split_at(n - 4);
        let mut c = [0u8; 4];
        c.copy_from_slice(crc);
        if CRC32.checksum(body) != u32::from_le_bytes(c) {
            return Err(FrameError::Crc);
        }
        postcard::from_bytes(body).map_err(|_| FrameError::Decode)
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

    #[test]
    fn schema_hash_is_stable_and_nonzero() {
        assert_eq!(schema_hash(), schema_hash());
        assert_ne!(schema_hash(), 0);
    }
}
