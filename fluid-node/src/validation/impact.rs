//! Impact pressure on the downstream wall of a dry-bed dam break: the tank of Lobovský,
//! Botia-Vera, Castellana, Mas-Soler & Souto-Iglesias (2014), "Experimental investigation of
//! dynamic pressure loads during dam break", J. Fluids Struct. 48:407–434 (arXiv:1308.0115),
//! with the reference data of docs/REFERENCES.md ("Lobovský et al. 2014").
//!
//! The tank is 1.61 m long (modelled to the nearest whole number of particle spacings,
//! [`ImpactCase::lattice_length`]); the water column is 0.6 m long and H high against the left
//! wall, released at once (the experiment's gate lift is not modelled). The pressure sensors sit on
//! the right wall at heights z above the bed, on its centre line. The paper's tank is 0.15 m
//! wide so that the flow stays quasi-2D: it is modelled at that width between free-slip side
//! walls, [`TANK_WIDTH`]/dx particle layers at every resolution ([`ImpactCase::layers`]); a
//! slab of a fixed 4 layers, as in the Martin & Moyce case, moves the peak by −35 to +60 %
//! (docs/VALIDATION.md, "Impact pressure", "The slab's width").
//!
//! Measured per sensor, on the probe's `probes.csv` series (rows every [`ROW_INTERVAL`], each
//! the probe's box average over its `window`), from the impact's onset (the first reading
//! ≥ [`ONSET`]·ρ0 g H):
//!
//! - the first impact's pulse ([`Impact::first_pulse`]) with the paper's definitions
//!   (§5.1.2–5.1.3, Fig. 21): the peak within the experiment's impact time after the onset,
//!   rise time = 2 (t_peak − t_½rise), decay time = 2 (t_½fall − t_peak), where t_½rise and
//!   t_½fall are where the pressure crosses half the peak before and after it ([`pulse`]);
//! - the pressure impulse I = ∫ p dt over the experiment's median impact time (rise + decay)
//!   from the onset ([`Impact::impulse`]). The paper integrates over each run's own impact
//!   time; our half-peak crossings sit on acoustic oscillations (docs/VALIDATION.md "Impact
//!   pressure"), so the experiment's span is used instead of ours;
//! - the period the sensor rings at after the peak ([`Impact::ringing_period`]): a diagnosis
//!   of the weakly compressible solvers' crest, not a reading to compare.

use super::*;

/// Tank length [m] (Lobovský et al. 2014; docs/REFERENCES.md §1.3).
pub const TANK_LENGTH: f64 = 1.61;
/// Water column length [m].
pub const COLUMN_LENGTH: f64 = 0.6;
/// The tank's width [m]: the slab is as wide, to the nearest whole particle layer
/// ([`ImpactCase::new`]).
pub const TANK_WIDTH: f64 = 0.15;
/// The sensors' sensing face, 4.2 mm across (docs/REFERENCES.md §1.3, second-hand): each probe
/// reads the mean over that disk on the wall ([`shared::scene::ProbeFace`]).
pub const SENSOR_DIAMETER: f64 = 0.0042;

/// A wall pressure sensor and its measured peak pressure over the repeated runs [Pa].
#[derive(Debug, Clone, Copy)]
pub struct Sensor {
    pub name: &'static str,
    /// Height of the sensor centre above the bed [m].
    pub z: f64,
    /// Median peak pressure and its 2.5 % and 97.5 % percentiles over the runs [Pa].
    pub median: f64,
    pub p025: f64,
    pub p975: f64,
}

/// mbar in Pa.
const MBAR: f64 = 100.0;

/// H = 300 mm: sensors 1–4 and their peak pressures over 100 runs (Lobovský et al. 2014,
/// Table 2; docs/REFERENCES.md gives the transcription's provenance).
pub const LOBOVSKY_H300: [Sensor; 4] = [
    Sensor {
        name: "s1",
        z: 0.003,
        median: 91.44 * MBAR,
        p025: 75.06 * MBAR,
        p975: 130.98 * MBAR,
    },
    Sensor {
        name: "s2",
        z: 0.015,
        median: 57.49 * MBAR,
        p025: 53.26 * MBAR,
        p975: 63.31 * MBAR,
    },
    Sensor {
        name: "s3",
        z: 0.030,
        median: 43.76 * MBAR,
        p025: 39.79 * MBAR,
        p975: 49.62 * MBAR,
    },
    Sensor {
        name: "s4",
        z: 0.080,
        median: 30.15 * MBAR,
        p025: 24.18 * MBAR,
        p975: 36.32 * MBAR,
    },
];

/// H = 600 mm, sensor 1 (3 mm above the bed): median pressure impulse over the impact time
/// [Pa·s] (§5.2.3 as transcribed: 12.74 mbar·s) and median peak [Pa] (185.69 mbar);
/// docs/REFERENCES.md §1.3.
pub const LOBOVSKY_H600_S1_IMPULSE: f64 = 12.74 * MBAR;
pub const LOBOVSKY_H600_S1_PEAK: f64 = 185.69 * MBAR;

/// The boxes the loads of one run are compared over [s] ([`Impact::box_peak`]): from the
/// experiment's rise time (its median is 7 ms at H = 600 mm) to a fifth of its impact time.
pub const LOAD_BOXES: [f64; 3] = [0.005, 0.010, 0.020];

/// One run of the experiment reduced as [`Impact`] reduces ours: the sensor's 1 ms means
/// every [`ROW_INTERVAL`], the onset ([`ONSET`]), then over the impact time
/// ([`LOBOVSKY_H600_S1_IMPACT_TIME`]) from it the highest row, the impulse and the highest
/// mean over each of [`LOAD_BOXES`].
#[derive(Debug, Clone, Copy)]
pub struct EventLoads {
    /// The onset, t·sqrt(g/H) from the release as the experiment's file counts it.
    pub onset_star: f64,
    /// The highest 1 ms mean [Pa].
    pub peak: f64,
    /// ∫ p dt over the impact time from the onset [Pa·s].
    pub impulse: f64,
    /// The highest mean over each of [`LOAD_BOXES`] [Pa].
    pub boxed: [f64; 3],
}

