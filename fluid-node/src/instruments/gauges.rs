//! Wave gauges (free-surface elevation at (x, y)) and pressure probes, written as CSV time series
//! (`gauges.csv`: `time,<names...>,<name>_spray...`; `probes.csv`: `time,<names...>`) in the run
//! directory.
//!
//! # What a gauge reads
//!
//! The free surface is where the kernel-interpolated fluid fraction
//!
//! φ(z) = Σ_j (m_j/ρ0) W(|(x, y, z) − x_j|)
//!
//! (the SPH interpolation of paper Eq. 11 applied to unity, i.e. the interpolated mass density
//! over ρ0) drops to one half, on the vertical line through the gauge: the definition of the
//! mass-threshold free-surface gauges of DualSPHysics (Crespo et al. 2015, "DualSPHysics:
//! open-source parallel CFD solver based on SPH", Comput. Phys. Commun. 187:204–216; its
//! `MeasureTool` and `GaugeSwl` put the surface where the kernel-interpolated mass falls below
//! half the reference, see docs/VALIDATION.md "Wave gauges"). The reference volume m/ρ0 is
//! used rather than m/ρ_j because with summation density (Müller et al. 2003, Eq. 3) a lone
//! droplet has ρ_j = m W(0) and would read φ = 1 at its centre.
//!
//! The line is sampled from the bed upwards every dx/4 (linear interpolation between samples):
//!
//! 1. The *water column* is the lowest stretch with φ ≥ ½ φ0 (φ0 = φ of a full particle
//!    lattice) that either starts within one kernel support plus dx of the bed or is at least one
//!    kernel support plus dx thick (water over a submerged moving block). Spray, droplets and a
//!    one-particle sheet crossing the line make thinner stretches (about 2 dx), so above a dry
//!    bed they do not count, and above the water they are never reached: the scan stops at the
//!    column's top.
//! 2. The surface is where φ falls below half the column's own largest φ, φ_max (= φ0 in open
//!    water), so a gauge in a narrow slab or near a wall, where the fluid-only sum is lower
//!    because there is no fluid on one side, still reads the surface and not below it.
//!
//! The *bed* is the top of the highest fixed block on the vertical line, or the domain floor
//! ([`shared::scene::Scene::bed_elevation`]). A **dry gauge** (no water column under it: no
//! fluid there, or less than about one particle spacing of it) **reads the bed elevation**; no
//! NaN is ever written. A gauge whose reading equals its bed elevation is dry.
//!
//! `<name>_spray` is the former reading, kept as the height of the highest water: half a
//! spacing above the highest particle within one spacing of the line, spray and droplets
//! included (the bed elevation when there is none).
//!
//! Samples are taken after a step but no more often than `output.interval/50`
//! ([`ROWS_PER_INTERVAL`]) of simulated time, and every row is flushed to the file as it is
//! written, so a run that is killed keeps everything it had recorded.
//!
//! # What a probe reads
//!
//! The Shepard-normalised SPH interpolation of the particles' pressure at the probe's point
//! ([`FluidView::pressure_at`]); NaN where no particle is within a kernel support (a dry point).
//! A probe with `window = w` ([`ProbeSpec::window`]) is read after **every** step instead, and
//! its row at time t holds the time-weighted box average over (t − w, t] (over (0, t] while
//! t < w) of those readings, each held over the step it ends ([`BoxAverage`]): a pressure
//! sensor sampled by an acquisition that averages over w. In the average a dry reading counts as
//! 0 Pa (atmospheric: pressures are gauge pressures), and a window with no wet reading is NaN,
//! like the instantaneous dry reading.
//!
//! A probe with a sensing `face` ([`ProbeSpec::face`]) reads the mean over the face's disk:
//! the weighted sum of seven point probes ([`shared::scene::ProbeFace::points`], Stroud's rule),
//! each read (and box-averaged) as above and owned on several ranks by the rank holding its own
//! point, then combined as the row is written; a dry point counts as 0 Pa, and a face whose
//! every point is dry reads NaN. A face with `reading = "wall"` is read once, as the wall's
//! load behind it ([`super::wall_load`], summed before the row by the method's wall term), and
//! reads 0 Pa while the wall is dry.

use crate::core::grid::CellGrid;
use crate::core::particles::Particles;
use crate::kernels::Kernel;
use crate::ranks::share::Share;
use shared::math::{Real, Vector};
use shared::scene::{FaceReading, GaugeSpec, ProbeSpec};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

