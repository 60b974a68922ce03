//! Blocks on a terrain read from a file (`[[terrain]]`): the incline cases with the slope given
//! as a triangle mesh (a DEM plane turned by α) instead of a slab block, against the same
//! Mohr–Coulomb reference and tolerances; and a block set down on a small terrain bump, which
//! must tip onto it and stay.

use super::harness::Harness;
use super::incline::{INCLINE_DAMPING, Incline};
use super::scenes::{G, block_toml, box_corners, rotate_y, scene};
use shared::math::Real;
use shared::report::{Row, Tolerance};
use shared::scene::Scene;
use shared::solver::SolverError;
use shared::terrain::dem::Grid;
use std::path::PathBuf;

/// A scratch folder for the terrain files of a case (removed on drop).
struct Files(tempfile::TempDir);

impl Files {
    fn new(tag: &str) -> Files {
        let d = tempfile::Builder::new()
            .prefix(&format!("rockwave-solid-terrain-{tag}-"))
            .tempdir()
            .expect("temporary folder");
        Files(d)
    }

    fn join(&self, name: &str) -> PathBuf {
        self.0.path().join(name)
    }
}

/// The `[[terrain]]` table of `file` with extra lines.
fn terrain_toml(file: &std::path::Path, extra: &str) -> String {
    format!(
        "[[terrain]]\nname = \"ground\"\nfile = {:?}\n{extra}\n",
        file.display().to_string()
    )
}

/// A free 2500 kg/m³ block `rock` with corners `block` on the terrain of `file` in a ±2 m
/// domain (friction 35°, 20 % contact damping, and the `[solid.contact]` lines `contact`),
/// ready to run; with its starting centroid.
fn rock_on_terrain(
    name: &str,
    file: &std::path::Path,
    block: &[[Real; 3]],
    contact: &str,
    solver: &str,
) -> Result<(Harness, shared::math::Point), SolverError> {
    let scene = scene(
        name,
        [0.0, 0.0, -G],
        2.0,
        "",
        &format!("friction_angle = 35\ndamping_ratio = 0.2\n{contact}"),
        &[
            terrain_toml(file, ""),
            block_toml("rock", "free", 2500.0, block, ""),
        ],
    );
    let h = Harness::new(&scene, solver)?;
    let start = h.block("rock").position;
    Ok((h, start))
}

/// The incline scene with the slope a terrain: a flat DEM (spacing `cell`, reaching past the
/// ±10 m domain so its rim is at the domain's sides) turned by α about y, as the slab is.
pub fn incline_on_terrain_scene(inc: &Incline, cell: Real, dir: &std::path::Path) -> Scene {
    let n = (24.0 / cell).round() as usize + 1;
    let file = dir.join("plane.asc");
    std::fs::write(
        &file,
        Grid::from_fn(n, n, -12.0, -12.0, cell, |_, _| 0.0).to_asc(),
    )
    .expect("write the DEM");
    let block = rotate_y(
        &box_corners([0.0, -0.2, 0.0], [inc.b, 0.2, inc.h]),
        inc.alpha.to_radians(),
    );
    scene(
        "incline_terrain",
        [0.0, 0.0, -G],
        10.0,
        "",
        &format!(
            "friction_angle = {}\ncohesion = {}\ndamping_ratio = {INCLINE_DAMPING}",
            inc.phi, inc.cohesion
        ),
        &[
            terrain_toml(&file, &format!("rotation = [0.0, {}, 0.0]", inc.alpha)),
            block_toml("rock", "free", 2500.0, &block, ""),
        ],
    )
}