/// H = 300 mm, "peak event 5" of Lobovský et al. (2014, Fig. 18), one of the runs, its raw
/// series (20 kHz) reduced as [`EventLoads`] says, per sensor of [`LOBOVSKY_H300`]
/// (docs/REFERENCES.md §1.3 gives the source and the reduction). Its sensor-1 peak, 88.2 mbar,
/// is near Table 2's median of 91.44: a typical run for sensor 1. Not a statistic: one run.
pub const LOBOVSKY_H300_EVENT5: [EventLoads; 4] = [
    EventLoads {
        onset_star: 2.445,
        peak: 8822.0,
        impulse: 493.1,
        boxed: [7816.0, 7266.0, 6647.0],
    },
    EventLoads {
        onset_star: 2.462,
        peak: 5650.0,
        impulse: 440.2,
        boxed: [5603.0, 5588.0, 5512.0],
    },
    EventLoads {
        onset_star: 2.513,
        peak: 4514.0,
        impulse: 405.4,
        boxed: [4486.0, 4478.0, 4462.0],
    },
    EventLoads {
        onset_star: 2.772,
        peak: 1627.0,
        impulse: 139.2,
        boxed: [1617.0, 1608.0, 1592.0],
    },
];

/// H = 600 mm, sensor 1: the median impact time [s], rise 7 ms plus decay 104 ms
/// (docs/REFERENCES.md): the span the experiment's impulse is integrated over.
pub const LOBOVSKY_H600_S1_IMPACT_TIME: f64 = 0.007 + 0.104;

/// The onset of the impact at a sensor, as a fraction of ρ0 g H: the first reading at or above
/// it starts the impulse integral ([`Impact::impulse`]).
pub const ONSET: f64 = 0.1;

/// One impact run: water height, resolution, probe window and solver table additions.
#[derive(Debug, Clone)]
pub struct ImpactCase {
    /// Water column height H [m] (0.3 or 0.6).
    pub height: f64,
    /// Particles per H.
    pub per_h: usize,
    /// Probe averaging window [s] (None: the reading at each row).
    pub window: Option<f64>,
    /// Simulated time over sqrt(H/g).
    pub end_star: f64,
    /// The scene's largest step (`[time] dt_max`) [s]: 1 ms, the probe window's length.
    pub dt_max: f64,
    /// Particle layers across the slab, between its side walls: the tank's width
    /// ([`TANK_WIDTH`]) at every resolution, at least [`SLAB_LAYERS`].
    pub layers: usize,
    /// Extra lines for the solver's parameter table (`[fluid.<solver>]`), e.g. `delta = 0.0`.
    pub params: String,
    /// The modelled tank's length [m]: [`Self::lattice_length`] unless a test moves the wall
    /// off the lattice.
    pub length: f64,
    /// How far the neighbour grid's cells are moved [m] (the domain's lower corner moves down
    /// and back by it; water, walls and probes stay): another order of every sum, so a run of
    /// the same case that parts from the others after a few steps, as the experiment's
    /// repeated runs part (docs/VALIDATION.md, "Impact pressure", "Run to run"). 0: none.
    pub grid_shift: f64,
    /// The fill's rows along x shifted by up to this fraction of dx (`[fluid] row_shift`), so
    /// that they do not reach the sensors' wall in step ("The wall's load along the width").
    /// 0: the lattice.
    pub row_shift: f64,
    /// Which draw of the shifted rows (`[fluid] row_draw`): the ensemble's member.
    pub row_draw: u32,
    /// Read the wall's height too: a strip at every cell's height up to H, in both readings
    /// ([`PROFILE`], [`Impact::profile`]).
    pub profile: bool,
}

impl ImpactCase {
    /// H, H/dx and the window, with the defaults: the run to t·sqrt(g/H) = 4.5 (the first
    /// impact, at t·sqrt(g/H) ≈ 1.5 for H = 600 mm and 2.4 for 300 mm in our runs, and its
    /// decay), the experiment's width, no extra parameters.
    ///
    /// The width is held as dx shrinks: a slab of a fixed number of layers narrows with each
    /// refinement, and the peak moves with the width by −35 to +60 % (docs/VALIDATION.md,
    /// "The slab's width"), so a resolution study at fixed layers mixes two changes.
    pub fn new(height: f64, per_h: usize, window: Option<f64>) -> Self {
        let dx = height / per_h as f64;
        Self {
            height,
            per_h,
            window,
            end_star: 4.5,
            dt_max: 1e-3,
            layers: ((TANK_WIDTH / dx).round() as usize).max(SLAB_LAYERS),
            params: String::new(),
            length: Self::lattice_length(dx),
            grid_shift: 0.0,
            row_shift: 0.0,
            row_draw: 0,
            profile: false,
        }
    }

    pub fn dx(&self) -> f64 {
        self.height / self.per_h as f64
    }

    /// [`TANK_LENGTH`] to the nearest whole number of spacings `dx` (1.62 m at dx = 20 mm, 1.60
    /// at 40 mm, 1.61 at 10 and 5 mm): the right wall, which holds the sensors, then lies
    /// between two rows of the lattice that water and boundary particles share. Off the lattice
    /// the wall's first row of boundary particles sits up to a spacing behind the face, while
    /// Eq. 22's backstop acts a quarter spacing in front of it: at dx = 20 mm (1.61 m is 80.5
    /// spacings) the water pressed into the backstop, which took two thirds of sensor 1's
    /// impulse, and the sensor's wall stood half a spacing off (docs/VALIDATION.md, "What a
    /// sensor reads").
    pub fn lattice_length(dx: f64) -> f64 {
        (TANK_LENGTH / dx).round() * dx
    }

