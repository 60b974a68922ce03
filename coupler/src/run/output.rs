//! The run directory: what a user opens after a run.
//!
//! - `scene.toml`: the scene as run (after command-line overrides);
//! - `particles_NNNNN.vtp`, `blocks_NNNNN.vtp` (written by the nodes) and `particles.pvd`,
//!   `blocks.pvd` (written here) so ParaView opens a whole run at once;
//! - `terrain.vtp` (written here, once): the `[[terrain]]` surfaces as placed;
//! - `gauges.csv`, `probes.csv`, `fluid.json` (particle counts) (fluid node), `blocks.csv` (solid
//!   node);
//! - `summary.json`: how the run went, written at the end ([`crate::run::summary`]).

use shared::geometry::Polyhedron;
use shared::protocol::Role;
use shared::scene::{BlockKind, Scene};
use shared::vtk::PolyhedronRef;
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