/// The sliding and sticking incline cases on a terrain mesh of 0.5 m triangles (2 × 48² of
/// them): d(1 s) against ½[g(sin α − cos α tan φ) − cA/m]t², the tolerances of
/// [`incline_rows`](super::incline_rows).
pub fn incline_on_terrain_rows(solver: &str) -> Vec<Row> {
    let cases = [
        (
            "incline on a terrain mesh α=20° φ=30°: sticks",
            Incline {
                alpha: 20.0,
                phi: 30.0,
                cohesion: 0.0,
                b: 0.4,
                h: 0.2,
            },
        ),
        (
            "incline on a terrain mesh α=30° φ=20°: slides",
            Incline::SLIDING,
        ),
    ];
    cases
        .iter()
        .map(|(case, inc)| {
            let files = Files::new("incline");
            let scene = incline_on_terrain_scene(inc, 0.5, files.0.path());
            let run = || -> Result<Real, SolverError> {
                let mut h = Harness::new(&scene, solver)?;
                let start = h.block("rock").position;
                h.run_until(1.0, None, |_| {})?;
                Ok((h.block("rock").position - start).dot(&inc.downhill()))
            };
            match run() {
                Err(e) => Row::failed(case, solver, "d(1 s) [m]", &e),
                Ok(d) => {
                    let reference = inc.reference_distance(1.0);
                    let tol = if reference > 0.0 {
                        Tolerance::Relative(0.005)
                    } else {
                        Tolerance::Absolute(1e-3)
                    };
                    Row::numeric(case, solver, "d(1 s) [m]", reference, d, tol)
                }
            }
        })
        .collect()
}

/// Height of the bump [m] and its offset from the block's centre along x [m].
const BUMP: Real = 0.01;
const BUMP_OFFSET: Real = 0.05;

/// A 0.4 × 0.4 × 0.2 m block set down flat on a DEM whose only relief is one raised vertex
/// (a bump of [`BUMP`] m, [`BUMP_OFFSET`] m off the block's centre along +x). Its weight is
/// on the −x side of the bump, so it tips onto its −x edge and rests there on the bump, tilted
/// by atan(BUMP / (0.2 + BUMP_OFFSET)); it must come to rest there, not slide off or sink
/// through the bump. Returns the tilt [rad], the horizontal drift [m] and the final speed.
pub fn block_on_bump(solver: &str, duration: Real) -> Result<(Real, Real, Real), SolverError> {
    let files = Files::new("bump");
    let file = files.join("bump.asc");
    let cell: Real = 0.05;
    let n = (4.0 / cell).round() as usize + 1;
    let grid = Grid::from_fn(n, n, -2.0, -2.0, cell, |x, y| {
        if (x - BUMP_OFFSET).abs() < 1e-9 && y.abs() < 1e-9 {
            BUMP
        } else {
            0.0
        }
    });
    assert!(grid.z.contains(&Some(BUMP)), "the bump is on the grid");
    std::fs::write(&file, grid.to_asc()).expect("write the DEM");
    let block = box_corners([-0.2, -0.2, BUMP], [0.2, 0.2, BUMP + 0.2]);
    let (mut h, start) = rock_on_terrain("terrain_bump", &file, &block, "", solver)?;
    h.run_until(duration, None, |_| {})?;
    let b = h.block("rock");
    let drift = (b.position - start).xy().norm();
    Ok((b.rotation.angle(), drift, b.velocity.norm()))
}

/// The bump case as rows: the tilt against θ = atan(BUMP / (0.2 + BUMP_OFFSET)) (5 %); the
/// horizontal drift of the centroid against that of the block turned by θ about its −x bottom
/// edge, 0.2(1 − cos θ) + 0.1 sin θ (2 mm: it tips in place, it does not slide off); the block
/// at rest (under 1 mm/s) after 1.5 s.
pub fn bump_rows(solver: &str) -> Vec<Row> {
    let case = "block tipped onto a terrain bump stays";
    let theta = (BUMP / (0.2 + BUMP_OFFSET)).atan();
    match block_on_bump(solver, 1.5) {
        Err(e) => vec![Row::failed(case, solver, "tilt [rad]", &e)],
        Ok((tilt, drift, speed)) => vec![
            Row::numeric(
                case,
                solver,
                "tilt [rad]",
                theta,
                tilt,
                Tolerance::Relative(0.05),
            ),
            Row::numeric(
                case,
                solver,
                "horizontal drift [m]",
                0.2 * (1.0 - theta.cos()) + 0.1 * theta.sin(),
                drift,
                Tolerance::Absolute(2e-3),
            ),
            Row::numeric(
                case,
                solver,
                "speed at 1.5 s [m/s]",
                0.0,
                speed,
                Tolerance::Absolute(1e-3),
            ),
        ],
    }
}

