//! Transport delay of a measurement, in whole control steps.

use std::collections::VecDeque;

/// The last `steps + 1` values pushed, oldest first: [`DelayLine::delay`] returns the
/// value of `steps` pushes ago.
pub struct DelayLine<T> {
    steps: usize,
    history: VecDeque<T>,
}

impl<T: Copy> DelayLine<T> {
    pub fn new(steps: usize) -> Self {
        Self { steps, history: VecDeque::new() }
    }

    /// Push this step's value and return the one `steps` steps old; before that many
    /// exist, the first value pushed (the sensor's first output held). No delay: the value
    /// itself, and no history is kept.
    pub fn delay(&mut self, now: T) -> T {
        if self.steps == 0 {
            return now;
        }
        self.history.push_back(now);
        while self.history.len() > self.steps + 1 {
            self.history.pop_front();
        }
        self.history.front().copied().unwrap_or(now)
    }
}
