//! One solver stepping the bench's scene in a thread pool of its own, as the node runtime
//! drives it: what every kind of row (plain, `--paired`, `--ranks`) times.

use fluid_node::sph::SphSolver;
use fluid_node::validation::{self, TempRunDir, build};
use rayon::ThreadPool;
use shared::coupling::step::StepRule;
use shared::protocol::BlockLoad;
use shared::scene::Scene;
use std::time::Instant;

/// Timed steps of a row by default: about 3·10⁶ particle-steps, from 3 to 200 steps.
pub fn default_steps(particles: usize) -> usize {
    (3_000_000 / particles.max(1)).clamp(3, 200)
}

/// A solver in its own pool, and where it stands.
pub struct Bench {
    pool: ThreadPool,
    pub solver: Box<dyn SphSolver>,
    rule: StepRule,
    end: f64,
    time: f64,
    loads: Vec<BlockLoad>,
    /// The run directory (removed when dropped).
    _dir: TempRunDir,
}

impl Bench {
    /// Solver `name` on scene `sc` in a pool of `threads` threads (built there, as the node
    /// builds it); exits with the solver's error if it cannot be built.
    pub fn new(threads: usize, name: &str, sc: &Scene) -> Self {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("thread pool");
        let dir = TempRunDir::new("bench").expect("temp dir");
        let solver = pool
            .install(|| build(name, sc, dir.path()))
            .unwrap_or_else(|e| {
                eprintln!("fluid-bench: {name}: {e}");
                std::process::exit(2)
            });
        Self {
            pool,
            solver,
            // Granted as the coupler grants it, towards the scene's end (never reached).
            rule: StepRule::new(sc.time.dt_max, sc.time.dt_min),
            end: sc.time.end,
            time: 0.0,
            loads: Vec::new(),
            _dir: dir,
        }
    }

    /// Takes `steps` steps on a worker of its pool (as the node does); returns their seconds.
    pub fn run(&mut self, steps: usize) -> f64 {
        let Self {
            pool,
            solver,
            rule,
            end,
            time,
            loads,
            ..
        } = self;
        pool.install(|| {
            let start = Instant::now();
            for _ in 0..steps {
                *time = validation::step(solver.as_mut(), rule, *time, *end, loads)
                    .unwrap_or_else(|e| {
                        // Every rank of a `--ranks` run stops at the same step (same bits).
                        eprintln!(
                            "fluid-bench: the dam break stopped at t = {time:.4} s: {e} (time fewer steps, or from an earlier --from)"
                        );
                        std::process::exit(1)
                    })
                    .0;
            }
            start.elapsed().as_secs_f64()
        })
    }

    /// Untimed: 3 steps (the reused buffers reach their size), then on until `from` simulated
    /// seconds.
    pub fn warm_up(&mut self, from: f64) {
        self.run(3);
        while self.solver.system().time < from {
            self.run(1);
        }
    }
}
