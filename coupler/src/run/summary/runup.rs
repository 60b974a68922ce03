//! Maximum run-up: the highest elevation above the still-water level that the water reaches
//! on a shore (a slope, beach or wall: a fixed-block face or a `[[terrain]]` triangle that is
//! not horizontal).
//!
//! Read from the particle frames of the run directory after the run, so it is resolved in
//! time only to the output interval (a peak between two frames is missed; a finer
//! `[output] interval` resolves it better).

use crate::run::povray::read_vtp;
use shared::geometry::Polyhedron;
use shared::scene::{BlockKind, Scene};
use std::collections::HashMap;
use std::path::Path;

/// Where and when the water climbed highest.
#[derive(Debug, Clone, serde::Serialize)]
pub struct RunUp {
    /// Height above the still-water level [m].
    pub height: f64,
    pub time: f64,
    /// Position of the highest water particle on the shore [m].
    pub position: [f64; 3],
    /// The still-water level it is measured from [m].
    pub still_water_level: f64,
}

/// Faces count as shore when their outward normal is less vertical than this (|n_z| < 0.98:
/// steeper than about 11°); floors and ceilings are not shores.
const HORIZONTAL: f64 = 0.98;
/// A particle touches a shore within this many particle spacings of the face.
const CONTACT: f64 = 1.5;
/// Particles with fewer neighbours within 1.5 dx are spray, not the water's edge.
const MIN_NEIGHBOURS: usize = 3;

/// The run-ups of a run: over every shore, and over each `[[runup]]` box.
#[derive(Debug, Clone, Default)]
pub struct RunUps {
    /// The highest water on any shore (height 0 and no position if none rose above the
    /// still-water level); None without frames.
    pub max: Option<RunUp>,
    /// Per `[[runup]]`, in the scene's order: its name and the highest water on a shore inside
    /// its box (None if none rose above the still-water level there, or without frames).
    pub regions: Vec<(String, Option<RunUp>)>,
}

/// The maximum run-up over the frames listed in `particles.pvd`, or None without frames.
pub fn max_runup(run_dir: &Path, scene: &Scene) -> Option<RunUp> {
    runups(run_dir, scene).max
}

/// The run-ups over every shore and over each `[[runup]]` box, in one pass over the frames.
pub fn runups(run_dir: &Path, scene: &Scene) -> RunUps {
    let (max, regions) = match scan(run_dir, scene) {
        Some((max, regions)) => (Some(max), regions),
        None => (None, vec![None; scene.runups.len()]),
    };
    let names = scene.runups.iter().map(|r| r.name.clone());
    RunUps {
        max,
        regions: names.zip(regions).collect(),
    }
}