/// Instrument rows per `output.interval` at most: a row is taken after a step once
/// `output.interval / ROWS_PER_INTERVAL` of simulated time has passed since the last.
pub const ROWS_PER_INTERVAL: Real = 50.0;

/// Rows between flushes: every row reaches the file at once (at most 50 rows per output
/// interval: the cost is nothing next to a step).
const FLUSH_EVERY: usize = 1;

struct Series {
    file: BufWriter<File>,
    row: Vec<Real>,
}

impl Series {
    fn create(path: &Path, names: impl Iterator<Item = String>) -> std::io::Result<Self> {
        let mut file = BufWriter::new(File::create(path)?);
        let mut header = String::from("time");
        for n in names {
            header.push(',');
            header.push_str(&n);
        }
        writeln!(file, "{header}")?;
        file.flush()?;
        Ok(Self {
            file,
            row: Vec::new(),
        })
    }

    /// Continues the file at `path` (no header): a resumed run appends where the checkpoint
    /// left it (the coupler cut the file back to that length).
    fn append(path: &Path) -> std::io::Result<Self> {
        let file = std::fs::OpenOptions::new().append(true).open(path)?;
        Ok(Self {
            file: BufWriter::new(file),
            row: Vec::new(),
        })
    }

    fn write(&mut self, time: Real) -> std::io::Result<()> {
        write!(self.file, "{time:.6}")?;
        for v in &self.row {
            write!(self.file, ",{v:.6}")?;
        }
        writeln!(self.file)
    }
}

/// The time-weighted box average of a piecewise-constant signal over a trailing window: each
/// reading holds from the previous reading's time to its own (module doc, "What a probe reads").
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct BoxAverage {
    window: Real,
    /// (time, reading) of the readings whose interval reaches into the window, oldest first.
    readings: std::collections::VecDeque<(Real, Real)>,
    /// Time of the reading before the oldest kept one (the start of its interval).
    start: Real,
}

impl BoxAverage {
    /// An average over `window` seconds of readings starting at time `start`.
    pub fn new(window: Real, start: Real) -> Self {
        Self {
            window,
            readings: Default::default(),
            start,
        }
    }

    /// Adds the reading at `time` (held over (previous time, time]).
    pub fn push(&mut self, time: Real, value: Real) {
        self.readings.push_back((time, value));
        // Drop readings whose interval ended before the window.
        while let Some(&(t, _)) = self.readings.front() {
            if t <= time - self.window && self.readings.len() > 1 {
                self.start = t;
                self.readings.pop_front();
            } else {
                break;
            }
        }
    }

    /// The average over (t − w, t] at the latest reading's time t (over what was read if less);
    /// NaN readings count as 0, and NaN when every reading in the window is NaN or there is none.
    pub fn mean(&self) -> Real {
        let Some(&(now, _)) = self.readings.back() else {
            return Real::NAN;
        };
        let from = (now - self.window).max(self.start);
        let (mut sum, mut span, mut wet) = (0.0, 0.0, false);
        let mut prev = self.start;
        for &(t, v) in &self.readings {
            let held = t - prev.max(from);
            if held > 0.0 {
                span += held;
                if v.is_finite() {
                    sum += v * held;
                    wet = true;
                }
            }
            prev = t;
        }
        if wet && span > 0.0 {
            sum / span
        } else {
            Real::NAN
        }
    }
}

/// The points the probes are read at: each probe's own, or its face's seven, as point probes
/// with the probe's window; and each probe's weights over its consecutive points. A face that
/// reads the wall is one point, its centre, keeping its face (the reading is the wall's,
/// [`super::wall_load`]).
fn probe_points(probes: &[ProbeSpec]) -> (Vec<ProbeSpec>, Vec<Vec<Real>>) {
    let (mut points, mut weights) = (Vec::new(), Vec::new());
    for p in probes {
        let point = |position| ProbeSpec {
            position,
            face: None,
            ..p.clone()
        };
        match p.face {
            None => {
                points.push(point(p.position));
                weights.push(vec![1.0]);
            }
            Some(face) if face.reading == FaceReading::Wall => {
                points.push(p.clone());
                weights.push(vec![1.0]);
            }
            Some(face) => {
                let rule = face.rule(p.position);
                points.extend(rule.iter().map(|&(x, _)| point(x)));
                weights.push(rule.iter().map(|&(_, w)| w).collect());
            }
        }
    }
    (points, weights)
}