    pub fn end(&self) -> f64 {
        self.end_star * (self.height / 9.81).sqrt()
    }
}

/// Where the wall readings start among an [`Impact`]'s series (and the scene's probes): sensor
/// k's face reads the water's pressure in series k and the wall's load behind it
/// (`reading = "wall"`, `instruments::wall_load`) in series `WALL + k`.
pub const WALL: usize = LOBOVSKY_H300.len();

/// Where the strips start: sensor k's height read on the wall along the middle half of the
/// tank's width (`<name>_strip`, the face swept along [`STRIP_SPAN`] of it) in series
/// `STRIP + k`. The flow is a dam break across its tank, the same along the width but for
/// the side walls' layers; the disk (4.2 mm) is smaller than a particle at every resolution
/// of the study, and its load is one column of the wall's, whose particles strike it one by
/// one (docs/VALIDATION.md, "The wall's load along the width").
pub const STRIP: usize = 2 * LOBOVSKY_H300.len();

/// The strips' length over the tank's width: the middle half, clear of the side walls by a
/// quarter of the width (37.5 mm in the tank: three kernel supports at H/dx = 60, three
/// quarters of one at 15).
pub const STRIP_SPAN: f64 = 0.5;

/// Where the wall's height profile starts among the series, with [`ImpactCase::profile`]: a
/// strip like the sensors' ([`STRIP_SPAN`]) at the middle of each cell of the wall's lattice
/// up to H, z = (k + ½) dx, reading the water's pressure (`z<k>`, series `PROFILE + k`), then
/// the same cells reading the wall's load (`z<k>_wall`, series `PROFILE + per_h + k`).
pub const PROFILE: usize = 3 * LOBOVSKY_H300.len();

/// Time between probe rows [s] (`output.interval`/50): 5 kHz.
pub const ROW_INTERVAL: f64 = 2e-4;

/// The scene: tank, column and the four sensors (heights of [`LOBOVSKY_H300`]) as probes on the
/// right wall's face, at mid-slab.
pub fn impact_scene(solver: &str, case: &ImpactCase) -> Scene {
    let (h, dx, length) = (case.height, case.dx(), case.length);
    let w = case.layers as f64 * dx;
    // The run-up along the wall climbs past 2 H: room above it, and a lid at 3 H for the jet
    // of the finer runs (it left a 3 H domain at H/dx = 45, H = 600 mm); the experiment's tank
    // is open, but the jet reaches 3 H only after the impact has decayed at the bed.
    let top = 3.0 * h;
    let lid = format!(
        "[[block]]\nname = \"lid\"\nkind = \"fixed\"\nshape = {{ type = \"box\", min = [-0.1, -0.1, {top}], max = [{}, {}, {}] }}\n\n",
        length + 0.1,
        w + 0.1,
        top + 0.1
    );
    let end = case.end();
    // Each sensor three times: the water's pressure over its face, the wall's load behind it
    // (`<name>_wall`, [`WALL`] columns on), and the wall's load along the middle of the width
    // at its height (`<name>_strip`, [`STRIP`] on).
    let strip = format!(
        ", reading = \"wall\", span = [0.0, {}, 0.0]",
        STRIP_SPAN * w
    );
    let probes: String = [
        ("", ""),
        ("_wall", ", reading = \"wall\""),
        ("_strip", &strip),
    ]
    .iter()
    .flat_map(|(suffix, reading)| {
        LOBOVSKY_H300
            .iter()
            .map(move |s| wall_probe(case, w, &format!("{}{suffix}", s.name), s.z, reading))
    })
    .collect::<String>()
        + &profile_probes(case, w);
    let params = if case.params.is_empty() {
        String::new()
    } else {
        format!("[fluid.{solver}]\n{}\n", case.params)
    };
    let min = if case.grid_shift == 0.0 {
        "0.0, 0.0, 0.0".to_string()
    } else {
        format!("{0}, {0}, {0}", -case.grid_shift)
    };
    let text = format!(
        "name = \"lobovsky_impact\"\n[time]\nend = {end}\ndt_max = {dt_max}\n[domain]\nmin = [{min}]\nmax = [{length}, {w}, {domain_top}]\n\
         [output]\ninterval = {interval}\n{fluid}\n{params}[[fluid.water]]\nshape = {{ type = \"box\", min = [0.0, 0.0, 0.0], max = [{COLUMN_LENGTH}, {w}, {h}] }}\n\n{tank}{lid}{probes}",
        domain_top = top + 0.1,
        dt_max = case.dt_max,
        interval = 50.0 * ROW_INTERVAL,
        fluid = fluid_table(solver, dx, None)
            + &if case.row_shift == 0.0 {
                String::new()
            } else {
                format!(
                    "row_shift = [{}, 0.0, 0.0]\nrow_draw = {}\n",
                    case.row_shift, case.row_draw
                )
            },
        tank = tank(length, w, top, 0.1),
    );
    Scene::parse_checked(&text, "lobovsky_impact (generated)", &[&crate::check_scene])
        .expect("generated impact scene is valid")
}

/// A `[[probe]]` on the right wall at mid-width (`w` the slab's width) and height `z`, with
/// the sensors' face, the case's window and `face_keys` added to the face (a reading, a span).
fn wall_probe(case: &ImpactCase, w: f64, name: &str, z: f64, face_keys: &str) -> String {
    let window = case
        .window
        .map(|w| format!("window = {w}\n"))
        .unwrap_or_default();
    format!(
        "[[probe]]\nname = \"{name}\"\nposition = [{}, {}, {z}]\n{window}face = {{ diameter = {SENSOR_DIAMETER}, normal = [-1.0, 0.0, 0.0]{face_keys} }}\n\n",
        case.length,
        0.5 * w
    )
}