fn scan(run_dir: &Path, scene: &Scene) -> Option<(RunUp, Vec<Option<RunUp>>)> {
    let dx = scene.fluid.as_ref()?.dx;
    let inside = |r: &shared::scene::RunupSpec, p: &[f64; 3]| {
        (0..2).all(|k| p[k] >= r.min[k] && p[k] <= r.max[k])
    };
    let shores: Vec<Polyhedron> = scene
        .blocks
        .iter()
        .filter(|b| b.kind == BlockKind::Fixed)
        .filter_map(|b| Polyhedron::from_shape(&b.shape).ok())
        .filter(|p| p.faces.iter().any(|f| f.normal.z.abs() < HORIZONTAL))
        .collect();
    // A terrain the run could read is read again here (the nodes had it; a file gone since is
    // no shore, and the run-up is then that of the blocks alone).
    let terrain = shared::terrain::Terrain::load_all(scene).unwrap_or_default();
    let on_terrain_shore = |p: &[f64; 3]| {
        terrain.iter().any(|t| {
            t.nearest(&shared::math::Point::from(*p), CONTACT * dx)
                .is_some_and(|s| {
                    let n = t.mesh.triangle(s.triangle).normal();
                    s.distance > -dx && n.is_some_and(|n| n.z.abs() < HORIZONTAL)
                })
        })
    };
    let frames = crate::run::povray::pvd_frames(&run_dir.join("particles.pvd"));
    let first = read_vtp(&run_dir.join(&frames.first()?.1)).ok()?;
    let level = first
        .points
        .iter()
        .map(|p| p[2])
        .fold(f64::NEG_INFINITY, f64::max)
        + 0.5 * dx;
    let mut best: Option<RunUp> = None;
    let mut regions: Vec<Option<RunUp>> = vec![None; scene.runups.len()];
    let higher = |b: &Option<RunUp>, h: f64| b.as_ref().is_none_or(|b| h > b.height);
    for (time, file) in &frames {
        let Ok(frame) = read_vtp(&run_dir.join(file)) else {
            continue;
        };
        // Only particles near or above the still-water level can set a run-up.
        let high: Vec<[f64; 3]> = frame
            .points
            .iter()
            .copied()
            .filter(|p| p[2] > level - 2.0 * dx)
            .collect();
        let cell = |p: &[f64; 3]| [0, 1, 2].map(|k| (p[k] / (CONTACT * dx)).floor() as i64);
        let mut grid: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
        for (i, p) in high.iter().enumerate() {
            grid.entry(cell(p)).or_default().push(i);
        }
        for p in high.iter().filter(|p| p[2] > level) {
            let h = p[2] - level;
            let raises_region = scene
                .runups
                .iter()
                .zip(&regions)
                .any(|(r, b)| inside(r, p) && higher(b, h));
            if !higher(&best, h) && !raises_region {
                continue;
            }
            let on_shore = shores.iter().any(|s| {
                let local = shared::math::Point::from(*p) - s.centroid.coords;
                let (d, face) = s.plane_distance(&local);
                d <= CONTACT * dx && d > -dx && s.faces[face].normal.z.abs() < HORIZONTAL
            });
            if !on_shore && !on_terrain_shore(p) {
                continue;
            }
            let c = cell(p);
            let mut neighbours = 0;
            for dxi in -1..=1 {
                for dyi in -1..=1 {
                    for dzi in -1..=1 {
                        if let Some(ids) = grid.get(&[c[0] + dxi, c[1] + dyi, c[2] + dzi]) {
                            neighbours += ids
                                .iter()
                                .filter(|&&j| {
                                    let q = high[j];
                                    let r2 = (0..3).map(|k| (q[k] - p[k]).powi(2)).sum::<f64>();
                                    r2 > 0.0 && r2 <= (CONTACT * dx).powi(2)
                                })
                                .count();
                        }
                    }
                }
            }
            if neighbours >= MIN_NEIGHBOURS {
                let r = RunUp {
                    height: h,
                    time: *time,
                    position: *p,
                    still_water_level: level,
                };
                for (spec, b) in scene.runups.iter().zip(regions.iter_mut()) {
                    if inside(spec, p) && higher(b, h) {
                        *b = Some(r.clone());
                    }
                }
                if higher(&best, h) {
                    best = Some(r);
                }
            }
        }
    }
    let max = best.unwrap_or(RunUp {
        height: 0.0,
        time: 0.0,
        position: [f64::NAN; 3],
        still_water_level: level,
    });
    Some((max, regions))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Still water on a lattice, then a tongue of water up the slope: the run-up is the top of
    /// the tongue above the still-water level, and a lone spray particle higher up is ignored.
    #[test]
    fn runup_is_the_highest_connected_water_on_the_shore() {
        let mut scene = Scene::default_scene();
        let dx = 0.05;
        scene.set_dx(dx);
        let dir = std::env::temp_dir().join(format!("rockwave-runup-{}", std::process::id()));
        tongue_up_the_slope(&dir, &scene, dx);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// The same tongue with the slope a `[[terrain]]` DEM instead of the fixed slope block: the
    /// terrain's inclined triangles are shore as the block's faces are.
    #[test]
    fn runup_on_a_terrain_shore() {
        let mut scene = Scene::default_scene();
        let dx = 0.05;
        scene.set_dx(dx);
        let dir = std::env::temp_dir().join(format!("rockwave-runup-dem-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        // z = (1.5 − x)·tan 25° up to x = 1.5, flat beyond (not shore), past the domain.
        let tan = 25f64.to_radians().tan();
        let grid = shared::terrain::dem::Grid::from_fn(221, 61, -1.0, -1.0, dx, |x, _| {
            ((1.5 - x) * tan).max(0.0)
        });
        std::fs::write(dir.join("slope.asc"), grid.to_asc()).unwrap();
        scene.blocks.retain(|b| b.kind != BlockKind::Fixed);
        scene.terrain.push(
            toml::from_str(&format!(
                "name = \"slope\"\nfile = {:?}",
                dir.join("slope.asc")
            ))
            .unwrap(),
        );
        assert_eq!(
            shared::terrain::Terrain::load_all(&scene).unwrap().len(),
            1,
            "the terrain loads"
        );
        // Two `[[runup]]` boxes: the slope's (its run-up is the tongue's) and the flat far
        // side's (no shore: none).
        scene.runups = vec![
            toml::from_str("name = \"slope\"\nmin = [0.0, 0.0]\nmax = [1.5, 1.0]").unwrap(),
            toml::from_str("name = \"far\"\nmin = [3.0, 0.0]\nmax = [5.0, 1.0]").unwrap(),
        ];
        let top = tongue_up_the_slope(&dir, &scene, dx);
        let r = runups(&dir, &scene);
        let slope = r.regions[0].1.as_ref().expect("the slope's run-up");
        assert_eq!(r.regions[0].0, "slope");
        assert!((slope.height - r.max.as_ref().unwrap().height).abs() < 1e-12);
        assert!((slope.position[2] - top).abs() < 1e-9);
        assert!(r.regions[1].1.is_none(), "{:?}", r.regions[1]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Writes the still frame and the tongue frame into `dir`, checks the run-up over every
    /// shore, and returns the tongue's top.
    fn tongue_up_the_slope(dir: &Path, scene: &Scene, dx: f64) -> f64 {
        std::fs::create_dir_all(dir).unwrap();
        // Still water up to z = 0.5 between the slope toe region and the far wall.
        let mut still = Vec::new();
        for i in 0..60 {
            for k in 0..10 {
                still.push([1.6 + i as f64 * dx, 0.4, 0.5 * dx + k as f64 * dx]);
            }
        }
        // The slope: z = (1.5 − x)·tan 25°. Water climbs it in a tongue three particles thick,
        // half a spacing off the surface, up to z = 0.65.
        let tan = 25f64.to_radians().tan();
        let mut wave = still.clone();
        let mut z = 0.5;
        while z <= 0.65 + 1e-9 {
            let x_surface = 1.5 - z / tan;
            for j in 0..3 {
                wave.push([x_surface + 0.6 * dx + j as f64 * 0.9 * dx, 0.4, z]);
            }
            z += 0.8 * dx;
        }
        let top = wave.iter().map(|p| p[2]).fold(0.0, f64::max);
        // Spray: one drop touching the slope far above the tongue, with no water around it.
        wave.push([1.5 - 0.9 / tan + 0.6 * dx, 0.4, 0.9]);
        // One frame in each encoding: the run-up reads both.
        let (bin, ascii) = (
            shared::scene::VtkFormat::Binary,
            shared::scene::VtkFormat::Ascii,
        );
        shared::vtk::write_particles(&dir.join("p0.vtp"), &still, &[], &[], bin).unwrap();
        shared::vtk::write_particles(&dir.join("p1.vtp"), &wave, &[], &[], ascii).unwrap();
        shared::vtk::write_pvd(
            &dir.join("particles.pvd"),
            &[(0.0, "p0.vtp".into()), (0.5, "p1.vtp".into())],
        )
        .unwrap();
        let r = max_runup(dir, scene).unwrap();
        let level = 0.5 * dx + 9.0 * dx + 0.5 * dx;
        assert!((r.still_water_level - level).abs() < 1e-12);
        assert!((r.height - (top - level)).abs() < 1e-9, "{r:?}, top {top}");
        assert_eq!(r.time, 0.5);
        top
    }
}