/// A probe's reading from its points' `readings` and `weights`: a dry (NaN) point counts as
/// 0 Pa; NaN when every point is dry. One point: its reading as it is.
fn face_mean(readings: &[Real], weights: &[Real]) -> Real {
    if readings.iter().all(|r| !r.is_finite()) {
        return Real::NAN;
    }
    readings
        .iter()
        .zip(weights)
        .map(|(r, w)| if r.is_finite() { r * w } else { 0.0 })
        .sum()
}

/// Gauges and probes of a scene and their CSV files.
/// Where a [`Recorder`] is in its sampling, for a checkpoint: the last sample time, the rows
/// written, and the probes' running box averages.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct RecorderMark {
    last: Real,
    rows: usize,
    pub(crate) averages: Vec<Option<BoxAverage>>,
}

pub struct Recorder {
    gauges: Vec<GaugeSpec>,
    /// Bed elevation under each gauge: what a dry gauge reads.
    beds: Vec<Real>,
    /// The points read: every probe's own point, or its face's seven ([`probe_points`]).
    probes: Vec<ProbeSpec>,
    /// Of each point, the scene's probe whose wall load it reads ([`FluidView::wall_loads`]),
    /// if its face reads the wall.
    walls: Vec<Option<usize>>,
    /// Of each probe of the scene, in order: the weights of its consecutive points in `probes`.
    weights: Vec<Vec<Real>>,
    gauge_file: Option<Series>,
    probe_file: Option<Series>,
    /// The box average of each point with a window ([`ProbeSpec::window`]).
    averages: Vec<Option<BoxAverage>>,
    min_interval: Real,
    last: Real,
    rows: usize,
    /// Scratch: the row being read (all instruments; rank 0 of several merges the owners').
    row: Vec<Real>,
}

impl Recorder {
    /// Opens the files (only those the scene has instruments for). `beds[i]` is the bed
    /// elevation under gauge i ([`shared::scene::Scene::bed_elevation`]).
    pub fn new(
        run_dir: &Path,
        gauges: &[GaugeSpec],
        beds: &[Real],
        probes: &[ProbeSpec],
        output_interval: Real,
        files: bool,
    ) -> std::io::Result<Self> {
        let gauge_file = if gauges.is_empty() || !files {
            None
        } else {
            Some(Series::create(
                &run_dir.join("gauges.csv"),
                gauges
                    .iter()
                    .map(|g| g.name.clone())
                    .chain(gauges.iter().map(|g| format!("{}_spray", g.name))),
            )?)
        };
        let probe_file = if probes.is_empty() || !files {
            None
        } else {
            Some(Series::create(
                &run_dir.join("probes.csv"),
                probes.iter().map(|p| p.name.clone()),
            )?)
        };
        let (points, weights) = probe_points(probes);
        let walls = weights
            .iter()
            .enumerate()
            .flat_map(|(k, w)| {
                let wall = probes[k]
                    .face
                    .is_some_and(|f| f.reading == FaceReading::Wall);
                std::iter::repeat_n(wall.then_some(k), w.len())
            })
            .collect();
        Ok(Self {
            walls,
            gauges: gauges.to_vec(),
            beds: beds.to_vec(),
            averages: points
                .iter()
                .map(|p| p.window.map(|w| BoxAverage::new(w, 0.0)))
                .collect(),
            probes: points,
            weights,
            gauge_file,
            probe_file,
            row: Vec::new(),
            min_interval: output_interval / ROWS_PER_INTERVAL,
            last: Real::NEG_INFINITY,
            rows: 0,
        })
    }

