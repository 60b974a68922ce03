//! `fluid-bench --phases`: where a timed row's steps went, phase by phase.
//!
//! The rows turn on the solver's [`PhaseClock`] for their timed steps only (warm-up and
//! `--from` steps are not counted) and keep it here; once every row has run, one table per
//! solver and size gives the mean µs per step of each phase the solver entered, one column per
//! thread count, and, when 1 and 2 threads were both timed, their ratio per phase (1-thread
//! time over 2-thread time: the speed-up, as the rows' 2 ÷ 1 of particle-steps/s). The
//! phase tables of docs/PERFORMANCE.md are made with it. With `--ranks`, a column per rank
//! (each rank's own clock; time in messages, waiting included, is the halo phase).
//!
//! "outside the phases" is the row's step time minus the phases' sum: the step grant, the
//! schemes' bookkeeping and the clock's own reads; a few µs when the phases cover the step.

use fluid_node::core::phases::{Phase, PhaseClock};

/// One timed row's phase sums.
pub struct Timed {
    pub solver: String,
    pub particles: usize,
    pub threads: usize,
    /// On ranks (`--ranks`): which rank's steps (a column per rank).
    pub rank: Option<usize>,
    pub steps: usize,
    /// Wall time of the timed steps [s].
    pub secs: f64,
    pub clock: PhaseClock,
}

impl Timed {
    fn per_step_us(&self, secs: f64) -> f64 {
        1e6 * secs / self.steps as f64
    }
}

/// µs with a decimal below 100, none above (a step's phases span 0.1 µs to 10 ms).
fn us(x: f64) -> String {
    if x.abs() < 100.0 {
        format!("{x:.1}")
    } else {
        format!("{x:.0}")
    }
}

/// Prints one table per solver and size, in the order the rows ran.
pub fn print(rows: &[Timed]) {
    let mut groups: Vec<(&str, usize)> = Vec::new();
    for r in rows {
        if !groups.contains(&(&r.solver, r.particles)) {
            groups.push((&r.solver, r.particles));
        }
    }
    for (solver, particles) in groups {
        let cols: Vec<&Timed> = rows
            .iter()
            .filter(|r| r.solver == solver && r.particles == particles)
            .collect();
        let one = cols.iter().position(|r| r.threads == 1 && r.rank.is_none());
        let two = cols.iter().position(|r| r.threads == 2 && r.rank.is_none());
        let ratio = one.zip(two);
        let steps: Vec<String> = cols.iter().map(|r| r.steps.to_string()).collect();
        println!(
            "\nPhases of {solver}, {particles} particles: µs per step, mean over {} timed steps{}",
            steps.join(" / "),
            if ratio.is_some() {
                "; 2 ÷ 1 is the 1-thread time over the 2-thread time"
            } else {
                ""
            }
        );
        println!();
        let head: Vec<String> = cols
            .iter()
            .map(|r| match r.rank {
                Some(k) => format!("rank {k}"),
                None => format!(
                    "{} thread{}",
                    r.threads,
                    if r.threads == 1 { "" } else { "s" }
                ),
            })
            .collect();
        let sep = "---:|".repeat(cols.len() + usize::from(ratio.is_some()));
        println!(
            "| phase | {} |{}",
            head.join(" | "),
            if ratio.is_some() { " 2 ÷ 1 |" } else { "" }
        );
        println!("|---|{sep}");
        let row = |label: &str, values: Vec<f64>| {
            let cells: Vec<String> = values.iter().map(|&v| us(v)).collect();
            // No ratio of phases under a µs (a call that finds nothing to do): clock noise.
            let r = ratio.map_or(String::new(), |(a, b)| {
                if values[a].min(values[b]) >= 1.0 {
                    format!(" {:.2} |", values[a] / values[b])
                } else {
                    " – |".into()
                }
            });
            println!("| {label} | {} |{r}", cells.join(" | "));
        };
        for phase in Phase::ALL {
            if cols.iter().all(|r| r.clock.calls(phase) == 0) {
                continue;
            }
            row(
                phase.label(),
                cols.iter()
                    .map(|r| r.per_step_us(r.clock.total(phase).as_secs_f64()))
                    .collect(),
            );
        }
        row(
            "outside the phases",
            cols.iter()
                .map(|r| r.per_step_us(r.secs - r.clock.sum().as_secs_f64()))
                .collect(),
        );
        row(
            "**step**",
            cols.iter().map(|r| r.per_step_us(r.secs)).collect(),
        );
    }
}
