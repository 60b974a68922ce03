//! `summary.json`: how the run went, and the numbers a user looks for first (every field:
//! docs/ARCHITECTURE.md "Run directory"), gathered from the run's stats and files at its end:
//! each gauge's wave (`gauges.rs`), the run-up on the shores (`runup.rs`), and for a piston wave
//! maker the first harmonic against linear theory (`wave_maker.rs`, `linear_waves.rs`).

pub mod gauges;
pub mod linear_waves;
pub mod runup;
pub mod wave_maker;

use crate::run::error::RunError;
use crate::run::stats::RunStats;
use gauges::{GaugeSummary, summarise_gauge};
use shared::scene::Scene;
use std::collections::BTreeMap;
use std::io;
use std::path::Path;

/// Particle counts of the fluid node (its `fluid.json`).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FluidCounts {
    pub particles: u64,
    pub boundary_particles_fixed: u64,
    pub boundary_particles_moving: u64,
}

/// Peak resident memory of each process [MiB]; null for a node that did not run or could not be
/// read.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Memory {
    pub fluid_peak_rss_mib: Option<f64>,
    pub solid_peak_rss_mib: Option<f64>,
    pub coupler_peak_rss_mib: f64,
}

/// What `summary.json` holds.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Summary {
    pub scene: String,
    pub run_id: String,
    pub status: String,
    pub message: Option<String>,
    pub fluid_solver: Option<String>,
    pub solid_solver: Option<String>,
    pub scheme: String,
    pub stats: RunStats,
    /// Share of the wall time the nodes spent computing; the rest is coupling and waiting.
    pub compute_share: BTreeMap<String, f64>,
    pub gauges: BTreeMap<String, GaugeSummary>,
    /// Fluid particles and boundary particles (null without a fluid node).
    pub fluid: Option<FluidCounts>,
    pub memory: Memory,
    /// Last recorded centroid of each moving block [m].
    pub final_block_positions: BTreeMap<String, [f64; 3]>,
    /// Highest water on a shore (slope, beach, wall) above the still-water level, from the
    /// particle frames (resolved to the output interval).
    pub max_runup: Option<crate::run::summary::runup::RunUp>,
    /// The same per `[[runup]]` box, by name (null where no water rose above the still-water
    /// level on a shore in the box).
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub runup: BTreeMap<String, Option<crate::run::summary::runup::RunUp>>,
    /// For a piston wave maker (one kinematic block moving sinusoidally, paper Example 1):
    /// the first harmonic at the gauges in front of it against linear theory
    /// ([`crate::run::summary::wave_maker`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wave_maker: Option<crate::run::summary::wave_maker::WaveMakerSummary>,
}

impl Summary {
    /// Builds the summary of a finished (or failed) run from its stats and files.
    pub fn gather(
        dir: &Path,
        scene: &Scene,
        id: &str,
        stats: &RunStats,
        outcome: &Result<(), RunError>,
        scheme: String,
    ) -> Summary {
        let solvers = (stats.fluid_solver.clone(), stats.solid_solver.clone());
        let status = match outcome {
            Ok(()) => "completed",
            Err(RunError::Interrupted { .. }) => "interrupted",
            Err(RunError::Unstable { .. }) | Err(RunError::Collapsed { .. }) => "unstable",
            Err(_) => "failed",
        };
        let wall = stats.wall_seconds.max(1e-9);
        let runups = crate::run::summary::runup::runups(dir, scene);
        let series = gauge_series(&dir.join("gauges.csv"));
        let gauges = gauge_summaries(&series, scene);
        let mut compute_share = BTreeMap::new();
        if solvers.0.is_some() {
            compute_share.insert("fluid".into(), stats.fluid_compute_seconds / wall);
        }
        if solvers.1.is_some() {
            compute_share.insert("solid".into(), stats.solid_compute_seconds / wall);
        }
        Summary {
            scene: scene.name.clone(),
            run_id: id.into(),
            status: status.into(),
            message: outcome.as_ref().err().map(|e| e.to_string()),
            fluid_solver: solvers.0,
            solid_solver: solvers.1,
            scheme,
            stats: stats.clone(),
            compute_share,
            wave_maker: crate::run::summary::wave_maker::summarise(scene, &series, &gauges),
            gauges,
            fluid: std::fs::read_to_string(dir.join("fluid.json"))
                .ok()
                .and_then(|t| serde_json::from_str(&t).ok()),
            memory: Memory {
                fluid_peak_rss_mib: stats.fluid_peak_rss_bytes.map(mib),
                solid_peak_rss_mib: stats.solid_peak_rss_bytes.map(mib),
                coupler_peak_rss_mib: mib(stats.coupler_peak_rss_bytes),
            },
            final_block_positions: final_positions(&dir.join("blocks.csv")),
            max_runup: runups.max,
            runup: runups.regions.into_iter().collect(),
        }
    }

