//! Step-size control (docs/method.md eq. (24)): steps are relative to the amplitude, grow when the
//! corrector converges in fewer iterations than the target and shrink when it needs more, and
//! are halved on any failure until the minimum step.

use super::ContinuationSettings;

/// The arclength step of a continuation and its bounds.
#[derive(Debug, Clone)]
pub struct StepControl {
    step: f64,
    min: f64,
    max: f64,
    target_iterations: usize,
}

impl StepControl {
    /// The first step is `initial_step × amplitude`.
    pub fn new(settings: &ContinuationSettings, amplitude: f64) -> Self {
        Self {
            step: settings.initial_step * amplitude,
            min: settings.min_step,
            max: settings.max_step,
            target_iterations: settings.target_iterations,
        }
    }

    /// The step to try at a point of the given amplitude (clamped to the relative bounds).
    pub fn next(&mut self, amplitude: f64) -> f64 {
        self.step = self.step.clamp(self.min * amplitude, self.max * amplitude);
        self.step
    }

    /// The smallest step allowed at a point of the given amplitude.
    pub fn minimum(&self, amplitude: f64) -> f64 {
        self.min * amplitude
    }

    /// Whether the current step is the smallest allowed: a failure there ends the branch.
    pub fn at_minimum(&self, amplitude: f64) -> bool {
        self.step <= self.min * amplitude * (1.0 + 1e-12)
    }

    /// A failed or suspicious step: retry at half the size.
    pub fn reject(&mut self) {
        self.step *= 0.5;
    }

    /// An accepted step that took `iterations` corrector iterations: fewer than the target →
    /// grow (up to 2×), more → shrink (down to ½×).
    pub fn accept(&mut self, iterations: usize) {
        let ratio = (self.target_iterations.max(1) as f64) / (iterations.max(1) as f64);
        self.step *= ratio.sqrt().clamp(0.5, 2.0);
    }
}
