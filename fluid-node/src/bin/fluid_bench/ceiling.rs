//! `fluid-bench --ceiling ROUNDS`: what 2 threads give over 1 on this machine for loops with no
//! serial part at all, so that the solvers' own 2 ÷ 1 ratios can be read against the machine
//! rather than against 2. Four kernels, each split evenly over the pool by rayon:
//! - `compute`: independent multiply–add chains in registers, no memory traffic (the ideal);
//!   two chains per item, so each waits on its adds' latency;
//! - `throughput`: the same in registers, 24 chains per item, enough to fill a core's
//!   floating-point pipes: 2.0 only on two whole cores. Two hardware threads of one core (or a
//!   host that gives the guest's two cores one between them for a while) get ~1.0 here, where
//!   `compute` still gets 2.0 (the second thread fills the first one's latency);
//! - `stream`: a sum over 48 MB of f32, larger than the last-level cache (as a DFSPH or WCSPH
//!   pass streams its pairs' values and indices at ~3·10⁴ particles);
//! - `gather`: a pair loop's shape: per particle, 64 listed neighbours (indices to nearby
//!   particles), a 3-vector gathered per neighbour and dotted with a streamed f32 value;
//!   the lists and values take 40 MB.
//!
//! And the fixed cost of one parallel region: two items of a few µs each (a chain of 1 000
//! multiply–adds), so that the second thread must take one, timed over 10 000 regions; the
//! cost is the 2-thread time less half the 1-thread time. A solver step runs a few dozen
//! regions.
//!
//! Rounds alternate 1 and 2 threads (each timing the mean of ten calls after an untimed one);
//! each kernel's ratio is the median over rounds of the per-round ratio, so a slow minute on a
//! shared machine weighs on both sides of one ratio.

use rayon::prelude::*;
use std::time::Instant;

/// Particles of the gather kernel and neighbours per particle.
const PARTICLES: usize = 31_250;
const NEIGHBOURS: usize = 64;
/// f32 values of the stream kernel (48 MB).
const STREAM: usize = 12 << 20;
/// Independent chains and their length in the compute kernel.
const CHAINS: usize = 1 << 16;
const LINKS: usize = 500;
/// Items of the throughput kernel and the length of its chains.
const FILL_ITEMS: usize = 1 << 10;
const FILL_LINKS: usize = 2_000;

fn compute() -> f64 {
    (0..CHAINS)
        .into_par_iter()
        .map(|i| {
            let (mut a, mut b) = (i as f64 * 1e-6, 1.0 - i as f64 * 1e-6);
            for _ in 0..LINKS {
                a = a * 0.999_999 + 1e-7;
                b = b * 0.999_998 + 2e-7;
            }
            a + b
        })
        .sum()
}

fn throughput() -> f64 {
    (0..FILL_ITEMS)
        .into_par_iter()
        .map(|i| {
            // 24 chains of two lanes each (the SSE2 baseline's width): a multiply and an add
            // per link, independent across chains, so the pipes never wait.
            let mut a = [[1.0 + i as f64 * 1e-9; 2]; 24];
            for _ in 0..FILL_LINKS {
                for chain in a.iter_mut() {
                    for x in chain.iter_mut() {
                        *x = *x * 0.999_999_9 + 1e-9;
                    }
                }
            }
            a.iter().flatten().sum::<f64>()
        })
        .sum()
}

fn stream(values: &[f32]) -> f64 {
    values
        .par_chunks(1 << 14)
        .map(|c| c.iter().map(|&v| v as f64).sum::<f64>())
        .sum()
}

struct Pairs {
    index: Vec<u32>,
    value: Vec<[f32; 4]>,
    velocity: Vec<[f64; 3]>,
}

impl Pairs {
    /// Neighbours within ±128 places of a particle, as a cell-sorted list gives.
    fn new() -> Self {
        let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        let mut index = Vec::with_capacity(PARTICLES * NEIGHBOURS);
        for i in 0..PARTICLES {
            for _ in 0..NEIGHBOURS {
                let j = i as i64 + (next() % 257) as i64 - 128;
                index.push(j.clamp(0, PARTICLES as i64 - 1) as u32);
            }
        }
        let value = (0..index.len())
            .map(|k| [k as f32 * 1e-7, 0.5, -0.25, 1.0])
            .collect();
        let velocity = (0..PARTICLES)
            .map(|i| [i as f64 * 1e-6, 0.1, 0.2])
            .collect();
        Self {
            index,
            value,
            velocity,
        }
    }