/// With [`ImpactCase::profile`], the strips of [`PROFILE`] (none without), `w` the slab's width.
fn profile_probes(case: &ImpactCase, w: f64) -> String {
    if !case.profile {
        return String::new();
    }
    let span = format!(", span = [0.0, {}, 0.0]", STRIP_SPAN * w);
    [("", ""), ("_wall", ", reading = \"wall\"")]
        .iter()
        .flat_map(|(suffix, reading)| {
            let keys = format!("{span}{reading}");
            (0..case.per_h).map(move |k| {
                let z = (k as f64 + 0.5) * case.dx();
                wall_probe(case, w, &format!("z{k}{suffix}"), z, &keys)
            })
        })
        .collect()
}

/// The wall's height profile of one run ([`Impact::profile`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Profile {
    /// The window's start [s]: the earlier of sensor 1's onsets in the pressure and the strip.
    pub start: f64,
    /// Per cell of the wall up to H: its height z [m], the impulse [Pa·s] of the water's
    /// pressure and of the wall's load over the window.
    pub cells: Vec<(f64, f64, f64)>,
    /// Σ impulse · dx over the cells [N·s per metre of the wall's width]: the horizontal
    /// impulse the wall below H takes, in each reading.
    pub pressure: f64,
    pub wall: f64,
}

impl Profile {
    /// The mean impulse [Pa·s] over the lowest `cells` cells of the wall, in each reading
    /// (pressure, wall), or None past the profile's height. Read off a fine run, it is what a
    /// reading averaged over a layer that thick (the wall's lowest cell at a coarser dx) takes
    /// at best: the floor of a cell's reading at a corner sensor.
    pub fn lowest(&self, cells: usize) -> Option<(f64, f64)> {
        let layer = self.cells.get(..cells).filter(|l| !l.is_empty())?;
        let n = layer.len() as f64;
        Some((
            layer.iter().map(|c| c.1).sum::<f64>() / n,
            layer.iter().map(|c| c.2).sum::<f64>() / n,
        ))
    }
}

/// A pressure pulse measured as Lobovský et al. (2014) §5.1.2–5.1.3 do.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pulse {
    /// Peak pressure [Pa] and its time [s].
    pub peak: f64,
    pub t_peak: f64,
    /// Rise and decay times [s]: twice the time from the half-peak crossing to the peak.
    pub rise: f64,
    pub decay: f64,
    /// ∫ p dt over [t_peak − rise, t_peak + decay] (trapezoids) [Pa·s].
    pub impulse: f64,
}

/// The first impact's pulse of the series (t, p) (NaN readings, a dry sensor, count as 0):
/// its highest reading, the half-peak crossings around it, and the impulse over the impact time.
/// None without a positive reading.
pub fn pulse(ts: &[f64], ps: &[f64]) -> Option<Pulse> {
    let p = dry_as_zero(ps);
    let (ip, &peak) = p.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1))?;
    if peak <= 0.0 {
        return None;
    }
    let half = 0.5 * peak;
    let cross =
        |i0: usize, i1: usize| ts[i0] + (half - p[i0]) * (ts[i1] - ts[i0]) / (p[i1] - p[i0]);
    let t_peak = ts[ip];
    let mut ir = ip;
    while ir > 0 && p[ir] > half {
        ir -= 1;
    }
    let t_rise = if p[ir] <= half && ir < ip {
        cross(ir, ir + 1)
    } else {
        ts[ir]
    };
    let mut ifall = ip;
    while ifall + 1 < p.len() && p[ifall] > half {
        ifall += 1;
    }
    let t_fall = if p[ifall] <= half && ifall > ip {
        cross(ifall - 1, ifall)
    } else {
        ts[ifall]
    };
    let (rise, decay) = (2.0 * (t_peak - t_rise), 2.0 * (t_fall - t_peak));
    Some(Pulse {
        peak,
        t_peak,
        rise,
        decay,
        impulse: integral(ts, &p, t_peak - rise, t_peak + decay),
    })
}

/// A probe's readings with a dry one (NaN: no water within the kernel's reach) as 0 Pa.
pub fn dry_as_zero(ps: &[f64]) -> Vec<f64> {
    ps.iter()
        .map(|&v| if v.is_finite() { v } else { 0.0 })
        .collect()
}

/// ∫ p dt over [a, b] of the piecewise-linear series (t, p) (trapezoids, clipped to [a, b]).
pub fn integral(ts: &[f64], p: &[f64], a: f64, b: f64) -> f64 {
    let at = |t: f64, i: usize| {
        let s = (t - ts[i - 1]) / (ts[i] - ts[i - 1]);
        p[i - 1] + s * (p[i] - p[i - 1])
    };
    (1..ts.len())
        .filter(|&i| ts[i] > ts[i - 1])
        .map(|i| {
            let (lo, hi) = (ts[i - 1].max(a), ts[i].min(b));
            if hi > lo {
                0.5 * (at(lo, i) + at(hi, i)) * (hi - lo)
            } else {
                0.0
            }
        })
        .sum()
}

/// How long after a peak, and from how long before it, [`ringing_period`] reads the series [s].
pub const RINGING_SPAN: (f64, f64) = (0.005, 0.045);