/// Height [m] and half-width [m] of the mesa in [`block_on_mesa`].
const MESA: (Real, Real) = (0.4, 0.2);

/// The mesa's DEM (0.4 m cells, the top one cell, 45° flanks) written into `files`. It reaches
/// past the ±2 m domain, so the terrain's rim is at the domain's sides.
fn mesa_dem(files: &Files) -> PathBuf {
    let file = files.join("mesa.asc");
    let (height, half) = MESA;
    let grid = Grid::from_fn(12, 12, -11.0 * half, -11.0 * half, 2.0 * half, |x, y| {
        if x.abs() <= half + 1e-9 && y.abs() <= half + 1e-9 {
            height
        } else {
            0.0
        }
    });
    std::fs::write(&file, grid.to_asc()).expect("write the DEM");
    file
}

/// A cube as wide as a mesa's flat top, turned 45° about z and set down on it at zero gap. The
/// DEM (0.4 m cells) has the top as one cell, its rim four *ridges* with no vertex between the
/// corners; the cube's bottom corners hang over the 45° flanks and the mesa's corners stand
/// outside the cube's bottom face, so neither has a vertex in the other: the cube rests only
/// where its bottom edges cross the rim, eight edge–edge contacts, as the twisted stack of two
/// cubes does. Without them it would sink into the mesa. With `stiffness` [N/m] the contacts
/// are that soft, and the cube's weight presses the crossings past the contact margin. Returns
/// the drop of the centroid, the tilt [rad], the horizontal drift [m] after `duration`, and how
/// many edge–edge contacts hold it.
pub fn block_on_mesa(
    solver: &str,
    duration: Real,
    stiffness: Option<Real>,
) -> Result<(Real, Real, Real, usize), SolverError> {
    let files = Files::new("mesa");
    let file = mesa_dem(&files);
    let (height, half) = MESA;
    let cell = 2.0 * half;
    let (s, c) = std::f64::consts::FRAC_PI_4.sin_cos();
    let block: Vec<[Real; 3]> = box_corners([-half, -half, height], [half, half, height + cell])
        .iter()
        .map(|p| [c * p[0] - s * p[1], s * p[0] + c * p[1], p[2]])
        .collect();
    let contact = stiffness.map_or(String::new(), |k| format!("normal_stiffness = {k:e}"));
    let (mut h, start) = rock_on_terrain("terrain_mesa", &file, &block, &contact, solver)?;
    h.run_until(duration, None, |_| {})?;
    let b = h.block("rock");
    let edges = h
        .world()
        .contacts
        .iter()
        .filter(|c| c.key.feature == crate::contact::Feature::EdgeEdge && c.gap < 0.0)
        .count();
    Ok((
        start.z - b.position.z,
        b.rotation.angle(),
        (b.position - start).xy().norm(),
        edges,
    ))
}

/// Normal stiffness of the soft mesa case [N/m]: the cube's weight presses each of its eight
/// crossings W/(8k) = 4.9 contact margins (0.4 mm) deep.
pub const MESA_SOFT_STIFFNESS: Real = 1e5;

/// The mesa case as rows: the cube stays on the rim, level and in place, held by its eight edge
/// crossings. With the scene's stiff contacts it drops less than 1 mm (the springs'
/// deflection); with soft ones ([`MESA_SOFT_STIFFNESS`]) it sinks what the eight springs in
/// parallel give under its weight, W/(8k), within 3 %. Without the ridges' wedge depth
/// (contact/terrain.rs) the soft cube sinks onto its corners.
pub fn mesa_rows(solver: &str) -> Vec<Row> {
    let weight = 2500.0 * (2.0 * MESA.1).powi(3) * G;
    let mut rows = mesa_case_rows(
        solver,
        "cube turned 45° on a mesa's rim (edge crossings only)",
        None,
        0.0,
        Tolerance::Absolute(1e-3),
    );
    rows.extend(mesa_case_rows(
        solver,
        "cube turned 45° on a mesa's rim, soft contacts pressed in",
        Some(MESA_SOFT_STIFFNESS),
        weight / (8.0 * MESA_SOFT_STIFFNESS),
        Tolerance::Relative(0.03),
    ));
    rows
}

