//! `fluid-bench --paired BLOCK`: a solver's 2 ÷ 1 threads measured in pairs close in time.
//!
//! The plain rows time 1 thread, then 2 threads, a minute apart; on a shared host a single
//! 1-thread row moves by ±15 % from one minute to the next, so one row's ratio says little and
//! a campaign needs many rounds. Here two copies of the same solver on the same scene step in
//! alternation, one in a 1-thread pool and one in a 2-thread pool, BLOCK steps at a time: both
//! see the same flow at the same step (the solvers are deterministic) and every block of one is
//! timed within a second of a block of the other, so a slow second of the machine weighs on
//! both sides of a pair. Reported per solver: both throughputs over all timed steps, their
//! ratio, and the median and range of the per-pair ratios.

use super::bench::{Bench, default_steps};
use super::ceiling::median;
use super::scene::scene;

/// Prints a row per solver and size: 1 and 2 threads in alternating blocks of `block` steps,
/// `steps` timed steps on each side, after `from` simulated seconds (and 3 warm-up steps).
pub fn run(
    solvers: &[String],
    sizes: &[usize],
    params: &[String],
    block: usize,
    from: f64,
    steps: Option<usize>,
) {
    println!(
        "| solver | particles | from t [s] | steps timed per side | pairs | 1 thread [particle-steps/s] | 2 threads [particle-steps/s] | 2 ÷ 1, totals | 2 ÷ 1, median of pairs | range of pairs |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for name in solvers {
        for &n in sizes {
            let sc = scene(name, n, params);
            let mut one = Bench::new(1, name, &sc);
            let mut two = Bench::new(2, name, &sc);
            let count = one.solver.system().len();
            for side in [&mut one, &mut two] {
                side.warm_up(from);
            }
            let block = block.max(1);
            let pairs = steps
                .unwrap_or_else(|| default_steps(count))
                .div_ceil(block)
                .max(1);
            let (mut t1, mut t2, mut ratios) = (0.0, 0.0, Vec::with_capacity(pairs));
            for k in 0..pairs {
                // Which side goes first alternates, so neither always follows the other's
                // cache state.
                let (a, b) = if k % 2 == 0 {
                    let a = one.run(block);
                    (a, two.run(block))
                } else {
                    let b = two.run(block);
                    (one.run(block), b)
                };
                t1 += a;
                t2 += b;
                ratios.push(a / b);
            }
            let (lo, hi) = ratios
                .iter()
                .fold((f64::INFINITY, 0.0_f64), |(l, h), &r| (l.min(r), h.max(r)));
            let timed = pairs * block;
            let rate = |t: f64| (count * timed) as f64 / t;
            println!(
                "| {name} | {count} | {from} | {timed} | {pairs} | {:.3e} | {:.3e} | {:.2} | {:.2} | {lo:.2}–{hi:.2} |",
                rate(t1),
                rate(t2),
                t1 / t2,
                median(ratios)
            );
        }
    }
}
