//! The dam break of Martin & Moyce (1952): the surge front against the published points, and
//! self-convergence over three resolutions.

use super::*;

/// Martin & Moyce (1952) surge-front points (T, Z) for n² = 2 (docs/REFERENCES.md).
pub const MARTIN_MOYCE_N2_2: &[(f64, f64)] = &[
    (0.41, 1.11),
    (0.84, 1.22),
    (1.19, 1.44),
    (1.43, 1.67),
    (1.63, 1.89),
    (1.83, 2.11),
    (1.98, 2.33),
    (2.20, 2.56),
    (2.32, 2.78),
    (2.51, 3.00),
    (2.65, 3.22),
    (2.83, 3.44),
    (2.98, 3.67),
    (3.11, 3.89),
    (3.33, 4.11),
];

/// Martin & Moyce (1952) surge-front points (T, Z) for n² = 1 (docs/REFERENCES.md).
pub const MARTIN_MOYCE_N2_1: &[(f64, f64)] = &[
    (0.43, 1.11),
    (0.62, 1.22),
    (0.80, 1.44),
    (0.97, 1.67),
    (1.14, 1.89),
    (1.29, 2.11),
    (1.45, 2.33),
    (1.62, 2.56),
    (1.76, 2.78),
    (1.93, 3.00),
    (2.07, 3.22),
    (2.24, 3.44),
    (2.40, 3.67),
    (2.54, 3.89),
    (2.71, 4.11),
    (2.87, 4.33),
];

/// The published points for n² (2 or 1).
pub fn martin_moyce(n2: u32) -> &'static [(f64, f64)] {
    if n2 == 2 {
        MARTIN_MOYCE_N2_2
    } else {
        MARTIN_MOYCE_N2_1
    }
}

/// Particle layers across the slab.
pub const SLAB_LAYERS: usize = 4;

/// The dam-break scene: a column a wide and n²·a high at the left end of a 5.5·a tank.
pub fn dam_break_scene(solver: &str, n2: u32, a: f64, per_a: usize, walls: Option<Walls>) -> Scene {
    let dx = a / per_a as f64;
    let height = n2 as f64 * a;
    let (l, w) = (5.5 * a, SLAB_LAYERS as f64 * dx);
    let top = 2.5 * height;
    let end = dam_break_end(n2, a) * 1.01;
    let text = format!(
        "name = \"dam_break\"\n[time]\nend = {end}\ndt_max = 1e-3\n[domain]\nmin = [0.0, 0.0, 0.0]\nmax = [{l}, {w}, {top}]\n\
         [output]\ninterval = {end}\n{fluid}\n[[fluid.water]]\nshape = {{ type = \"box\", min = [0.0, 0.0, 0.0], max = [{a}, {w}, {height}] }}\n\n{tank}",
        fluid = fluid_table(solver, dx, walls),
        tank = tank(l, w, top, 0.2 * a),
    );
    Scene::parse(&text, "dam_break (generated)").expect("generated dam-break scene is valid")
}

/// Simulated time that covers the published points: t = T_last/(n·sqrt(g/a)).
pub fn dam_break_end(n2: u32, a: f64) -> f64 {
    let t_last = martin_moyce(n2).last().expect("points").0;
    t_last / ((n2 as f64).sqrt() * (9.81 / a).sqrt())
}

/// A dam-break run: the front Z(T) after every step.
#[derive(Debug, Clone)]
pub struct DamBreak {
    pub n2: u32,
    pub per_a: usize,
    pub curve: Vec<(f64, f64)>,
    pub particles: usize,
    pub steps: u64,
    pub seconds: f64,
}

impl DamBreak {
    /// Z at T by linear interpolation of the recorded curve.
    pub fn front_at(&self, t: f64) -> f64 {
        let c = &self.curve;
        let k = c.partition_point(|p| p.0 < t).clamp(1, c.len() - 1);
        let (a, b) = (c[k - 1], c[k]);
        let s = if b.0 > a.0 {
            ((t - a.0) / (b.0 - a.0)).clamp(0.0, 1.0)
        } else {
            1.0
        };
        a.1 + s * (b.1 - a.1)
    }

