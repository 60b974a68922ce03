//! A progress bar for long runs: simulated time, steps per second and ETA (indicatif).

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::time::Instant;

/// Draws nothing when disabled or when stderr is not a terminal.
pub struct Progress {
    bar: Option<ProgressBar>,
    started: Instant,
}

/// The bar counts simulated time in microseconds.
const TICKS_PER_SECOND: f64 = 1e6;

impl Progress {
    pub fn new(enabled: bool, end_time: f64) -> Progress {
        let bar = enabled.then(|| {
            let bar = ProgressBar::with_draw_target(
                Some((end_time * TICKS_PER_SECOND) as u64),
                ProgressDrawTarget::stderr(),
            );
            bar.set_style(
                ProgressStyle::with_template("{bar:30} t = {msg} ETA {eta}")
                    .expect("valid template")
                    .progress_chars("=> "),
            );
            bar
        });
        Progress {
            bar,
            started: Instant::now(),
        }
    }

    pub fn update(&self, time: f64, steps: u64) {
        let Some(bar) = &self.bar else { return };
        let rate = steps as f64 / self.started.elapsed().as_secs_f64().max(1e-9);
        bar.set_message(format!("{time:.4} s, {steps} steps, {rate:.0} steps/s"));
        bar.set_position((time * TICKS_PER_SECOND) as u64);
    }

    pub fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish();
        }
    }
}
