//! Transport delay of the samples, in seconds: each sensor's samples wait in a bounded
//! queue from their time tag until `tag + latency`, then the frame takes them.

use std::collections::VecDeque;

/// Most samples one sensor may have in flight (the loader refuses a scenario whose
/// `⌈latency_s × rate_hz⌉ + 2` exceeds it, naming both keys). 100,000: a 10 kHz sensor
/// 10 s late; at most 6.4 MB per sensor, and only what is really in flight is allocated
/// (a sensor samples at most once per dynamics substep, whatever its rate).
pub const MAX_SAMPLES_IN_FLIGHT: usize = 100_000;

/// Samples allocated up front per queue (it grows, up to its cap, only if needed).
const INITIAL_CAPACITY: usize = 64;

/// `⌈latency × rate⌉ + 2`, the cap of a queue (see [`SampleQueue`]); `None` when not a
/// finite count (a non-finite or absurd product).
pub fn in_flight_cap(latency_s: f64, rate_hz: f64) -> Option<usize> {
    let n = (latency_s * rate_hz).ceil();
    (0.0..1e15).contains(&n).then(|| n as usize + 2)
}

/// One sample on its way: its time tag (the time the truth was sampled, µs) and the time
/// it becomes available (µs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pending<T> {
    pub tag_us: u64,
    pub available_us: u64,
    pub value: T,
}

/// The samples of one sensor taken but not yet arrived, oldest first (the suite moves the
/// arrived ones out before it pushes a new one). The cap `⌈latency × rate⌉ + 2` bounds the
/// memory whatever the run's length: the samples in flight were taken within the last
/// `latency`, and a window that long holds at most `⌈(latency + 2 jitter) × rate⌉ + 1 ≤
/// ⌈latency × rate⌉ + 2` jittered grid points (jitter < half a period; a sample is at most
/// one substep late, and one boundary samples once). Should the cap ever be reached the
/// oldest sample is dropped (and counted in `dropped`). The cap is at most
/// [`MAX_SAMPLES_IN_FLIGHT`] (validated inputs; clamped here too) and memory grows only
/// with the samples really in flight.
#[derive(Clone, Debug)]
pub struct SampleQueue<T> {
    latency_us: u64,
    cap: usize,
    pending: VecDeque<Pending<T>>,
    /// Samples dropped at the cap (0 in a consistent configuration).
    pub dropped: u64,
    /// Most samples held at once so far.
    pub max_len: usize,
}

impl<T: Copy> SampleQueue<T> {
    pub fn new(latency_s: f64, rate_hz: f64) -> Self {
        let cap = in_flight_cap(latency_s, rate_hz).unwrap_or(MAX_SAMPLES_IN_FLIGHT).min(MAX_SAMPLES_IN_FLIGHT);
        Self {
            latency_us: (latency_s * 1e6).round() as u64,
            cap,
            pending: VecDeque::with_capacity(cap.min(INITIAL_CAPACITY)),
            dropped: 0,
            max_len: 0,
        }
    }

    /// Most samples held at once.
    pub fn cap(&self) -> usize {
        self.cap
    }

    /// Samples waiting now.
    pub fn len(&self) -> usize {
        self.pending.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pending.is_empty()
    }

    /// A sample of the truth at `tag_us`; available `latency` later.
    pub fn push(&mut self, tag_us: u64, value: T) {
        if self.pending.len() >= self.cap {
            self.pending.pop_front();
            self.dropped += 1;
        }
        self.pending.push_back(Pending { tag_us, available_us: tag_us + self.latency_us, value });
        self.max_len = self.max_len.max(self.pending.len());
    }

    /// The oldest sample available at `now_us`, taken off the queue.
    pub fn pop_available(&mut self, now_us: u64) -> Option<Pending<T>> {
        if self.pending.front()?.available_us <= now_us { self.pending.pop_front() } else { None }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_arrive_after_their_latency_in_order() {
        let mut q = SampleQueue::new(0.13, 10.0);
        assert_eq!(q.cap(), 4);
        q.push(0, 'a');
        q.push(100_000, 'b');
        assert_eq!(q.pop_available(129_999), None);
        assert_eq!(q.pop_available(130_000).map(|p| (p.tag_us, p.value)), Some((0, 'a')));
        assert_eq!(q.pop_available(130_000), None);
        assert_eq!(q.pop_available(230_000).map(|p| p.value), Some('b'));
        assert!(q.is_empty());
    }

    #[test]
    fn the_cap_is_bounded_and_nothing_large_is_allocated_up_front() {
        // Issue 37: 1e8 Hz × 10 s used to allocate a billion samples at construction.
        let q: SampleQueue<[f64; 6]> = SampleQueue::new(10.0, 1e8);
        assert_eq!(q.cap(), MAX_SAMPLES_IN_FLIGHT);
        assert!(q.pending.capacity() <= 2 * INITIAL_CAPACITY, "{}", q.pending.capacity());
        assert_eq!(in_flight_cap(10.0, 1e8), Some(1_000_000_002));
        assert_eq!(in_flight_cap(0.3, 2.0), Some(3));
        assert_eq!((in_flight_cap(f64::INFINITY, 1.0), in_flight_cap(1e300, 1e300)), (None, None));
    }
}