    /// Relative deviation (Z_sim − Z_ref)/Z_ref at each published point.
    pub fn deviations(&self) -> Vec<f64> {
        martin_moyce(self.n2)
            .iter()
            .map(|&(t, z)| (self.front_at(t) - z) / z)
            .collect()
    }

    /// Mean signed relative deviation from the published front (positive: ahead).
    pub fn mean_deviation(&self) -> f64 {
        let d = self.deviations();
        d.iter().sum::<f64>() / d.len() as f64
    }
}

/// The surge front [m]: the largest particle x plus half a spacing (the particle's own extent).
pub fn front(s: &dyn SphSolver, dx: f64) -> f64 {
    s.system()
        .particles
        .position
        .iter()
        .map(|p| p.x)
        .fold(f64::NEG_INFINITY, f64::max)
        + 0.5 * dx
}

/// Runs a dam break with a = 0.1 m and `per_a` particles across the column.
pub fn dam_break(
    solver: &str,
    n2: u32,
    per_a: usize,
    walls: Option<Walls>,
) -> Result<DamBreak, SolverError> {
    let a = 0.1;
    let scene = dam_break_scene(solver, n2, a, per_a, walls);
    let dir = TempRunDir::new("dambreak")?;
    let mut s = build(solver, &scene, dir.path())?;
    let particles = s.system().len();
    let dx = a / per_a as f64;
    let scale = (n2 as f64).sqrt() * (9.81 / a).sqrt();
    let mut curve = Vec::new();
    let start = std::time::Instant::now();
    let steps = run(s.as_mut(), &scene, dam_break_end(n2, a) * 1.01, |s, t| {
        curve.push((t * scale, front(s, dx) / a));
    })?;
    Ok(DamBreak {
        n2,
        per_a,
        curve,
        particles,
        steps,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// Self-convergence of three runs at spacings dx, dx/2, dx/4: the mean |ΔZ| between successive
/// resolutions over the published T points, and the observed order log2(e_coarse/e_fine).
pub fn self_convergence(runs: &[DamBreak; 3]) -> (f64, f64, f64) {
    let ts: Vec<f64> = martin_moyce(runs[0].n2).iter().map(|p| p.0).collect();
    let diff = |a: &DamBreak, b: &DamBreak| {
        ts.iter()
            .map(|&t| (a.front_at(t) - b.front_at(t)).abs())
            .sum::<f64>()
            / ts.len() as f64
    };
    let e1 = diff(&runs[0], &runs[1]);
    let e2 = diff(&runs[1], &runs[2]);
    (e1, e2, (e1 / e2).log2())
}

/// A dam break in a narrow tank, fixed walls only: a column 0.2 m long and 0.15 m high at one
/// end of a 0.6 m × 0.06 m tank, dx = 1 cm (1 800 particles), two gauges (one in the column, one
/// the front reaches) and a probe at the toe, to `end` seconds with frames every `interval`. The
/// runs of the fluid on several ranks use it (`crate::ranks`'s tests, tests/tests/mpi.rs): the
/// tank's 0.6 m along x hold 5 slabs at most.
pub fn narrow_dam_break(end: f64, interval: f64) -> String {
    format!(
        r#"name = "ranks_dam_break"
[time]
end = {end}
dt_max = 1e-3
[domain]
min = [0.0, 0.0, 0.0]
max = [0.6, 0.06, 0.3]
[output]
interval = {interval}
[fluid]
solver = "wcsph"
dx = 0.01
[[fluid.water]]
shape = {{ type = "box", min = [0.0, 0.0, 0.0], max = [0.2, 0.06, 0.15] }}
[[gauge]]
name = "dam"
x = 0.1
y = 0.03
[[gauge]]
name = "far"
x = 0.5
y = 0.03
[[probe]]
name = "toe"
position = [0.3, 0.03, 0.01]

{}"#,
        tank(0.6, 0.06, 0.3, 0.02)
    )
}