    /// Records one row if at least `output.interval/50` has passed since the last one. On
    /// several ranks (`share`) every rank reads every instrument and rank 0 writes, for each,
    /// the reading of the rank owning the point (its neighbourhood is whole there).
    pub fn sample<K: Kernel>(
        &mut self,
        time: Real,
        view: &FluidView<'_, K>,
        share: Option<&Share>,
    ) -> std::io::Result<()> {
        if self.gauges.is_empty() && self.probes.is_empty() {
            return Ok(());
        }
        // Windowed probes read after every step.
        for ((p, avg), wall) in self.probes.iter().zip(&mut self.averages).zip(&self.walls) {
            if let Some(avg) = avg {
                avg.push(time, view.probe(p, *wall));
            }
        }
        if time - self.last < self.min_interval * (1.0 - 1e-9) {
            return Ok(());
        }
        self.last = time;
        let mut row = std::mem::take(&mut self.row);
        row.clear();
        let reference = view.lattice_fraction();
        let cols = self.gauges.iter().zip(&self.beds);
        row.extend(
            cols.clone()
                .map(|(g, &bed)| view.surface_elevation(g.x, g.y, bed, reference)),
        );
        row.extend(cols.map(|(g, &bed)| view.spray_elevation(g.x, g.y, bed)));
        row.extend(self.probes.iter().zip(&self.averages).zip(&self.walls).map(
            |((p, avg), wall)| match avg {
                Some(avg) => avg.mean(),
                None => view.probe(p, *wall),
            },
        ));
        if let Some(s) = share {
            let at = |x: Real, y: Real| s.owner_at(view.grid, &Vector::new(x, y, 0.0));
            let gauges = self.gauges.iter().map(|g| at(g.x, g.y));
            let owners: Vec<usize> = gauges
                .clone()
                .chain(gauges)
                .chain(self.probe_owners(s, view.grid))
                .collect();
            s.merge(&mut row, &owners);
        }
        let (g, p) = row.split_at(2 * self.gauges.len());
        if let Some(s) = &mut self.gauge_file {
            s.row.clear();
            s.row.extend_from_slice(g);
            s.write(time)?;
        }
        if let Some(s) = &mut self.probe_file {
            s.row.clear();
            let mut at = 0;
            for w in &self.weights {
                s.row.push(face_mean(&p[at..at + w.len()], w));
                at += w.len();
            }
            s.write(time)?;
        }
        // Kept for its capacity.
        self.row = row;
        self.rows += 1;
        if self.rows.is_multiple_of(FLUSH_EVERY) {
            self.flush()?;
        }
        Ok(())
    }

    /// The rank owning each probe's point (on several ranks): rank 0 for a wall reading, which
    /// rank 0 sums from every rank's terms ([`super::wall_load::WallLoads::read`]).
    pub fn probe_owners(&self, share: &Share, grid: &CellGrid) -> Vec<usize> {
        self.probes
            .iter()
            .zip(&self.walls)
            .map(|(p, wall)| match wall {
                Some(_) => 0,
                None => share.owner_at(grid, &Vector::from(p.position)),
            })
            .collect()
    }

    /// The sampling state a checkpoint keeps: the last sample's time and the row count.
    pub fn mark(&self) -> RecorderMark {
        RecorderMark {
            last: self.last,
            rows: self.rows,
            averages: self.averages.clone(),
        }
    }

    /// Continues the files in `run_dir` from a checkpoint's `mark` (instead of the ones this
    /// recorder started).
    pub fn resume(&mut self, run_dir: &Path, mark: RecorderMark) -> std::io::Result<()> {
        if mark.averages.len() != self.averages.len() {
            return Err(std::io::Error::other(
                "the checkpoint's probe averages do not match the scene's probes",
            ));
        }
        (self.last, self.rows, self.averages) = (mark.last, mark.rows, mark.averages);
        if self.gauge_file.is_some() {
            self.gauge_file = Some(Series::append(&run_dir.join("gauges.csv"))?);
        }
        if self.probe_file.is_some() {
            self.probe_file = Some(Series::append(&run_dir.join("probes.csv"))?);
        }
        Ok(())
    }

    pub fn flush(&mut self) -> std::io::Result<()> {
        for s in [&mut self.gauge_file, &mut self.probe_file]
            .into_iter()
            .flatten()
        {
            s.file.flush()?;
        }
        Ok(())
    }
}

/// What the instruments read: the particles, their grid and the solver's interpolation kernel.
pub struct FluidView<'a, K: Kernel> {
    pub particles: &'a Particles,
    pub grid: &'a CellGrid,
    pub kernel: &'a K,
    pub mass: Real,
    /// Rest density ρ0: m/ρ0 is the reference volume of the fluid fraction.
    pub rest_density: Real,
    pub dx: Real,
    /// Each scene probe's wall load of the step ([`super::wall_load`]; read by the probes whose
    /// face reads the wall).
    pub wall_loads: &'a [Real],
}