    /// Writes `summary.json` into the run directory `dir`.
    pub fn write(&self, dir: &Path) -> io::Result<()> {
        let text = serde_json::to_string_pretty(self).map_err(io::Error::other)?;
        let tmp = dir.join("summary.json.partial");
        std::fs::write(&tmp, text)?;
        std::fs::rename(tmp, dir.join("summary.json"))
    }
}

/// Reads a CSV with a header row into (header, rows of numbers); non-numeric cells become NaN.
fn read_csv(path: &Path) -> Option<(Vec<String>, Vec<Vec<String>>)> {
    let text = std::fs::read_to_string(path).ok()?;
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    let header: Vec<String> = lines
        .next()?
        .split(',')
        .map(|s| s.trim().to_string())
        .collect();
    let rows = lines
        .map(|l| l.split(',').map(|s| s.trim().to_string()).collect())
        .collect();
    Some((header, rows))
}

fn mib(bytes: u64) -> f64 {
    bytes as f64 / (1024.0 * 1024.0)
}

/// Each column of `gauges.csv` as (time, value) pairs by its header name (finite values only).
fn gauge_series(path: &Path) -> BTreeMap<String, Vec<(f64, f64)>> {
    let mut out = BTreeMap::new();
    let Some((header, rows)) = read_csv(path) else {
        return out;
    };
    for (col, name) in header.iter().enumerate().skip(1) {
        let series = rows
            .iter()
            .filter_map(|r| Some((r.first()?.parse().ok()?, r.get(col)?.parse().ok()?)))
            .filter(|(t, v): &(f64, f64)| t.is_finite() && v.is_finite())
            .collect();
        out.insert(name.clone(), series);
    }
    out
}

fn gauge_summaries(
    series: &BTreeMap<String, Vec<(f64, f64)>>,
    scene: &Scene,
) -> BTreeMap<String, GaugeSummary> {
    let mut out = BTreeMap::new();
    // The terrain is part of the bed (read again: it is fixed, and the run has checked it).
    let terrain = shared::terrain::Terrain::load_all(scene).unwrap_or_default();
    for g in &scene.gauges {
        let Some(surface) = series.get(&g.name) else {
            continue;
        };
        let spray = series
            .get(&format!("{}_spray", g.name))
            .map(Vec::as_slice)
            .unwrap_or_default();
        out.insert(
            g.name.clone(),
            summarise_gauge(
                surface,
                spray,
                shared::terrain::bed_elevation(scene, &terrain, g.x, g.y),
            ),
        );
    }
    out
}

fn final_positions(path: &Path) -> BTreeMap<String, [f64; 3]> {
    let mut out = BTreeMap::new();
    let Some((header, rows)) = read_csv(path) else {
        return out;
    };
    let col = |name: &str| header.iter().position(|h| h == name);
    let (Some(b), Some(x), Some(y), Some(z)) = (col("block"), col("x"), col("y"), col("z")) else {
        return out;
    };
    for r in rows {
        let p = [x, y, z].map(|c| r.get(c).and_then(|v| v.parse().ok()).unwrap_or(f64::NAN));
        if let Some(name) = r.get(b) {
            out.insert(name.clone(), p);
        }
    }
    out
}
