//! The run directory: what a user opens after a run.
//!
//! - `scene.toml`: the scene as run (after command-line overrides);
//! - `particles_NNNNN.vtp`, `blocks_NNNNN.vtp` (written by the nodes) and `particles.pvd`,
//!   `blocks.pvd` (written here) so ParaView opens a whole run at once;
//! - `gauges.csv`, `probes.csv` (fluid node), `blocks.csv` (solid node);
//! - `summary.json`: how the run went, and the numbers a user looks for first.

use crate::session::{RunError, RunStats};
use shared::geometry::Polyhedron;
use shared::protocol::Role;
use shared::scene::{BlockKind, Scene};
use shared::vtk::PolyhedronRef;
use std::collections::BTreeMap;
use std::io;
use std::path::{Path, PathBuf};

/// A run directory being filled.
pub struct RunDir {
    path: PathBuf,
    particles: Vec<(f64, String)>,
    blocks: Vec<(f64, String)>,
    static_blocks: bool,
}

impl RunDir {
    /// Creates `path`; refuses an existing non-empty directory so that no earlier result is
    /// ever overwritten.
    pub fn create(path: &Path, scene: &Scene) -> Result<RunDir, String> {
        if path.exists()
            && std::fs::read_dir(path)
                .map(|mut d| d.next().is_some())
                .unwrap_or(true)
        {
            return Err(format!(
                "the run directory '{}' already exists and is not empty. Fix: choose another --out, or remove it",
                path.display()
            ));
        }
        std::fs::create_dir_all(path)
            .map_err(|e| format!("cannot create run directory '{}': {e}", path.display()))?;
        let text =
            toml::to_string(scene).map_err(|e| format!("cannot serialise the scene: {e}"))?;
        std::fs::write(path.join("scene.toml"), text)
            .map_err(|e| format!("cannot write scene.toml: {e}"))?;
        let mut dir = RunDir {
            path: path.to_path_buf(),
            particles: Vec::new(),
            blocks: Vec::new(),
            static_blocks: false,
        };
        if !scene.has_moving_blocks() && scene.output.vtk && !scene.blocks.is_empty() {
            // No solid node runs: the fixed blocks never move, one file serves every frame.
            dir.write_static_blocks(scene)
                .map_err(|e| format!("cannot write blocks_00000.vtp: {e}"))?;
            dir.static_blocks = true;
        }
        Ok(dir)
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    fn write_static_blocks(&self, scene: &Scene) -> io::Result<()> {
        let polys: Vec<Polyhedron> = scene
            .blocks
            .iter()
            .filter(|b| b.kind == BlockKind::Fixed)
            .filter_map(|b| Polyhedron::from_shape(&b.shape).ok())
            .collect();
        let corners: Vec<Vec<[f64; 3]>> = polys
            .iter()
            .map(|p| {
                p.vertices
                    .iter()
                    .map(|v| (v + p.centroid.coords).into())
                    .collect()
            })
            .collect();
        let faces: Vec<Vec<Vec<u32>>> = polys
            .iter()
            .map(|p| p.faces.iter().map(|f| f.vertices.clone()).collect())
            .collect();
        let refs: Vec<PolyhedronRef> = corners
            .iter()
            .zip(&faces)
            .map(|(v, f)| (v.as_slice(), f.as_slice()))
            .collect();
        let ids: Vec<f64> = (0..refs.len()).map(|i| i as f64).collect();
        shared::vtk::write_polyhedra(
            &self.path.join("blocks_00000.vtp"),
            &refs,
            &[("block", &ids)],
        )
    }

    /// Records frame `frame` (written by the nodes) and rewrites the .pvd series, so a run that
    /// stops early still opens in ParaView.
    pub fn add_frame(&mut self, frame: u32, time: f64, roles: &[Role]) -> io::Result<()> {
        if roles.contains(&Role::Fluid) {
            self.particles
                .push((time, format!("particles_{frame:05}.vtp")));
            shared::vtk::write_pvd(&self.path.join("particles.pvd"), &self.particles)?;
        }
        if roles.contains(&Role::Solid) {
            self.blocks.push((time, format!("blocks_{frame:05}.vtp")));
        } else if self.static_blocks {
            self.blocks.push((time, "blocks_00000.vtp".into()));
        }
        if !self.blocks.is_empty() {
            shared::vtk::write_pvd(&self.path.join("blocks.pvd"), &self.blocks)?;
        }
        Ok(())
    }

    /// Writes `summary.json`.
    pub fn write_summary(&self, summary: &Summary) -> io::Result<()> {
        let text = serde_json::to_string_pretty(summary).map_err(io::Error::other)?;
        let tmp = self.path.join("summary.json.partial");
        std::fs::write(&tmp, text)?;
        std::fs::rename(tmp, self.path.join("summary.json"))
    }
}

/// Per-gauge wave statistics from `gauges.csv`.
#[derive(Debug, Clone, serde::Serialize)]
pub struct GaugeSummary {
    /// Still-water elevation at the first sample [m].
    pub initial: f64,
    /// Largest rise above it [m].
    pub max_crest: f64,
    /// Largest drop below it [m].
    pub max_trough: f64,
    /// Time of the largest rise [s].
    pub crest_time: f64,
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
    /// Last recorded centroid of each moving block [m].
    pub final_block_positions: BTreeMap<String, [f64; 3]>,
    /// Highest water on a shore (slope, beach, wall) above the still-water level, from the
    /// particle frames (resolved to the output interval).
    pub max_runup: Option<crate::runup::RunUp>,
}

impl Summary {
    /// Builds the summary of a finished (or failed) run from its stats and files.
    pub fn gather(
        dir: &RunDir,
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
            gauges: gauge_summaries(&dir.path.join("gauges.csv")),
            final_block_positions: final_positions(&dir.path.join("blocks.csv")),
            max_runup: crate::runup::max_runup(&dir.path, scene),
        }
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

fn gauge_summaries(path: &Path) -> BTreeMap<String, GaugeSummary> {
    let mut out = BTreeMap::new();
    let Some((header, rows)) = read_csv(path) else {
        return out;
    };
    for (col, name) in header.iter().enumerate().skip(1) {
        if name.ends_with("_spray") {
            continue;
        }
        let series: Vec<(f64, f64)> = rows
            .iter()
            .filter_map(|r| Some((r.first()?.parse().ok()?, r.get(col)?.parse().ok()?)))
            .filter(|(_, v): &(f64, f64)| v.is_finite())
            .collect();
        let Some(&(_, initial)) = series.first() else {
            continue;
        };
        let (crest_time, crest) =
            series.iter().fold(
                (0.0, f64::NEG_INFINITY),
                |a, &(t, v)| if v > a.1 { (t, v) } else { a },
            );
        let trough = series.iter().map(|s| s.1).fold(f64::INFINITY, f64::min);
        out.insert(
            name.clone(),
            GaugeSummary {
                initial,
                max_crest: crest - initial,
                max_trough: initial - trough,
                crest_time,
            },
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