impl<K: Kernel> FluidView<'_, K> {
    /// What probe point `p` reads: the wall load of scene probe `wall`, or the water's pressure
    /// at the point.
    fn probe(&self, p: &ProbeSpec, wall: Option<usize>) -> Real {
        match wall {
            Some(k) => self.wall_loads[k],
            None => self.pressure_at(&Vector::from(p.position)),
        }
    }

    /// φ0: the fluid fraction Σ (m/ρ0) W at a node of a full cubic lattice of spacing dx (the
    /// fill lattice), the reference the half threshold is taken of (≈ 1; 1.0098 for the poly6
    /// kernel with h = 2 dx).
    pub fn lattice_fraction(&self) -> Real {
        let s = self.kernel.support();
        let n = (s / self.dx).ceil() as i32;
        let mut sum = 0.0;
        for i in -n..=n {
            for j in -n..=n {
                for k in -n..=n {
                    let r = self.dx * ((i * i + j * j + k * k) as Real).sqrt();
                    sum += self.kernel.value(r);
                }
            }
        }
        sum * self.mass / self.rest_density
    }

    /// Free-surface elevation at (x, y): the top of the water column over the bed where the
    /// fluid fraction φ falls below half its interior value (module doc); `bed` when dry.
    /// `reference` is [`Self::lattice_fraction`].
    pub fn surface_elevation(&self, x: Real, y: Real, bed: Real, reference: Real) -> Real {
        let support = self.kernel.support();
        let s2 = support * support;
        // The particles within one support of the line: (z, horizontal distance²), by z.
        let mut column: Vec<(Real, Real)> = Vec::new();
        let pos = &self.particles.position;
        self.grid
            .column_rows_top_down(&Vector::new(x, y, bed), |range| {
                for p in &pos[range] {
                    let d2 = (p.x - x).powi(2) + (p.y - y).powi(2);
                    if d2 < s2 {
                        column.push((p.z, d2));
                    }
                }
                false
            });
        if column.is_empty() {
            return bed;
        }
        column.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        let volume = self.mass / self.rest_density;
        let top = column[column.len() - 1].0 + support;
        // φ at increasing z: a window [lo, hi) of the sorted column within one support in z.
        let (mut lo, mut hi) = (0usize, 0usize);
        let mut fraction = |z: Real| {
            while lo < column.len() && column[lo].0 <= z - support {
                lo += 1;
            }
            while hi < column.len() && column[hi].0 < z + support {
                hi += 1;
            }
            column[lo..hi.max(lo)]
                .iter()
                .map(|&(zj, d2)| self.kernel.value((d2 + (z - zj).powi(2)).sqrt()))
                .sum::<Real>()
                * volume
        };
        let dz = 0.25 * self.dx;
        let wet = 0.5 * reference;
        let near_bed = bed + support + self.dx;
        let thick = support + self.dx;
        // Scan up from the bed for the water column: `samples` holds the current stretch with
        // φ ≥ ½ φ0 and, once it ends, the first sample above it.
        let mut z = bed.min(column[0].0);
        let mut start: Option<Real> = None;
        let mut largest: Real = 0.0;
        let mut samples: Vec<(Real, Real)> = Vec::new();
        let found = loop {
            if z > top + dz {
                break false;
            }
            let f = fraction(z);
            if f >= wet {
                if start.is_none() {
                    start = Some(z);
                    largest = 0.0;
                    samples.clear();
                }
                largest = largest.max(f);
                samples.push((z, f));
            } else if let Some(s) = start {
                samples.push((z, f));
                if s <= near_bed || z - s >= thick {
                    break true;
                }
                // Spray, a droplet or a sheet: thin, off the bed.
                start = None;
            }
            z += dz;
        };
        if !found {
            return bed;
        }
        // The highest crossing of ½ φ_max: above the stretch when φ_max < φ0 (a slab, a wall),
        // inside it when the water is compressed (φ_max > φ0).
        let half = 0.5 * largest;
        while let Some(&(zl, fl)) = samples.last() {
            if fl < half || zl > top + dz {
                break;
            }
            samples.push((zl + dz, fraction(zl + dz)));
        }
        match samples
            .windows(2)
            .rposition(|w| w[0].1 >= half && w[1].1 < half)
        {
            Some(i) => {
                let ((z0, f0), (z1, f1)) = (samples[i], samples[i + 1]);
                z0 + (f0 - half) / (f0 - f1) * (z1 - z0)
            }
            None => samples.last().map_or(bed, |s| s.0),
        }
    }

    /// The highest water at (x, y), spray included: half a spacing above the highest particle
    /// within one spacing of the vertical line; `bed` where there is none.
    pub fn spray_elevation(&self, x: Real, y: Real, bed: Real) -> Real {
        let mut top = Real::NEG_INFINITY;
        let probe = Vector::new(x, y, 0.0);
        let r2 = self.dx * self.dx;
        let pos = &self.particles.position;
        self.grid.column_rows_top_down(&probe, |range| {
            for i in range {
                let p = pos[i];
                if (p.x - x).powi(2) + (p.y - y).powi(2) <= r2 {
                    top = top.max(p.z);
                }
            }
            top > Real::NEG_INFINITY
        });
        if top.is_finite() {
            top + 0.5 * self.dx
        } else {
            bed
        }
    }

    /// Shepard-normalised SPH interpolation of pressure at a point (paper Eq. 11 divided by the
    /// interpolated unity, so the value is not diluted near a wall or the surface); NaN when no
    /// particle is within the kernel support.
    pub fn pressure_at(&self, x: &Vector) -> Real {
        let (mut num, mut den) = (0.0, 0.0);
        let s2 = self.kernel.support().powi(2);
        let p = self.particles;
        self.grid.neighbor_rows(x, |range| {
            for j in range {
                let r2 = (x - p.position[j]).norm_squared();
                if r2 < s2 {
                    let w = self.mass / p.density[j] * self.kernel.value(r2.sqrt());
                    num += p.pressure[j] * w;
                    den += w;
                }
            }
        });
        if den > 0.0 { num / den } else { Real::NAN }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernels::{Poly6, WendlandC2};

    /// Stroud's 7-point disk rule integrates the face's moments up to degree 5
    /// exactly: mean of 1, of r² (R²/2) and of r⁴ (R⁴/3), and of u⁴ (R⁴/8) along any direction
    /// in the face; every point lies in the face's plane, within its radius.
    #[test]
    fn a_face_is_read_at_seven_points_that_integrate_its_disk() {
        let face = shared::scene::ProbeFace {
            diameter: 0.02,
            normal: [-2.0, 0.0, 0.0],
            reading: Default::default(),
            span: None,
        };
        let (c, r) = ([1.0, 0.5, 0.003], 0.01);
        let rule = face.points(c);
        let mean = |f: &dyn Fn([f64; 3]) -> f64| rule.iter().map(|&(x, w)| w * f(x)).sum::<f64>();
        let d = |x: [f64; 3], k: usize| x[k] - c[k];
        let r2 = |x: [f64; 3]| d(x, 1).powi(2) + d(x, 2).powi(2);
        assert!((mean(&|_| 1.0) - 1.0).abs() < 1e-15);
        assert!((mean(&r2) - r * r / 2.0).abs() < 1e-18);
        assert!((mean(&|x| r2(x).powi(2)) - r.powi(4) / 3.0).abs() < 1e-20);
        assert!((mean(&|x| d(x, 2).powi(4)) - r.powi(4) / 8.0).abs() < 1e-20);
        for (x, _) in rule {
            assert_eq!(x[0], c[0], "off the wall's plane: {x:?}");
            assert!(r2(x) <= r * r, "outside the face: {x:?}");
        }
    }

    /// A face swept along a span is read at the seven points of disks centred along it, at
    /// most half a diameter apart, the weights shared: the mean of a field linear along the
    /// span is its value at the centre, and the centres' mean square distance from it is the
    /// line's, (span/2)²/3, less the midpoint rule's (piece/2)²/3.
    #[test]
    fn a_strip_is_read_at_disks_along_its_span() {
        let face = shared::scene::ProbeFace {
            diameter: 0.004,
            normal: [-1.0, 0.0, 0.0],
            reading: Default::default(),
            span: Some([0.0, 0.1, 0.0]),
        };
        let c = [1.0, 0.5, 0.003];
        let centres = face.centres(c);
        // 0.1 m in pieces of at most 2 mm: 50 disks, their centres 1 mm in from the ends.
        assert_eq!(centres.len(), 50);
        assert!((centres[0][1] - 0.451).abs() < 1e-12 && (centres[49][1] - 0.549).abs() < 1e-12);
        let rule = face.rule(c);
        assert_eq!(rule.len(), 7 * 50);
        let mean = |f: &dyn Fn([f64; 3]) -> f64| rule.iter().map(|&(x, w)| w * f(x)).sum::<f64>();
        assert!((mean(&|_| 1.0) - 1.0).abs() < 1e-12);
        assert!(mean(&|x| x[1] - c[1]).abs() < 1e-15);
        let (half, piece) = (0.05, 0.002);
        let second = half * half / 3.0 - (piece / 2.0f64).powi(2) / 3.0;
        // (The rule's points add each disk's own spread about its centre: the centres alone.)
        let along: f64 = centres.iter().map(|x| (x[1] - c[1]).powi(2)).sum::<f64>() / 50.0;
        assert!((along - second).abs() < 1e-12, "{along} vs {second}");
        for (x, _) in &rule {
            assert_eq!(x[0], c[0], "off the wall's plane: {x:?}");
        }
        // Without a span: the disk's seven points, weights as they are.
        let disk = shared::scene::ProbeFace { span: None, ..face };
        assert_eq!(disk.rule(c), disk.points(c).to_vec());
    }

    /// A face's points combine by their weights; a dry point counts as 0 Pa (atmospheric), and
    /// a face dry at every point reads NaN, like a dry point probe.
    #[test]
    fn a_face_reading_counts_dry_points_as_atmospheric() {
        let w = [0.25, 0.125, 0.125, 0.125, 0.125, 0.125, 0.125];
        let wet = [100.0, 200.0, 200.0, 200.0, 200.0, 200.0, 200.0];
        assert_eq!(face_mean(&wet, &w), 175.0);
        let mut half = wet;
        half[1..4].fill(Real::NAN);
        assert_eq!(face_mean(&half, &w), 25.0 + 3.0 * 25.0);
        assert!(face_mean(&[Real::NAN; 7], &w).is_nan());
        assert_eq!(face_mean(&[42.0], &[1.0]), 42.0);
        assert!(face_mean(&[Real::NAN], &[1.0]).is_nan());
    }

    const DX: Real = 0.05;
    const RHO: Real = 1000.0;

    /// Lattice particles (cell centres) filling [lo, hi].
    fn block(lo: [Real; 3], hi: [Real; 3]) -> Vec<Vector> {
        let n = |k: usize| ((hi[k] - lo[k]) / DX).round() as usize;
        let mut out = Vec::new();
        for i in 0..n(0) {
            for j in 0..n(1) {
                for k in 0..n(2) {
                    out.push(Vector::new(
                        lo[0] + (i as Real + 0.5) * DX,
                        lo[1] + (j as Real + 0.5) * DX,
                        lo[2] + (k as Real + 0.5) * DX,
                    ));
                }
            }
        }
        out
    }

    /// (surface, spray) at (x, y) over a bed at z = 0 for the particles `pts`.
    fn read<K: Kernel>(kernel: &K, pts: &[Vector], x: Real, y: Real) -> (Real, Real) {
        let mut grid = CellGrid::new(
            Vector::new(-0.2, -0.2, -0.2),
            Vector::new(1.2, 1.2, 2.0),
            kernel.support(),
        )
        .unwrap();
        let order = grid.sort(pts).to_vec();
        let sorted: Vec<Vector> = order.iter().map(|&i| pts[i as usize]).collect();
        let n = sorted.len();
        let particles = Particles::new(sorted, vec![RHO; n]);
        let view = FluidView {
            particles: &particles,
            grid: &grid,
            kernel,
            mass: RHO * DX.powi(3),
            rest_density: RHO,
            dx: DX,
            wall_loads: &[],
        };
        let reference = view.lattice_fraction();
        (
            view.surface_elevation(x, y, 0.0, reference),
            view.spray_elevation(x, y, 0.0),
        )
    }

    /// Still water 0.5 m deep over [0, 1]² (20 × 20 × 10 particles).
    fn pool() -> Vec<Vector> {
        block([0.0, 0.0, 0.0], [1.0, 1.0, 0.5])
    }

    fn each_kernel(check: impl Fn(&str, &dyn Fn(&[Vector], Real, Real) -> (Real, Real))) {
        // The kernels the solvers interpolate with: Müller's poly6 (h = 2 dx), WCSPH's Wendland
        // C2 (h = 1.3 dx).
        let poly6 = Poly6::new(2.0 * DX);
        let wendland = WendlandC2::new(1.3 * DX);
        check("poly6", &|p, x, y| read(&poly6, p, x, y));
        check("wendland", &|p, x, y| read(&wendland, p, x, y));
    }

    #[test]
    fn still_water_reads_its_surface() {
        each_kernel(|name, read| {
            for (x, y) in [(0.5, 0.5), (0.52, 0.47), (0.1, 0.9)] {
                let (eta, spray) = read(&pool(), x, y);
                assert!((eta - 0.5).abs() < 0.2 * DX, "{name} at ({x}, {y}): {eta}");
                assert!((spray - 0.5).abs() < 1e-12, "{name}: spray {spray}");
            }
        });
    }

    #[test]
    fn a_spray_droplet_above_the_water_does_not_move_the_reading() {
        each_kernel(|name, read| {
            let (still, _) = read(&pool(), 0.5, 0.5);
            let mut pts = pool();
            // The reported case: one droplet ~0.75 m above the line.
            pts.push(Vector::new(0.5, 0.5, 1.25));
            let (eta, spray) = read(&pts, 0.5, 0.5);
            assert!((eta - still).abs() < 1e-9, "{name}: {eta} vs {still}");
            assert!(
                (spray - 1.275).abs() < 1e-9,
                "{name}: the spray column shows it"
            );
        });
    }

    #[test]
    fn a_thin_sheet_crossing_above_the_water_does_not_move_the_reading() {
        each_kernel(|name, read| {
            let (still, _) = read(&pool(), 0.5, 0.5);
            // A horizontal sheet one particle thick 3 dx above the surface, over the gauge.
            let mut pts = pool();
            pts.extend(block([0.2, 0.2, 0.65], [0.8, 0.8, 0.65 + DX]));
            let (eta, _) = read(&pts, 0.5, 0.5);
            assert!((eta - still).abs() < DX, "{name}: {eta} vs {still}");
        });
    }

    #[test]
    fn a_dry_gauge_reads_the_bed() {
        each_kernel(|name, read| {
            // No water within reach of the line.
            let pts = block([0.0, 0.0, 0.0], [0.3, 1.0, 0.5]);
            assert_eq!(read(&pts, 0.8, 0.5), (0.0, 0.0), "{name}");
            // Only a sheet of spray passing over the dry bed.
            let sheet = block([0.5, 0.2, 0.3], [1.0, 0.8, 0.3 + DX]);
            let (eta, spray) = read(&sheet, 0.8, 0.5);
            assert_eq!(eta, 0.0, "{name}: the sheet is not a water column");
            assert!((spray - 0.35).abs() < 1e-9, "{name}: {spray}");
        });
    }

    #[test]
    fn a_narrow_slab_reads_its_surface() {
        // Quasi-2D tanks are 4 particles wide: the fluid-only sum is lower across the whole
        // slab, and the surface is where φ falls to half of the slab's own interior value.
        each_kernel(|name, read| {
            let pts = block([0.0, 0.4, 0.0], [1.0, 0.6, 0.5]);
            let (eta, _) = read(&pts, 0.5, 0.5);
            assert!((eta - 0.5).abs() < 0.2 * DX, "{name}: {eta}");
        });
    }

    #[test]
    fn a_column_over_a_submerged_body_counts_when_thick() {
        // Water 6 dx deep starting 0.2 m above the bed (over a block the gauge does not know).
        each_kernel(|name, read| {
            let pts = block([0.0, 0.0, 0.2], [1.0, 1.0, 0.5]);
            let (eta, _) = read(&pts, 0.5, 0.5);
            assert!((eta - 0.5).abs() < 0.2 * DX, "{name}: {eta}");
        });
    }

    #[test]
    fn the_box_average_weights_each_reading_by_its_step() {
        let mut a = BoxAverage::new(0.01, 0.0);
        assert!(a.mean().is_nan(), "no reading yet");
        // Steps of 2, 3 and 5 ms: readings 10, 20, 40 held over them.
        a.push(0.002, 10.0);
        assert!((a.mean() - 10.0).abs() < 1e-12, "over (0, t] while t < w");
        a.push(0.005, 20.0);
        a.push(0.010, 40.0);
        let full = (10.0 * 0.002 + 20.0 * 0.003 + 40.0 * 0.005) / 0.01;
        assert!((a.mean() - full).abs() < 1e-9, "{} vs {full}", a.mean());
        // At 11 ms the window (1, 11] ms keeps 1 ms of the first reading.
        a.push(0.011, 0.0);
        let slid = (10.0 * 0.001 + 20.0 * 0.003 + 40.0 * 0.005) / 0.01;
        assert!((a.mean() - slid).abs() < 1e-9, "{} vs {slid}", a.mean());
        // Long after, only the latest readings count.
        a.push(0.030, 7.0);
        assert!((a.mean() - 7.0).abs() < 1e-9, "{}", a.mean());
    }

    #[test]
    fn a_dry_reading_counts_as_atmospheric_and_a_dry_window_is_nan() {
        let mut a = BoxAverage::new(0.004, 0.0);
        a.push(0.002, Real::NAN);
        assert!(a.mean().is_nan());
        a.push(0.004, 100.0);
        assert!((a.mean() - 50.0).abs() < 1e-9, "{}", a.mean());
        a.push(0.008, Real::NAN);
        assert!(a.mean().is_nan(), "{}", a.mean());
    }
}