/// The period [s] of the oscillation that follows the peak at `t_peak` in the series (t, p):
/// the lag of the autocorrelation's first positive maximum past its first zero, over
/// [`RINGING_SPAN`] around the peak resampled every 0.1 ms (the mean removed). A weakly
/// compressible run's wall pressure rings after the impact at a period set by its sound speed
/// and the thickness of the layer that stops (docs/VALIDATION.md, "What the Riemann crest
/// is"); None when the series does not cover the span or nothing repeats within it.
pub fn ringing_period(ts: &[f64], p: &[f64], t_peak: f64) -> Option<f64> {
    const STEP: f64 = 1e-4;
    let (t0, t1) = (t_peak - RINGING_SPAN.0, t_peak + RINGING_SPAN.1);
    if ts.len() < 2 || t0 < ts[0] || t1 > ts[ts.len() - 1] {
        return None;
    }
    let n = ((t1 - t0) / STEP).round() as usize;
    let at = |t: f64| {
        let i = ts.partition_point(|&x| x < t).clamp(1, ts.len() - 1);
        let s = (t - ts[i - 1]) / (ts[i] - ts[i - 1]);
        p[i - 1] + s * (p[i] - p[i - 1])
    };
    let mut x: Vec<f64> = (0..n).map(|k| at(t0 + k as f64 * STEP)).collect();
    let mean = x.iter().sum::<f64>() / n as f64;
    x.iter_mut().for_each(|v| *v -= mean);
    // Lags up to half the span, so each is averaged over at least half of it.
    let r: Vec<f64> = (0..n / 2)
        .map(|l| {
            x[..n - l]
                .iter()
                .zip(&x[l..])
                .map(|(a, b)| a * b)
                .sum::<f64>()
                / (n - l) as f64
        })
        .collect();
    let zero = r.iter().position(|&v| v < 0.0)?;
    (zero + 1..r.len() - 1)
        .find(|&l| r[l] > 0.0 && r[l] >= r[l - 1] && r[l] > r[l + 1])
        .map(|l| l as f64 * STEP)
}

/// An impact run: each sensor's probe series and its pulse.
#[derive(Debug, Clone)]
pub struct Impact {
    pub case: ImpactCase,
    /// Row times [s] and, per sensor of [`LOBOVSKY_H300`], the probe's readings [Pa]: the
    /// water's pressure over the face, then from [`WALL`] on the wall's load behind it.
    pub times: Vec<f64>,
    pub series: Vec<Vec<f64>>,
    /// Each series' first impact ([`Impact::first_pulse`]).
    pub pulses: Vec<Option<Pulse>>,
    pub particles: usize,
    pub steps: u64,
    pub seconds: f64,
}

impl Impact {
    /// Sensor `k`'s readings with a dry (NaN) reading as 0 Pa, and the index of the impact's
    /// onset: the first reading ≥ [`ONSET`]·ρ0 g H (water of 1000 kg/m³); None without one.
    fn onset(&self, k: usize) -> Option<(Vec<f64>, usize)> {
        let p = dry_as_zero(&self.series[k]);
        let threshold = ONSET * 1000.0 * 9.81 * self.case.height;
        let i = p.iter().position(|&v| v >= threshold)?;
        Some((p, i))
    }

    /// The impulse at sensor `k` [Pa·s] over `duration` from the impact's onset, and the onset
    /// time; None when the pressure never gets there. Integrating over the experiment's impact
    /// time rather than between our own half-peak crossings keeps the acoustic spikes of a
    /// weakly compressible run (docs/VALIDATION.md "Impact pressure") out of the limits.
    pub fn impulse(&self, k: usize, duration: f64) -> Option<(f64, f64)> {
        let (p, i) = self.onset(k)?;
        let t0 = self.times[i];
        Some((integral(&self.times, &p, t0, t0 + duration), t0))
    }

    /// The mean and standard deviation [Pa] of sensor `k`'s rows over `duration` from the
    /// impact's onset (each row one probe window's average): how far a reading swings about
    /// its level through the impact (DFSPH's peak, docs/VALIDATION.md "Impact pressure").
    pub fn spread(&self, k: usize, duration: f64) -> Option<(f64, f64)> {
        let (p, i) = self.onset(k)?;
        let j = self
            .times
            .partition_point(|&t| t <= self.times[i] + duration);
        let rows = &p[i..j];
        let n = rows.len() as f64;
        let mean = rows.iter().sum::<f64>() / n;
        let variance = rows.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n;
        Some((mean, variance.sqrt()))
    }

    /// The highest mean [Pa] of sensor `k` over a box of `window` seconds inside `duration`
    /// from the impact's onset: the load a structure of that response time feels, in which
    /// the artificial sound speed's ringing (a few ms) averages out and the experiment's
    /// smooth load does not (docs/VALIDATION.md, "One run of the experiment").
    pub fn box_peak(&self, k: usize, window: f64, duration: f64) -> Option<f64> {
        let (p, i) = self.onset(k)?;
        let t0 = self.times[i];
        self.times
            .iter()
            .filter(|&&t| t >= t0 + window && t <= t0 + duration)
            .map(|&t| integral(&self.times, &p, t - window, t) / window)
            .reduce(f64::max)
    }

    /// The period [s] at which sensor `k` rings after its first impact's peak
    /// ([`ringing_period`]); None without a pulse or a repeat.
    pub fn ringing_period(&self, k: usize) -> Option<f64> {
        let peak = self.pulses[k]?;
        ringing_period(&self.times, &dry_as_zero(&self.series[k]), peak.t_peak)
    }

    /// The wall's height profile over `duration` from the impact's first onset at sensor 1 (a
    /// window common to every cell and both readings, so that the sums are the wall's
    /// impulse over one span of time); None without [`ImpactCase::profile`] or an onset.
    pub fn profile(&self, duration: f64) -> Option<Profile> {
        let n = self.case.per_h;
        if !self.case.profile || self.series.len() < PROFILE + 2 * n {
            return None;
        }
        let start = [0, STRIP]
            .iter()
            .filter_map(|&k| self.onset(k).map(|(_, i)| self.times[i]))
            .reduce(f64::min)?;
        let dx = self.case.dx();
        let impulse = |k: usize| {
            integral(
                &self.times,
                &dry_as_zero(&self.series[k]),
                start,
                start + duration,
            )
        };
        let cells: Vec<(f64, f64, f64)> = (0..n)
            .map(|k| {
                let z = (k as f64 + 0.5) * dx;
                (z, impulse(PROFILE + k), impulse(PROFILE + n + k))
            })
            .collect();
        Some(Profile {
            start,
            pressure: cells.iter().map(|c| c.1 * dx).sum(),
            wall: cells.iter().map(|c| c.2 * dx).sum(),
            cells,
        })
    }

