//! Transport delay of the samples, in seconds: each sensor's samples wait in a bounded
//! queue from their time tag until `tag + latency`, then the frame takes them.

use std::collections::VecDeque;

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
/// oldest sample is dropped (and counted in `dropped`).
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
        let cap = (latency_s * rate_hz).ceil() as usize + 2;
        Self {
            latency_us: (latency_s * 1e6).round() as u64,
            cap,
            pending: VecDeque::with_capacity(cap),
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
}
