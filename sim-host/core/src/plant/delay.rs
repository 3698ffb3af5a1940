//! A pure delay of actuator commands by whole steps: the magnetorquer dipoles
//! (`[actuators.magnetorquers] delay_s`, control periods), the wheel torques
//! (`[actuators.wheels] torque_delay_s`, dynamics steps) and the CMG gimbal-rate commands
//! (`[actuators.cmg] rate_delay_s`, control periods). Plant only: the flight code does not
//! know the delay, which is what a margin against it measures (docs/margins.md).

use std::collections::VecDeque;

/// Fed once per step with the command held over it, returns the command of `steps` steps
/// earlier (zeros — actuator off — before the first one arrives). Memory: `steps + 1`
/// commands, allocated once.
#[derive(Clone, Debug, Default)]
pub struct DelayLine<const N: usize> {
    steps: usize,
    queue: VecDeque<[f64; N]>,
}

impl<const N: usize> DelayLine<N> {
    /// A delay of `steps` whole steps.
    pub fn new(steps: usize) -> Self {
        Self { steps, queue: VecDeque::with_capacity(steps.saturating_add(1)) }
    }

    /// A delay of `delay_s` rounded to whole steps of `step_s` (0 for a non-positive
    /// delay or step).
    pub fn from_seconds(delay_s: f64, step_s: f64) -> Self {
        Self::new(if delay_s > 0.0 && step_s > 0.0 { (delay_s / step_s).round() as usize } else { 0 })
    }

    /// The delay in steps.
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// Feeds this step's command, returns the one that acts over it.
    pub fn push(&mut self, cmd: [f64; N]) -> [f64; N] {
        if self.steps == 0 {
            return cmd;
        }
        self.queue.push_back(cmd);
        if self.queue.len() > self.steps { self.queue.pop_front().unwrap_or([0.0; N]) } else { [0.0; N] }
    }
}

#[cfg(test)]
mod tests {
    use super::DelayLine;

    #[test]
    fn delay_shifts_by_whole_steps() {
        // y[k] = x[k − n] for k ≥ n, 0 before: a ramp comes out n steps late.
        for n in [0usize, 1, 3] {
            let mut d = DelayLine::<3>::new(n);
            for k in 0..10usize {
                let x = [k as f64, -(k as f64), 2.0 * k as f64];
                let y = d.push(x);
                let want = if k >= n { ((k - n) as f64) * 1.0 } else { 0.0 };
                assert_eq!(y, [want, -want, 2.0 * want], "n {n} k {k}");
            }
        }
    }
}