fn mesa_case_rows(
    solver: &str,
    case: &str,
    stiffness: Option<Real>,
    sink: Real,
    tolerance: Tolerance,
) -> Vec<Row> {
    match block_on_mesa(solver, 1.0, stiffness) {
        Err(e) => vec![Row::failed(case, solver, "drop [m]", &e)],
        Ok((drop, tilt, drift, edges)) => {
            let mut rows = resting_rows(case, solver, (sink, drop, tolerance), tilt, drift, 1e-3);
            rows.push(Row::categorical(
                case,
                solver,
                "closed edge–edge contacts",
                "8",
                &edges.to_string(),
            ));
            rows
        }
    }
}

/// A block at rest where it was set down: its drop against `sink` (measured, tolerance), its
/// tilt and horizontal drift against 0 within `tol` (rad, m).
fn resting_rows(
    case: &str,
    solver: &str,
    (sink, drop, tolerance): (Real, Real, Tolerance),
    tilt: Real,
    drift: Real,
    tol: Real,
) -> Vec<Row> {
    vec![
        Row::numeric(case, solver, "drop [m]", sink, drop, tolerance),
        Row::numeric(
            case,
            solver,
            "tilt [rad]",
            0.0,
            tilt,
            Tolerance::Absolute(tol),
        ),
        Row::numeric(
            case,
            solver,
            "horizontal drift [m]",
            0.0,
            drift,
            Tolerance::Absolute(tol),
        ),
    ]
}

/// How far inside the mesa's rim the slab of [`slab_at_mesa_rim`] has its two corners [m].
pub const RIM_INSET: Real = 5e-4;

/// A 0.3 m tall slab set down on the mesa's top with two bottom corners [`RIM_INSET`] inside
/// the rim (x = 0.1995 m) and two 0.3 m further in, on soft contacts
/// ([`MESA_SOFT_STIFFNESS`]), so that its weight presses each corner W/(4k) = 1.65 mm in.
/// Pressed past RIM_INSET/(√2 − 1) = 1.2 mm, the rim corners' nearest surface point is on the
/// 45° flank; a contact that followed it pushed them outward along the flank's normal. They
/// keep the top's triangle they entered by (DDA's reference face, contact/terrain.rs), so the
/// slab sinks level and stays in place. Returns the drop of the centroid, the tilt [rad] and
/// the horizontal drift [m] after `duration`.
pub fn slab_at_mesa_rim(solver: &str, duration: Real) -> Result<(Real, Real, Real), SolverError> {
    let files = Files::new("rim");
    let file = mesa_dem(&files);
    let (height, half) = MESA;
    let block = box_corners(
        [half - RIM_INSET - 0.3, -0.15, height],
        [half - RIM_INSET, 0.15, height + 0.3],
    );
    let contact = format!("normal_stiffness = {MESA_SOFT_STIFFNESS:e}");
    let (mut h, start) = rock_on_terrain("terrain_rim", &file, &block, &contact, solver)?;
    h.run_until(duration, None, |_| {})?;
    let b = h.block("rock");
    Ok((
        start.z - b.position.z,
        b.rotation.angle(),
        (b.position - start).xy().norm(),
    ))
}

/// The rim case as rows: the slab sinks W/(4k) (3 %), level and in place (10⁻⁵ rad and m; a
/// contact that took the nearest surface point tilts and shifts it far beyond that).
pub fn rim_rows(solver: &str) -> Vec<Row> {
    let case = "slab with two corners 0.5 mm inside a mesa's rim, soft contacts pressed in";
    let weight = 2500.0 * 0.3 * 0.3 * 0.3 * G;
    match slab_at_mesa_rim(solver, 1.0) {
        Err(e) => vec![Row::failed(case, solver, "drop [m]", &e)],
        Ok((drop, tilt, drift)) => {
            let sink = weight / (4.0 * MESA_SOFT_STIFFNESS);
            resting_rows(
                case,
                solver,
                (sink, drop, Tolerance::Relative(0.03)),
                tilt,
                drift,
                1e-5,
            )
        }
    }
}
