//! Wave gauges (free-surface elevation at (x, y)) and pressure probes, written as CSV time series
//! (`gauges.csv`, `probes.csv`: `time,<names...>`) in the run directory.
//!
//! Samples are taken after a step but no more often than `output.interval/50` of simulated time,
//! and the files are flushed every few rows, at every frame and in `finish()`, so a run that is
//! killed keeps what it had recorded.

use crate::kernel::Kernel;
use crate::neighbors::CellGrid;
use crate::particles::Particles;
use shared::math::{Real, Vector};
use shared::scene::{GaugeSpec, ProbeSpec};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

/// Rows between flushes.
const FLUSH_EVERY: usize = 20;

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

    fn write(&mut self, time: Real) -> std::io::Result<()> {
        write!(self.file, "{time:.6}")?;
        for v in &self.row {
            write!(self.file, ",{v:.6}")?;
        }
        writeln!(self.file)
    }
}

/// Gauges and probes of a scene and their CSV files.
pub struct Recorder {
    gauges: Vec<GaugeSpec>,
    probes: Vec<ProbeSpec>,
    gauge_file: Option<Series>,
    probe_file: Option<Series>,
    min_interval: Real,
    last: Real,
    rows: usize,
}

impl Recorder {
    /// Opens the files (only those the scene has instruments for).
    pub fn new(
        run_dir: &Path,
        gauges: &[GaugeSpec],
        probes: &[ProbeSpec],
        output_interval: Real,
    ) -> std::io::Result<Self> {
        let gauge_file = if gauges.is_empty() {
            None
        } else {
            Some(Series::create(
                &run_dir.join("gauges.csv"),
                gauges.iter().map(|g| g.name.clone()),
            )?)
        };
        let probe_file = if probes.is_empty() {
            None
        } else {
            Some(Series::create(
                &run_dir.join("probes.csv"),
                probes.iter().map(|p| p.name.clone()),
            )?)
        };
        Ok(Self {
            gauges: gauges.to_vec(),
            probes: probes.to_vec(),
            gauge_file,
            probe_file,
            min_interval: output_interval / 50.0,
            last: Real::NEG_INFINITY,
            rows: 0,
        })
    }

    /// Records one row if at least `output.interval/50` has passed since the last one.
    pub fn sample<K: Kernel>(
        &mut self,
        time: Real,
        view: &FluidView<'_, K>,
    ) -> std::io::Result<()> {
        if self.gauge_file.is_none() && self.probe_file.is_none() {
            return Ok(());
        }
        if time - self.last < self.min_interval * (1.0 - 1e-9) {
            return Ok(());
        }
        self.last = time;
        if let Some(s) = &mut self.gauge_file {
            s.row.clear();
            s.row
                .extend(self.gauges.iter().map(|g| view.surface_elevation(g.x, g.y)));
            s.write(time)?;
        }
        if let Some(s) = &mut self.probe_file {
            s.row.clear();
            s.row.extend(
                self.probes
                    .iter()
                    .map(|p| view.pressure_at(&Vector::from(p.position))),
            );
            s.write(time)?;
        }
        self.rows += 1;
        if self.rows.is_multiple_of(FLUSH_EVERY) {
            self.flush()?;
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
    pub dx: Real,
}

impl<K: Kernel> FluidView<'_, K> {
    /// Free-surface elevation z at (x, y): half a spacing above the highest particle within one
    /// spacing of the vertical line; NaN where the bed is dry.
    pub fn surface_elevation(&self, x: Real, y: Real) -> Real {
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
            Real::NAN
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
