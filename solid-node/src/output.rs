//! What the solid node writes into the run directory: block kinematics as CSV (every step, at
//! most every `output.interval / 20` of simulated time, each sample flushed to the file) and
//! the block geometry per frame.

use crate::world::World;
use shared::math::Real;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// The strain and stress columns `blocks.csv` gets when the scene has a deformable block:
/// strain e = (εx, εy, εz, γyz, γzx, γxy) (engineering shears) and stress σ = D e [Pa], both in
/// the block frame (Shi's order); 0 on the rows of rigid blocks.
pub const STRAIN_COLUMNS: &str = "exx,eyy,ezz,gyz,gzx,gxy,sxx,syy,szz,syz,szx,sxy";

/// `blocks.csv`: time, block, centroid, velocity, orientation quaternion [i, j, k, w] and
/// angular velocity of every kinematic and free block; with [`STRAIN_COLUMNS`] appended when
/// the scene has a deformable block (a scene of rigid blocks keeps exactly the columns it had).
pub struct KinematicsCsv {
    out: BufWriter<File>,
    min_interval: Real,
    last: Option<Real>,
    rows: usize,
    strains: bool,
}

impl KinematicsCsv {
    pub fn create(
        run_dir: &Path,
        output_interval: Real,
        strains: bool,
    ) -> std::io::Result<KinematicsCsv> {
        let mut out = BufWriter::new(File::create(run_dir.join("blocks.csv"))?);
        write!(out, "time,block,x,y,z,vx,vy,vz,qi,qj,qk,qw,wx,wy,wz")?;
        if strains {
            write!(out, ",{STRAIN_COLUMNS}")?;
        }
        writeln!(out)?;
        Ok(KinematicsCsv {
            out,
            min_interval: output_interval / 20.0,
            last: None,
            rows: 0,
            strains,
        })
    }

    /// Writes the moving blocks' state if at least `output.interval / 20` passed since the last
    /// sample (or `force`).
    pub fn sample(&mut self, world: &World, force: bool) -> std::io::Result<()> {
        let t = world.time;
        if !force
            && self
                .last
                .is_some_and(|l| t - l < self.min_interval * (1.0 - 1e-9))
        {
            return Ok(());
        }
        if self.last == Some(t) {
            return Ok(());
        }
        self.last = Some(t);
        for &i in &world.moving {
            let b = &world.blocks[i];
            let (p, v, q, w) = (
                b.position,
                b.velocity,
                b.rotation.coords,
                b.angular_velocity,
            );
            write!(
                self.out,
                "{t:.9},{},{:.9},{:.9},{:.9},{:.9},{:.9},{:.9},{:.12},{:.12},{:.12},{:.12},{:.9},{:.9},{:.9}",
                b.name, p.x, p.y, p.z, v.x, v.y, v.z, q.x, q.y, q.z, q.w, w.x, w.y, w.z
            )?;
            if self.strains {
                match &b.elastic {
                    Some(el) => {
                        for x in el.strain.iter() {
                            write!(self.out, ",{x:.6e}")?;
                        }
                        for x in el.stress().iter() {
                            write!(self.out, ",{x:.6e}")?;
                        }
                    }
                    None => write!(self.out, "{}", ",0".repeat(12))?,
                }
            }
            writeln!(self.out)?;
            self.rows += 1;
        }
        // Every sample reaches the file at once (at most 20 per output interval): a killed
        // run loses nothing it had recorded.
        self.out.flush()
    }

    /// The sampling state a checkpoint keeps: the last sample's time and the row count.
    pub fn mark(&self) -> (Option<Real>, usize) {
        (self.last, self.rows)
    }

    /// Continues `blocks.csv` in `run_dir` (no header) from a checkpoint's `mark`: a resumed
    /// run appends where the checkpoint left it (the coupler cut the file back to that length).
    pub fn resume(&mut self, run_dir: &Path, mark: (Option<Real>, usize)) -> std::io::Result<()> {
        (self.last, self.rows) = mark;
        let file = std::fs::OpenOptions::new()
            .append(true)
            .open(run_dir.join("blocks.csv"))?;
        self.out = BufWriter::new(file);
        Ok(())
    }