    fn gather(&self) -> f64 {
        self.index
            .par_chunks(NEIGHBOURS)
            .zip(self.value.par_chunks(NEIGHBOURS))
            .map(|(js, vs)| {
                let mut d = 0.0;
                for (&j, o) in js.iter().zip(vs) {
                    let v = &self.velocity[j as usize];
                    d += v[0] * o[0] as f64 + v[1] * o[1] as f64 + v[2] * o[2] as f64;
                }
                d
            })
            .sum()
    }
}

/// A kernel: one call's result (kept, so the work is not optimised away).
type Kernel<'a> = Box<dyn Fn() -> f64 + Sync + 'a>;

/// Mean seconds of a call of `f` over ten calls in a pool of `threads` (a mean, as the
/// solvers' rows are means over their timed steps), after one untimed call.
fn time(threads: usize, f: &(dyn Fn() -> f64 + Sync)) -> f64 {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool");
    pool.install(|| {
        std::hint::black_box(f());
        let t = Instant::now();
        for _ in 0..10 {
            std::hint::black_box(f());
        }
        t.elapsed().as_secs_f64() / 10.0
    })
}

/// The median of `v` (the mean of the middle two for an even count).
pub(super) fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// µs per parallel region of two items of a 1 000-link chain each, in a pool of `threads`
/// (the best of three runs of 10 000 regions).
fn region_us(threads: usize) -> f64 {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool");
    let mut out = [0.0_f64; 2];
    pool.install(|| {
        (0..3)
            .map(|_| {
                let t = Instant::now();
                for k in 0..10_000 {
                    out.par_iter_mut().enumerate().for_each(|(i, o)| {
                        let mut a = (i + k) as f64 * 1e-9;
                        for _ in 0..1_000 {
                            a = a * 0.999_999 + 1e-7;
                        }
                        *o += a;
                    });
                }
                std::hint::black_box(&out);
                t.elapsed().as_secs_f64() * 1e6 / 10_000.0
            })
            .fold(f64::INFINITY, f64::min)
    })
}

/// Prints the table: per kernel, the median 1-thread time, the median 2-thread time and the
/// median and range of the per-round ratio.
pub fn run(rounds: usize) {
    let values: Vec<f32> = (0..STREAM).map(|k| (k % 1000) as f32 * 1e-3).collect();
    let pairs = Pairs::new();
    let kernels: [(&str, Kernel); 4] = [
        ("compute (registers only)", Box::new(compute)),
        ("throughput (registers, pipes full)", Box::new(throughput)),
        ("stream (48 MB of f32)", Box::new(|| stream(&values))),
        (
            "gather (a pair loop's shape, 40 MB)",
            Box::new(|| pairs.gather()),
        ),
    ];
    println!("| kernel | rounds | 1 thread [ms] | 2 threads [ms] | 2 ÷ 1, median | 2 ÷ 1, range |");
    println!("|---|---:|---:|---:|---:|---|");
    for (name, f) in &kernels {
        let (mut one, mut two, mut ratio) = (Vec::new(), Vec::new(), Vec::new());
        for _ in 0..rounds.max(1) {
            let t1 = time(1, f.as_ref());
            let t2 = time(2, f.as_ref());
            one.push(t1);
            two.push(t2);
            ratio.push(t1 / t2);
        }
        let (lo, hi) = ratio
            .iter()
            .fold((f64::INFINITY, 0.0_f64), |(a, b), &r| (a.min(r), b.max(r)));
        println!(
            "| {name} | {} | {:.2} | {:.2} | {:.2} | {lo:.2}–{hi:.2} |",
            ratio.len(),
            1e3 * median(one),
            1e3 * median(two),
            median(ratio)
        );
    }
    let (r1, r2) = (region_us(1), region_us(2));
    println!(
        "\nOne parallel region of two items: {r1:.1} µs on 1 thread, {r2:.1} µs on 2 threads: {:.1} µs over half the 1-thread time.",
        r2 - 0.5 * r1
    );
}
