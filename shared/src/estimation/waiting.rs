//! Samples taken after the filter's newest time, waiting for the gyro to catch up.
//!
//! The history's now is the gyro's newest sample time. A gyro that reports later than
//! another sensor (an IMU with 100 µs of latency against a Sun sensor with none, a slower
//! gyro grid) leaves that sensor's newest samples *ahead* of the filter: they cannot be
//! fused yet, and they are not wrong. They wait here, per sensor, until a gyro sample at or
//! after their time arrives; the estimation stage ([`super::determination`]) then fuses
//! them at their own time, in time order across the sensors, while it carries the history
//! to the gyro's time ([`super::history::History::fuse_ahead`]: no replay).
//!
//! Bounded, no heap: [`WAITING_PER_SENSOR`] samples per sensor, oldest first. A full queue
//! refuses the new sample (the caller counts it: a final refusal): the oldest waiting are
//! the next the gyro reaches, so a gyro lagging beyond the queue still has some of the
//! sensor's samples fused, not none.
//! Worst case per step: every queue due at once, [`MAX_WAITING`] samples fused, each one
//! propagation and one update (docs/estimation-timing.md).

use super::history::Measurement;

/// Samples one sensor may have waiting. A sensor delivers at most one new sample per frame,
/// so this covers a gyro that lags the sensor by up to 4 control periods (fewer samples
/// when the sensor, or its coarse-update interval, is slower; the loader checks a
/// scenario's timing against it).
pub const WAITING_PER_SENSOR: usize = 4;

/// Sensors whose samples may wait: star tracker, fine Sun sensor, coarse sun sensors,
/// magnetometer (in that order: the order of the stage's updates at equal times).
pub const WAITING_SENSORS: usize = 4;

/// Most samples waiting at once, and most fused in one step.
pub const MAX_WAITING: usize = WAITING_PER_SENSOR * WAITING_SENSORS;

/// One waiting sample: its time on the flight clock, µs, and what to fuse.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Waiting {
    pub t_us: u64,
    pub measurement: Measurement,
}

/// What [`WaitQueue::push`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pushed {
    /// Queued.
    Queued,
    /// Not queued: the sensor's queue is full.
    Full,
    /// Not queued: not newer than the sensor's newest waiting sample (out of order).
    OutOfOrder,
}

/// The waiting samples of every sensor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WaitQueue {
    /// Per sensor, oldest first, packed from slot 0.
    slots: [[Option<Waiting>; WAITING_PER_SENSOR]; WAITING_SENSORS],
}

// The RAM it costs on the flight computer (16 slots of 64 B on the M4F).
const _: () = assert!(core::mem::size_of::<WaitQueue>() <= 1280);

impl Default for WaitQueue {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl WaitQueue {
    pub const EMPTY: Self = Self { slots: [[None; WAITING_PER_SENSOR]; WAITING_SENSORS] };

    /// Queue `w` for sensor `sensor` (< [`WAITING_SENSORS`]; others are ignored as out of
    /// order). A sensor's samples come in time order, so its queue stays sorted.
    pub fn push(&mut self, sensor: usize, w: Waiting) -> Pushed {
        let Some(q) = self.slots.get_mut(sensor) else { return Pushed::OutOfOrder };
        let len = q.iter().take_while(|s| s.is_some()).count();
        let newest = len.checked_sub(1).and_then(|i| q.get(i)).copied().flatten();
        if newest.is_some_and(|n| w.t_us <= n.t_us) {
            return Pushed::OutOfOrder;
        }
        match q.get_mut(len) {
            Some(slot) => {
                *slot = Some(w);
                Pushed::Queued
            }
            None => Pushed::Full,
        }
    }

    /// Take the earliest waiting sample taken at or before `t_us` (at equal times the
    /// sensor first in [`WAITING_SENSORS`] order), with its sensor.
    pub fn pop_due(&mut self, t_us: u64) -> Option<(usize, Waiting)> {
        let mut best: Option<(usize, Waiting)> = None;
        for (i, q) in self.slots.iter().enumerate() {
            if let Some(w) = q.first().copied().flatten().filter(|w| w.t_us <= t_us)
                && best.is_none_or(|(_, b)| w.t_us < b.t_us)
            {
                best = Some((i, w));
            }
        }
        let (i, _) = best?;
        if let Some(q) = self.slots.get_mut(i) {
            q.rotate_left(1);
            if let Some(last) = q.last_mut() {
                *last = None;
            }
        }
        best
    }

    /// Time of the newest sample waiting for `sensor`.
    pub fn newest_us(&self, sensor: usize) -> Option<u64> {
        self.slots.get(sensor).and_then(|q| q.iter().rev().find_map(|s| s.map(|w| w.t_us)))
    }

    /// Samples waiting.
    pub fn len(&self) -> usize {
        self.slots.iter().flatten().filter(|s| s.is_some()).count()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Forget every waiting sample; returns how many there were.
    pub fn clear(&mut self) -> usize {
        let n = self.len();
        *self = Self::EMPTY;
        n
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;

    fn w(t_us: u64) -> Waiting {
        Waiting { t_us, measurement: Measurement::Vector { body: Vec3::x(), reference: Vec3::x(), sigma_rad: 0.01 } }
    }

    #[test]
    fn samples_leave_in_time_order_across_sensors_ties_by_sensor_order() {
        let mut q = WaitQueue::EMPTY;
        assert_eq!(q.push(3, w(10)), Pushed::Queued);
        assert_eq!(q.push(0, w(20)), Pushed::Queued);
        assert_eq!(q.push(2, w(10)), Pushed::Queued);
        assert_eq!(q.push(3, w(30)), Pushed::Queued);
        assert_eq!(q.len(), 4);
        assert_eq!(q.pop_due(5), None);
        let order: Vec<(usize, u64)> = core::iter::from_fn(|| q.pop_due(25)).map(|(s, w)| (s, w.t_us)).collect();
        assert_eq!(order, [(2, 10), (3, 10), (0, 20)]);
        assert_eq!(q.newest_us(3), Some(30));
        assert_eq!(q.pop_due(u64::MAX).map(|(s, w)| (s, w.t_us)), Some((3, 30)));
        assert!(q.is_empty());
    }

    #[test]
    fn a_full_queue_refuses_the_new_sample_and_out_of_order_ones() {
        let mut q = WaitQueue::EMPTY;
        for k in 0..WAITING_PER_SENSOR as u64 {
            assert_eq!(q.push(1, w(k)), Pushed::Queued);
        }
        assert_eq!(q.push(1, w(100)), Pushed::Full);
        assert_eq!(q.push(1, w(3)), Pushed::OutOfOrder);
        assert_eq!(q.push(7, w(200)), Pushed::OutOfOrder);
        let left: Vec<u64> = core::iter::from_fn(|| q.pop_due(u64::MAX)).map(|(_, w)| w.t_us).collect();
        assert_eq!(left, [0, 1, 2, 3]);
        assert_eq!(q.push(1, w(5)), Pushed::Queued);
        assert_eq!(q.clear(), 1);
    }
}
