//! The run directory: what a user opens after a run.
//!
//! - `scene.toml`: the scene as run (after command-line overrides);
//! - `particles_NNNNN.vtp`, `blocks_NNNNN.vtp` (written by the nodes) and `particles.pvd`,
//!   `blocks.pvd` (written here) so ParaView opens a whole run at once;
//! - `terrain.vtp` (written here, once): the `[[terrain]]` surfaces as placed;
//! - `gauges.csv`, `probes.csv`, `fluid.json` (particle counts) (fluid node), `blocks.csv` (solid
//!   node);
//! - `summary.json`: how the run went, and the numbers a user looks for first (every field:
//!   docs/ARCHITECTURE.md "Run directory").

use crate::run::error::RunError;
use crate::run::gauges::{GaugeSummary, summarise_gauge};
use crate::run::stats::RunStats;
use shared::geometry::Polyhedron;
use shared::protocol::Role;
use shared::scene::{BlockKind, Scene};
use shared::vtk::PolyhedronRef;
use std::collections::BTreeMap;
use std::io;
use std::path::{Path, PathBuf};

/// A .pvd series: (time, frame file) per frame.
pub type Series = Vec<(f64, String)>;

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
        if path.exists() && !path.is_dir() {
            return Err(format!(
                "the run directory '{}' is a file, not a directory. Fix: choose another --out (a new or empty directory)",
                path.display()
            ));
        }
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
        if scene.output.vtk && !scene.terrain.is_empty() {
            // The terrain never moves: one file for ParaView, beside the frames.
            dir.write_terrain(scene)?;
        }
        if !scene.has_moving_blocks() && scene.output.vtk && !scene.blocks.is_empty() {
            // No solid node runs: the fixed blocks never move, one file serves every frame.
            dir.write_static_blocks(scene)
                .map_err(|e| format!("cannot write blocks_00000.vtp: {e}"))?;
            dir.static_blocks = true;
        }
        Ok(dir)
    }

    /// The directory of an earlier run, to continue it (`coupler run --resume`): it must hold
    /// the `scene.toml` the run was started with.
    pub fn open_existing(path: &Path, scene: &Scene) -> RunDir {
        RunDir {
            path: path.to_path_buf(),
            particles: Vec::new(),
            blocks: Vec::new(),
            static_blocks: !scene.has_moving_blocks()
                && scene.output.vtk
                && !scene.blocks.is_empty(),
        }
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Whether one blocks_00000.vtp serves every frame (no solid node runs).
    pub fn static_blocks(&self) -> bool {
        self.static_blocks
    }

    /// The .pvd series' entries (time, file), for a checkpoint.
    pub fn series(&self) -> (Series, Series) {
        (self.particles.clone(), self.blocks.clone())
    }

    /// Sets the .pvd series to a checkpoint's entries (none: a restart from t = 0) and
    /// rewrites the files.
    pub fn restore_series(
        &mut self,
        particles: Vec<(f64, String)>,
        blocks: Vec<(f64, String)>,
    ) -> io::Result<()> {
        self.particles = particles;
        self.blocks = blocks;
        for (name, list) in [
            ("particles.pvd", &self.particles),
            ("blocks.pvd", &self.blocks),
        ] {
            let path = self.path.join(name);
            if !list.is_empty() {
                shared::vtk::write_pvd(&path, list)?;
            } else if path.exists() {
                std::fs::remove_file(&path)?;
            }
        }
        Ok(())
    }

    /// `terrain.vtp`: every `[[terrain]]` surface as placed in the scene (its triangles), with
    /// the terrain's index as cell data.
    fn write_terrain(&self, scene: &Scene) -> Result<(), String> {
        let terrain = shared::terrain::Terrain::load_all(scene)?;
        let corners: Vec<Vec<[f64; 3]>> = terrain
            .iter()
            .map(|t| t.mesh.vertices().iter().map(|v| [v.x, v.y, v.z]).collect())
            .collect();
        let faces: Vec<Vec<Vec<u32>>> = terrain
            .iter()
            .map(|t| t.mesh.indices().iter().map(|f| f.to_vec()).collect())
            .collect();
        write_polyhedra(
            &self.path.join("terrain.vtp"),
            &corners,
            &faces,
            "terrain",
            scene,
        )
        .map_err(|e| format!("cannot write terrain.vtp: {e}"))
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
        write_polyhedra(
            &self.path.join("blocks_00000.vtp"),
            &corners,
            &faces,
            "block",
            scene,
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
    pub max_runup: Option<crate::run::runup::RunUp>,
    /// The same per `[[runup]]` box, by name (null where no water rose above the still-water
    /// level on a shore in the box).
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub runup: BTreeMap<String, Option<crate::run::runup::RunUp>>,
    /// For a piston wave maker (one kinematic block moving sinusoidally, paper Example 1):
    /// the first harmonic at the gauges in front of it against linear theory
    /// ([`crate::run::wave_maker`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wave_maker: Option<crate::run::wave_maker::WaveMakerSummary>,
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
        let runups = crate::run::runup::runups(&dir.path, scene);
        let series = gauge_series(&dir.path.join("gauges.csv"));
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
            wave_maker: crate::run::wave_maker::summarise(scene, &series, &gauges),
            gauges,
            fluid: std::fs::read_to_string(dir.path.join("fluid.json"))
                .ok()
                .and_then(|t| serde_json::from_str(&t).ok()),
            memory: Memory {
                fluid_peak_rss_mib: stats.fluid_peak_rss_bytes.map(mib),
                solid_peak_rss_mib: stats.solid_peak_rss_bytes.map(mib),
                coupler_peak_rss_mib: mib(stats.coupler_peak_rss_bytes),
            },
            final_block_positions: final_positions(&dir.path.join("blocks.csv")),
            max_runup: runups.max,
            runup: runups.regions.into_iter().collect(),
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

/// Writes polyhedra (corners and faces of each) to `path` as VTK, each cell tagged with its
/// index under `field`, in the scene's VTK format.
fn write_polyhedra(
    path: &std::path::Path,
    corners: &[Vec<[f64; 3]>],
    faces: &[Vec<Vec<u32>>],
    field: &str,
    scene: &Scene,
) -> io::Result<()> {
    let refs: Vec<PolyhedronRef> = corners
        .iter()
        .zip(faces)
        .map(|(v, f)| (v.as_slice(), f.as_slice()))
        .collect();
    let ids: Vec<f64> = (0..refs.len()).map(|i| i as f64).collect();
    shared::vtk::write_polyhedra(path, &refs, &[(field, &ids)], scene.output.vtk_format)
}