    pub fn flush(&mut self) -> std::io::Result<()> {
        self.out.flush()
    }
}

/// One block for the VTK writer: world corners and faces (vertex lists).
type PolyRef<'a> = (&'a [[f64; 3]], &'a [Vec<u32>]);

/// Path of frame `frame`'s block file.
pub fn frame_path(run_dir: &Path, frame: u32) -> PathBuf {
    run_dir.join(format!("blocks_{frame:05}.vtp"))
}

/// Writes all blocks (fixed ones too) at their current pose (deformed, for deformable blocks)
/// as polygons, with per-block kind (0 fixed, 1 kinematic, 2 free), speed and contact-force
/// magnitude as cell data; when the scene has a deformable block, also its volumetric strain
/// εx + εy + εz, von Mises stress [Pa] and the six block-frame strains and stresses (0 for
/// rigid blocks). `format` is the scene's `output.vtk_format`.
pub fn write_blocks_vtp(
    world: &World,
    path: &Path,
    format: shared::scene::VtkFormat,
) -> std::io::Result<()> {
    // The scene's blocks; a terrain's block is only its bounding box (its surface is the
    // scene's file, not a block frame's).
    let scene_blocks = &world.blocks[..world.first_terrain];
    let verts: Vec<Vec<[f64; 3]>> = scene_blocks
        .iter()
        .map(|b| b.world_vertices.iter().map(|p| [p.x, p.y, p.z]).collect())
        .collect();
    let faces: Vec<Vec<Vec<u32>>> = scene_blocks
        .iter()
        .map(|b| b.shape.faces.iter().map(|f| f.vertices.clone()).collect())
        .collect();
    let blocks: Vec<PolyRef> = verts
        .iter()
        .zip(&faces)
        .map(|(v, f)| (v.as_slice(), f.as_slice()))
        .collect();
    let kind: Vec<f64> = scene_blocks
        .iter()
        .map(|b| match b.kind {
            shared::scene::BlockKind::Fixed => 0.0,
            shared::scene::BlockKind::Kinematic => 1.0,
            shared::scene::BlockKind::Free => 2.0,
        })
        .collect();
    let speed: Vec<f64> = scene_blocks.iter().map(|b| b.velocity.norm()).collect();
    let contact: Vec<f64> = world.contact_force[..world.first_terrain]
        .iter()
        .map(|f| f.norm())
        .collect();
    let mut arrays: Vec<(&str, &[f64])> = vec![
        ("kind", &kind),
        ("speed", &speed),
        ("contact_force", &contact),
    ];
    let per_block = |f: &dyn Fn(&crate::blocks::elastic::Elastic) -> f64| -> Vec<f64> {
        scene_blocks
            .iter()
            .map(|b| b.elastic.as_ref().map_or(0.0, |e| f(e)))
            .collect()
    };
    let (volumetric, mises);
    let components: Vec<Vec<f64>>;
    const NAMES: [&str; 12] = [
        "strain_xx",
        "strain_yy",
        "strain_zz",
        "strain_yz",
        "strain_zx",
        "strain_xy",
        "stress_xx",
        "stress_yy",
        "stress_zz",
        "stress_yz",
        "stress_zx",
        "stress_xy",
    ];
    if !world.deformable.is_empty() {
        volumetric = per_block(&|e| e.strain[0] + e.strain[1] + e.strain[2]);
        mises = per_block(&|e| e.von_mises());
        components = (0..12)
            .map(|k| {
                per_block(&|e| {
                    if k < 6 {
                        e.strain[k]
                    } else {
                        e.stress()[k - 6]
                    }
                })
            })
            .collect();
        arrays.push(("volumetric_strain", &volumetric));
        arrays.push(("von_mises_stress", &mises));
        for (name, c) in NAMES.iter().zip(&components) {
            arrays.push((name, c));
        }
    }
    shared::vtk::write_polyhedra(path, &blocks, &arrays, format)
}