    /// The first impact's [`pulse`] at sensor `k`: over the experiment's impact time
    /// ([`LOBOVSKY_H600_S1_IMPACT_TIME`]) from the onset, so a later splash or reflection is not
    /// taken for the peak.
    pub fn first_pulse(&self, k: usize) -> Option<Pulse> {
        let (p, i) = self.onset(k)?;
        let end = self.times[i] + LOBOVSKY_H600_S1_IMPACT_TIME;
        let j = self.times.partition_point(|&t| t <= end);
        pulse(&self.times[i..j], &p[i..j])
    }
}

/// Runs `case` with `solver` and reads the probes' `probes.csv`.
pub fn impact(solver: &str, case: &ImpactCase) -> Result<Impact, SolverError> {
    let scene = impact_scene(solver, case);
    let dir = TempRunDir::new("impact")?;
    let mut s = build(solver, &scene, dir.path())?;
    let particles = s.system().len();
    let start = std::time::Instant::now();
    let steps = run(s.as_mut(), &scene, case.end(), |_, _| {})?;
    let seconds = start.elapsed().as_secs_f64();
    drop(s);
    let rows = read_csv(&dir.path().join("probes.csv"))?;
    let times: Vec<f64> = rows.iter().map(|r| r[0]).collect();
    let columns = PROFILE + if case.profile { 2 * case.per_h } else { 0 };
    let series: Vec<Vec<f64>> = (1..=columns)
        .map(|k| rows.iter().map(|r| r[k]).collect())
        .collect();
    let mut r = Impact {
        case: case.clone(),
        times,
        series,
        pulses: Vec::new(),
        particles,
        steps,
        seconds,
    };
    r.pulses = (0..r.series.len()).map(|k| r.first_pulse(k)).collect();
    Ok(r)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A step load with a decaying ringing on top, sampled unevenly: the period comes back
    /// within 5 % (the step and the decay pull the autocorrelation's maximum in by 0.2 ms
    /// here); a series that only decays does not ring.
    #[test]
    fn a_ringing_step_gives_back_its_period() {
        let (t_peak, period) = (0.4, 0.0065);
        let ts: Vec<f64> = (0..3000)
            .map(|i| 0.3 + 2.7e-4 * i as f64 + 1e-5 * ((i * 7) % 5) as f64)
            .collect();
        let ring = |t: f64| {
            let s = t - t_peak;
            if s < 0.0 {
                0.0
            } else {
                1e4 * (1.0 + (-s / 0.02).exp() * (std::f64::consts::TAU * s / period).cos())
            }
        };
        let ps: Vec<f64> = ts.iter().map(|&t| ring(t)).collect();
        let got = ringing_period(&ts, &ps, t_peak).expect("it rings");
        assert!(
            (got - period).abs() <= 0.05 * period,
            "period {got} s against {period} s"
        );
        let decay: Vec<f64> = ts
            .iter()
            .map(|&t| {
                if t < t_peak {
                    0.0
                } else {
                    1e4 * (-(t - t_peak) / 0.01).exp()
                }
            })
            .collect();
        assert_eq!(ringing_period(&ts, &decay, t_peak), None);
        // Too close to the end of the series to read the span.
        assert_eq!(ringing_period(&ts, &ps, ts[ts.len() - 10]), None);
    }

    /// A plateau of 5 kPa with a ringing of ±10 kPa and period 4 ms on it: its highest 1 ms
    /// mean is the ringing's crest, a 4 ms box reads the plateau, a 20 ms one too; a box
    /// longer than the span from the onset reads nothing.
    #[test]
    fn a_box_as_long_as_the_ringing_reads_the_load_under_it() {
        let ts: Vec<f64> = (0..=2000).map(|i| 2e-4 * i as f64).collect();
        let p = |t: f64| {
            if t < 0.1 {
                0.0
            } else {
                5e3 + 1e4 * (std::f64::consts::TAU * (t - 0.1) / 0.004).sin()
            }
        };
        let run = Impact {
            case: ImpactCase::new(0.3, 15, None),
            times: ts.clone(),
            series: vec![ts.iter().map(|&t| p(t)).collect()],
            pulses: vec![None],
            particles: 0,
            steps: 0,
            seconds: 0.0,
        };
        let short = run.box_peak(0, 0.001, 0.111).unwrap();
        assert!(short > 1.3e4, "{short}");
        for w in [0.004, 0.020] {
            let long = run.box_peak(0, w, 0.111).unwrap();
            assert!((long - 5e3).abs() < 0.01 * 5e3, "{w} s: {long}");
        }
        assert_eq!(run.box_peak(0, 0.2, 0.111), None);
    }

    #[test]
    fn a_triangle_pulse_has_its_rise_decay_and_area() {
        // 0 until 1 s, up to 10 at 2 s, down to 0 at 4 s, 0 after: half-crossings at 1.5 and
        // 3 s, rise 1 s, decay 2 s, impact time [1, 4] s, area 15.
        let ts: Vec<f64> = (0..=50).map(|i| 0.1 * i as f64).collect();
        let ps: Vec<f64> = ts
            .iter()
            .map(|&t| {
                if t <= 1.0 || t >= 4.0 {
                    0.0
                } else if t <= 2.0 {
                    10.0 * (t - 1.0)
                } else {
                    5.0 * (4.0 - t)
                }
            })
            .collect();
        let p = pulse(&ts, &ps).unwrap();
        assert!((p.peak - 10.0).abs() < 1e-9 && (p.t_peak - 2.0).abs() < 1e-9);
        assert!((p.rise - 1.0).abs() < 1e-9, "{p:?}");
        assert!((p.decay - 2.0).abs() < 1e-9, "{p:?}");
        assert!((p.impulse - 15.0).abs() < 1e-9, "{p:?}");
        // A dry sensor (NaN) reads nothing.
        assert_eq!(pulse(&ts, &vec![f64::NAN; ts.len()]), None);
    }

    /// Rows 0, 0, 1000, 3000, 1000, 3000 Pa at 1 s spacing: the onset (≥ 0.1 ρ0 g H = 294 Pa at
    /// H = 0.3 m) is row 2; over 2 s from it three rows, mean 5000/3, the population's
    /// standard deviation sqrt(8/9)·1000; over 10 s all four, mean 2000, sd 1000.
    #[test]
    fn the_spread_is_taken_from_the_onset_over_the_duration() {
        let series = vec![0.0, f64::NAN, 1000.0, 3000.0, 1000.0, 3000.0];
        let r = Impact {
            case: ImpactCase::new(0.3, 10, None),
            times: (0..6).map(|k| k as f64).collect(),
            series: vec![series],
            pulses: Vec::new(),
            particles: 0,
            steps: 0,
            seconds: 0.0,
        };
        let (mean, sd) = r.spread(0, 2.0).unwrap();
        assert!((mean - 5000.0 / 3.0).abs() < 1e-9, "{mean}");
        assert!((sd - (8.0f64 / 9.0).sqrt() * 1000.0).abs() < 1e-9, "{sd}");
        let (mean, sd) = r.spread(0, 10.0).unwrap();
        assert!((mean - 2000.0).abs() < 1e-9 && (sd - 1000.0).abs() < 1e-9);
    }

    /// With the profile the scene has a strip at every cell's height up to H in both readings
    /// (H/dx = 10: ten each, z = 15, 45, … 285 mm), and the profile integrates each over one
    /// window from sensor 1's first onset: a cell that reads 2000 Pa from t = 1 s on and a wall
    /// cell that reads 1000 Pa take 2000 and 1000 Pa·s over 1 s, and the sums are those times
    /// dx per cell.
    #[test]
    fn the_profile_reads_every_cell_over_one_window() {
        let case = ImpactCase {
            profile: true,
            ..ImpactCase::new(0.3, 10, None)
        };
        let s = impact_scene("wcsph", &case);
        assert_eq!(s.probes.len(), PROFILE + 20);
        let (low, wall) = (&s.probes[PROFILE], &s.probes[PROFILE + 19]);
        assert_eq!((low.name.as_str(), wall.name.as_str()), ("z0", "z9_wall"));
        assert!(
            (low.position[2] - 0.015).abs() < 1e-12 && (wall.position[2] - 0.285).abs() < 1e-12
        );
        assert_eq!(low.face.unwrap().reading, shared::scene::FaceReading::Fluid);
        assert_eq!(wall.face.unwrap().reading, shared::scene::FaceReading::Wall);
        assert_eq!(wall.face.unwrap().span, s.probes[STRIP].face.unwrap().span);
        let times: Vec<f64> = (0..6).map(|k| k as f64).collect();
        // Sensor 1 (series 0) rises past ONSET·ρ0 g H = 294 Pa at t = 1 s; the strip later.
        let onset = |from: usize| -> Vec<f64> {
            (0..6)
                .map(|k| if k >= from { 500.0 } else { 0.0 })
                .collect()
        };
        let mut series = vec![vec![0.0; 6]; PROFILE + 20];
        series[0] = onset(1);
        series[STRIP] = onset(2);
        for k in 0..10 {
            series[PROFILE + k] = (0..6)
                .map(|j| if j >= 1 { 2000.0 } else { f64::NAN })
                .collect();
            series[PROFILE + 10 + k] = vec![1000.0; 6];
        }
        let r = Impact {
            case: case.clone(),
            times,
            series,
            pulses: Vec::new(),
            particles: 0,
            steps: 0,
            seconds: 0.0,
        };
        let p = r.profile(1.0).expect("a profile");
        assert_eq!(p.start, 1.0);
        assert_eq!(p.cells.len(), 10);
        assert!(
            p.cells
                .iter()
                .all(|&(_, ip, iw)| ip == 2000.0 && iw == 1000.0),
            "{p:?}"
        );
        assert!(
            (p.pressure - 10.0 * 2000.0 * 0.03).abs() < 1e-9
                && (p.wall - 10.0 * 1000.0 * 0.03).abs() < 1e-9
        );
        // The lowest layer's mean, of a profile that falls with height.
        let falling = Profile {
            cells: (0..4)
                .map(|k| (k as f64, 10.0 - k as f64, 5.0 - k as f64))
                .collect(),
            ..p.clone()
        };
        assert_eq!(falling.lowest(1), Some((10.0, 5.0)));
        assert_eq!(falling.lowest(2), Some((9.5, 4.5)));
        assert_eq!(falling.lowest(4), Some((8.5, 3.5)));
        assert_eq!((falling.lowest(0), falling.lowest(5)), (None, None));
        // Without the profile's probes there is none.
        let plain = Impact {
            case: ImpactCase::new(0.3, 10, None),
            ..r
        };
        assert!(plain.profile(1.0).is_none());
    }

    #[test]
    fn the_scene_has_the_tank_the_column_and_the_sensors() {
        let case = ImpactCase::new(0.3, 10, Some(1e-3));
        let s = impact_scene("wcsph", &case);
        // Each sensor three times: its face's pressure, then (from WALL on) the wall's load,
        // then (from STRIP on) the wall's load along the middle half of the width.
        assert_eq!(s.probes.len(), 3 * WALL);
        assert!(s.probes.iter().all(|p| p.position[0] == case.length));
        // The tank's length is a whole number of spacings, within half a spacing of the
        // experiment's: the sensors' wall lies between two rows of the lattice.
        for (h, per_h) in [(0.3, 15), (0.6, 15), (0.6, 30), (0.3, 30), (0.3, 8)] {
            let c = ImpactCase::new(h, per_h, None);
            let cells = c.length / c.dx();
            assert!((cells - cells.round()).abs() < 1e-9, "{h} {per_h}: {cells}");
            assert!((c.length - TANK_LENGTH).abs() <= 0.5 * c.dx() + 1e-12);
        }
        assert_eq!(s.probes[0].window, Some(1e-3));
        let face = s.probes[0].face.expect("a sensing face");
        assert_eq!((face.diameter, face.normal), (0.0042, [-1.0, 0.0, 0.0]));
        assert_eq!(face.reading, shared::scene::FaceReading::Fluid);
        let wall = s.probes[WALL].face.expect("a sensing face");
        assert_eq!(wall.reading, shared::scene::FaceReading::Wall);
        assert_eq!(s.probes[WALL].position, s.probes[0].position);
        assert_eq!(s.probes[WALL].name, "s1_wall");
        let strip = s.probes[STRIP].face.expect("a sensing face");
        assert_eq!(strip.reading, shared::scene::FaceReading::Wall);
        assert_eq!(s.probes[STRIP].position, s.probes[0].position);
        assert_eq!(s.probes[STRIP].name, "s1_strip");
        // 150 mm wide at 30 mm (5 layers): the strip is its middle 75 mm.
        let span = strip.span.expect("a span");
        assert!(
            span[0] == 0.0 && span[2] == 0.0 && (span[1] - 0.075).abs() < 1e-12,
            "{span:?}"
        );
        assert!((s.probes[3].position[2] - 0.08).abs() < 1e-12);
        // The step cap is the window's length and the slab the tank's width (150 mm: 5
        // layers of 30 mm), at least SLAB_LAYERS (8 of 37.5 mm at H = 600 mm, H/dx = 16,
        // not 4), unless the study asks for others.
        assert_eq!(s.time.dt_max, 1e-3);
        assert!((s.domain.max[1] - 5.0 * case.dx()).abs() < 1e-12);
        assert_eq!(ImpactCase::new(0.6, 16, None).layers, SLAB_LAYERS);
        assert_eq!(ImpactCase::new(0.3, 60, None).layers, 30);
        let other = ImpactCase {
            dt_max: 2.5e-4,
            layers: 15,
            ..case.clone()
        };
        let s = impact_scene("dfsph", &other);
        assert_eq!(s.time.dt_max, 2.5e-4);
        assert!((s.domain.max[1] - 15.0 * case.dx()).abs() < 1e-12);
        assert!((s.probes[0].position[1] - 7.5 * case.dx()).abs() < 1e-12);
        // A grid shift moves the domain's lower corner only.
        let shifted = impact_scene(
            "dfsph",
            &ImpactCase {
                grid_shift: 0.013,
                ..other.clone()
            },
        );
        assert_eq!(shifted.domain.min, [-0.013; 3]);
        assert_eq!(shifted.domain.max, s.domain.max);
        assert_eq!(
            format!("{:?}{:?}", shifted.probes, shifted.blocks),
            format!("{:?}{:?}", s.probes, s.blocks)
        );
    }

    /// scenes/validation/lobovsky_impact.toml is `fluid-validate`'s H/dx = 30 case as a scene
    /// for the coupler: the tank, water, walls, lid and sensors of [`impact_scene`] (every
    /// number to 10⁻⁹ of itself), its step cap and output interval, and its end to the file's
    /// four digits. So the file follows the study (it once stayed a 4-layer slab without the
    /// sensors' faces after the study took the tank's width).
    #[test]
    fn the_shipped_scene_is_the_studys_case_at_h_dx_30() {
        let path = "scenes/validation/lobovsky_impact.toml";
        let text = include_str!("../../../scenes/validation/lobovsky_impact.toml");
        let mut file = Scene::parse(text, path).expect("the shipped scene parses");
        let made = impact_scene("wcsph", &ImpactCase::new(0.3, 30, Some(1e-3)));
        let end = (file.time.end - made.time.end).abs();
        assert!(
            end < 1e-4,
            "{path}: end {} s, the study's {} s",
            file.time.end,
            made.time.end
        );
        assert_eq!(
            file.output.interval, made.output.interval,
            "{path}: output interval"
        );
        // What the file adds for a reader and a coupler run: its description and no frames.
        (file.time.end, file.description, file.output) =
            (made.time.end, made.description.clone(), made.output.clone());
        let value = |s: &Scene| toml::Value::try_from(s).expect("a scene serialises");
        close(&value(&file), &value(&made), path);
    }

    /// Panics unless `a` and `b` have the same keys, lengths and values, numbers to 10⁻⁹ of
    /// their size (the generated scene's 1.61 + 0.1 is not the file's 1.71 to the bit).
    fn close(a: &toml::Value, b: &toml::Value, at: &str) {
        use toml::Value::{Array, Float, Integer, Table};
        let number = |v: &toml::Value| match v {
            Float(x) => Some(*x),
            Integer(i) => Some(*i as f64),
            _ => None,
        };
        match (a, b) {
            (Table(x), Table(y)) => {
                let keys = |t: &toml::Table| t.keys().cloned().collect::<Vec<_>>();
                assert_eq!(keys(x), keys(y), "{at}: keys");
                for (k, v) in x {
                    close(v, &y[k], &format!("{at}.{k}"));
                }
            }
            (Array(x), Array(y)) => {
                assert_eq!(x.len(), y.len(), "{at}: length");
                for (i, (v, w)) in x.iter().zip(y).enumerate() {
                    close(v, w, &format!("{at}[{i}]"));
                }
            }
            _ => match (number(a), number(b)) {
                (Some(x), Some(y)) => {
                    assert!(
                        (x - y).abs() <= 1e-9 * x.abs().max(y.abs()),
                        "{at}: {x} against {y}"
                    )
                }
                _ => assert_eq!(a, b, "{at}"),
            },
        }
    }
}
