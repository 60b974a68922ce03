//! `[[slide]]`: a rock mass given as a convex region and its joint sets, cut into blocks (Shi's
//! block cutting, [`crate::geometry::cutting`]) when the scene is read.
//!
//! The cut blocks are ordinary free convex blocks appended to [`Scene::blocks`], named
//! `<slide name>/<k>` and marked with [`SlideMember`], so every process that reads the scene
//! (coupler, fluid node, solid node) sees the same blocks without any of them sending geometry:
//! the cutting is a deterministic function of the scene text. The scene as written (and as sent
//! to the nodes, and as hashed for checkpoints) keeps the `[[slide]]` table and leaves the cut
//! blocks out ([`crate::scene::serialize_written_blocks`]).
//!
//! The solid node also reads the joint sets: a contact between two blocks of one slide across
//! a joint plane takes that set's cohesion, tensile strength and friction, bonded at the start
//! and with residual friction only once broken (`solid-node/src/joints.rs`).

use super::error::{FieldError, Seg, render_path};
use super::schema::{
    BlockKind, BlockSpec, DEFAULT_MAX_BLOCKS, JointSetSpec, MAX_BLOCKS_LIMIT, Scene, ShapeSpec,
    SlideCut, SlideMember, SlideSpec,
};
use crate::geometry::cutting::{self, Cell, PlaneFamily};
use crate::geometry::{Polyhedron, shape_points};
use crate::math::{Point, Real, Vector, readable};

/// Default smallest block kept, as a fraction of the region's volume.
pub const DEFAULT_MIN_BLOCK_FRACTION: Real = 1e-6;

/// Cutting tolerance, as a fraction of the region's size: corners closer to a plane than this
/// lie on it.
const TOLERANCE: Real = 1e-9;

/// Farthest a joint set's `offset` may lie from the origin [m], as `[domain]`'s corners: a
/// 10 000 km box holds any landslide, and the joint planes' positions keep their precision.
const MAX_OFFSET: Real = 1e7;

/// Thinnest slab of rock between two joints of a set, as a fraction of the particle spacing
/// `fluid.dx`: the same floor as the size of a moving `[[block]]` (a quarter of dx), below
/// which no particle would see the block.
const MIN_SPACING_OF_DX: Real = 0.25;

/// An error at `slide[slide].<field>`, where `field` may index, e.g. `joint_set[1].dip`.
fn fail(
    slide: usize,
    field: &str,
    value: impl std::fmt::Debug,
    problem: &str,
    fix: &str,
) -> FieldError {
    let mut segments = vec![Seg::Key("slide".into()), Seg::Index(slide)];
    for part in field.split('.').filter(|p| !p.is_empty()) {
        match part.split_once('[') {
            Some((key, rest)) => {
                segments.push(Seg::Key(key.into()));
                if let Ok(j) = rest.trim_end_matches(']').parse() {
                    segments.push(Seg::Index(j));
                }
            }
            None => segments.push(Seg::Key(part.into())),
        }
    }
    FieldError {
        path: render_path(&segments),
        segments,
        value: format!("{value:?}"),
        problem: problem.into(),
        fix: fix.into(),
        line: None,
    }
}

/// Checks the slide's own fields; returns every problem.
fn check_fields(i: usize, s: &SlideSpec) -> Vec<FieldError> {
    let mut errors = Vec::new();
    if s.name.trim().is_empty() || s.name.contains(['/', ',', '"', '\'', ';']) {
        errors.push(fail(
            i,
            "name",
            &s.name,
            "must be a non-empty name without '/', ',', quotes or ';' (the blocks are named <name>/<k>)",
            "e.g. name = \"slope\"",
        ));
    }
    if !(s.density.is_finite() && s.density > 0.0) {
        errors.push(fail(
            i,
            "density",
            s.density,
            "must be a positive finite number",
            "give the rock density in kg/m³, e.g. density = 2600.0",
        ));
    } else if s.density > super::validate::MAX_DENSITY {
        errors.push(fail(
            i,
            "density",
            s.density,
            &format!(
                "is denser than {:e} kg/m³, four times the densest element (osmium): a typo, \
                 which overflows the blocks' mass and inertia",
                super::validate::MAX_DENSITY
            ),
            "give the rock density in kg/m³, e.g. density = 2600.0",
        ));
    }
    if let Some(v) = s.min_block_volume
        && !(v.is_finite() && v >= 0.0)
    {
        errors.push(fail(
            i,
            "min_block_volume",
            v,
            "must be >= 0",
            "give the smallest block kept in m³, or leave it out for 1e-6 of the region",
        ));
    }
    if s.max_blocks == 0 || s.max_blocks > MAX_BLOCKS_LIMIT {
        errors.push(fail(
            i,
            "max_blocks",
            s.max_blocks,
            &format!(
                "must be in 1..={MAX_BLOCKS_LIMIT} (every process cuts the slide and checks its \
                 blocks when it reads the scene; 64 000 blocks took 14 s and 1.1 GB)"
            ),
            &format!(
                "e.g. max_blocks = {DEFAULT_MAX_BLOCKS}; for more blocks, cut the rock mass into \
                 several [[slide]]s or use larger joint spacings"
            ),
        ));
    }
    for (field, v) in [
        ("friction_angle", s.friction_angle),
        ("cohesion", s.cohesion),
    ] {
        if let Some(v) = v {
            let ok = if field == "cohesion" {
                v.is_finite() && v >= 0.0
            } else {
                (0.0..90.0).contains(&v)
            };
            if !ok {
                errors.push(fail(
                    i,
                    field,
                    v,
                    "is out of range",
                    "friction_angle in [0, 90) degrees, cohesion >= 0 Pa, or leave it out",
                ));
            }
        }
    }
    if s.joint_sets.is_empty() {
        errors.push(fail(i, "joint_set", "nothing", "a slide needs at least one joint set", "add [[slide.joint_set]] with dip, dip_direction and spacing (or make the rock one [[block]])"));
    }
    for (j, js) in s.joint_sets.iter().enumerate() {
        let f = |field: &str| format!("joint_set[{j}].{field}");
        if !(0.0..=90.0).contains(&js.dip) {
            errors.push(fail(
                i,
                &f("dip"),
                js.dip,
                "must be in [0, 90] degrees",
                "give the dip below horizontal, e.g. dip = 35.0",
            ));
        }
        if !(0.0..360.0).contains(&js.dip_direction) {
            errors.push(fail(i, &f("dip_direction"), js.dip_direction, "must be in [0, 360) degrees", "give the azimuth of the dip, clockwise from north (+y), e.g. dip_direction = 90.0 for east (+x)"));
        }
        if !(js.spacing.is_finite() && js.spacing > 0.0) {
            errors.push(fail(
                i,
                &f("spacing"),
                js.spacing,
                "must be a positive finite number",
                "give the distance between joints in metres",
            ));
        }
        if js
            .offset
            .iter()
            .any(|x| !x.is_finite() || x.abs() > MAX_OFFSET)
        {
            errors.push(fail(
                i,
                &f("offset"),
                js.offset,
                &format!(
                    "must be finite and within ±{MAX_OFFSET:e} m (a plane's place is lost in \
                     rounding beyond)"
                ),
                "give a point one joint passes through near the region, e.g. one of its corners",
            ));
        }
        if !(0.0..90.0).contains(&js.friction_angle) {
            errors.push(fail(
                i,
                &f("friction_angle"),
                js.friction_angle,
                "must be in [0, 90) degrees",
                "e.g. friction_angle = 30.0",
            ));
        }
        for (field, v) in [
            ("cohesion", js.cohesion),
            ("tensile_strength", js.tensile_strength),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                errors.push(fail(
                    i,
                    &f(field),
                    v,
                    "must be >= 0",
                    "give the joint's strength in Pa, 0 for a clean joint",
                ));
            }
        }
    }
    errors
}

/// Cuts one slide; the blocks and the summary, or the problems.
pub fn cut_slide(i: usize, s: &SlideSpec) -> Result<(Vec<BlockSpec>, SlideCut), Vec<FieldError>> {
    let errors = check_fields(i, s);
    if !errors.is_empty() {
        return Err(errors);
    }
    let region = shape_points(&s.region)
        .and_then(|p| Polyhedron::from_points(&p).map(|poly| (p, poly)))
        .map_err(|e| vec![fail(i, "region", "the region", &e.problem, &e.fix)])?;
    let (points, poly) = region;
    let lo = points
        .iter()
        .fold(Vector::repeat(Real::INFINITY), |m, p| m.inf(&p.coords));
    let hi = points
        .iter()
        .fold(Vector::repeat(Real::NEG_INFINITY), |m, p| m.sup(&p.coords));
    let tol = TOLERANCE * (hi - lo).norm();
    let cell = Cell::hull(&points, tol).ok_or_else(|| {
        vec![fail(
            i,
            "region",
            "the region",
            "encloses no volume",
            "give a convex region that spans 3D",
        )]
    })?;
    let families: Vec<PlaneFamily> = s.joint_sets.iter().map(JointSetSpec::family).collect();
    // Planes per set across the region, and the bound they put on the count (each family of
    // parallel planes splits a convex cell into at most planes + 1 pieces).
    let counts: Vec<u64> = families
        .iter()
        .map(|f| {
            let (a, b) = cell.extent(&f.normal);
            f.count_within(a, b, tol)
        })
        .collect();
    let mut errors = Vec::new();
    for (j, (&n, js)) in counts.iter().zip(&s.joint_sets).enumerate() {
        if n == 0 {
            errors.push(fail(
                i,
                &format!("joint_set[{j}]"),
                format!("dip {} / dip_direction {} / spacing {} m", js.dip, js.dip_direction, js.spacing),
                "cuts no block: no plane of this set crosses the region",
                "make the spacing smaller than the region, move its offset into the region, or remove the set",
            ));
        }
    }
    if !errors.is_empty() {
        return Err(errors);
    }
    let bound: f64 = counts.iter().map(|&n| n as f64 + 1.0).product();
    let least = fewest_pieces(&families, &counts, poly.volume);
    let too_many = |reached: String| {
        vec![fail(
            i,
            "joint_set",
            format!("{counts:?} planes per set"),
            &format!(
                "cut the region into {reached} blocks (up to {bound:.3e} from the sets' plane counts), more than max_blocks = {}",
                s.max_blocks
            ),
            &if s.max_blocks < MAX_BLOCKS_LIMIT {
                format!(
                    "use larger spacings, or raise max_blocks (at most {MAX_BLOCKS_LIMIT}) if you mean it (each block is a 6-DOF body in the solid node)"
                )
            } else {
                format!(
                    "use larger spacings, or cut the rock mass into several [[slide]]s ({MAX_BLOCKS_LIMIT} blocks at most each)"
                )
            },
        )]
    };
    // Estimated before anything is cut: refused outright when the fewest pieces the sets can
    // make pass the limit, or when even a hundredth of the bound would (the bound is exact for
    // orthogonal sets in a box); otherwise cut, stopping at the limit.
    if least > s.max_blocks as f64 {
        return Err(too_many(format!("at least {least:.3e}")));
    }
    if bound > 100.0 * s.max_blocks as f64 {
        return Err(too_many(format!("about {bound:.3e}")));
    }
    let started = std::time::Instant::now();
    let expected = bound.min(s.max_blocks as f64) as usize;
    let progress = |set: usize, pieces: usize, done: bool| CuttingProgress {
        slide: &s.name,
        set,
        sets: families.len(),
        pieces,
        expected,
        done,
    };
    let mut shown = false;
    let mut report = |k: usize, pieces: usize| {
        if let Some(p) = PROGRESS.get()
            && started.elapsed() > PROGRESS_AFTER
        {
            shown = true;
            p(&progress(k + 1, pieces, false));
        }
    };
    let cut = cutting::cut(cell, &families, tol, s.max_blocks, &mut report);
    if let Some(p) = PROGRESS.get().filter(|_| shown) {
        p(&progress(families.len(), expected, true));
    }
    let cut = cut.map_err(|e| too_many(format!("more than {}", e.reached - 1)))?;
    let region_volume = poly.volume;
    let min_block_volume = s
        .min_block_volume
        .unwrap_or(DEFAULT_MIN_BLOCK_FRACTION * region_volume);
    let mut summary = SlideCut {
        region_volume,
        min_block_volume,
        planes_used: cut.planes_used.clone(),
        slivers: cut.degenerate,
        min_volume: Real::INFINITY,
        ..Default::default()
    };
    let mut blocks = Vec::with_capacity(cut.cells.len());
    for c in &cut.cells {
        let corners: Vec<Point> = c.corners.clone();
        match Polyhedron::from_points(&corners) {
            Ok(p) if p.volume >= min_block_volume => {
                summary.kept_volume += p.volume;
                summary.min_volume = summary.min_volume.min(p.volume);
                summary.max_volume = summary.max_volume.max(p.volume);
                let shape = ShapeSpec::Convex {
                    vertices: corners.iter().map(|p| [p.x, p.y, p.z]).collect(),
                };
                let name = format!("{}/{}", s.name, blocks.len());
                blocks.push(BlockSpec {
                    friction_angle: s.friction_angle,
                    cohesion: s.cohesion,
                    slide: Some(SlideMember { slide: i }),
                    ..BlockSpec::plain(name, BlockKind::Free, shape, s.density)
                });
            }
            Ok(p) => {
                summary.slivers += 1;
                summary.sliver_volume += p.volume;
            }
            Err(_) => summary.slivers += 1,
        }
    }
    summary.blocks = blocks.len();
    if blocks.is_empty() {
        summary.min_volume = 0.0;
        return Err(vec![fail(
            i,
            "min_block_volume",
            min_block_volume,
            &format!(
                "drops every one of the {} pieces the joint sets cut",
                cut.cells.len()
            ),
            "lower min_block_volume or use larger spacings",
        )]);
    }
    Ok((blocks, summary))
}

/// The joint sets of a scene's slides spaced closer than the water can resolve (below
/// [`MIN_SPACING_OF_DX`] of `fluid.dx`), as (slide, set) pairs; none without water.
fn too_fine(scene: &Scene) -> Vec<(usize, usize)> {
    let Some(dx) = scene
        .fluid
        .as_ref()
        .map(|f| f.dx)
        .filter(|_| scene.has_fluid())
    else {
        return Vec::new();
    };
    let mut found = Vec::new();
    for (i, s) in scene.slides.iter().enumerate() {
        for (j, js) in s.joint_sets.iter().enumerate() {
            if js.spacing > 0.0 && js.spacing < MIN_SPACING_OF_DX * dx {
                found.push((i, j));
            }
        }
    }
    found
}

/// The joint sets spaced closer than a quarter of `fluid.dx`, named with the spacing the water
/// needs: the blocks between their planes would be thinner than the water can see, whatever
/// the cube root of their volume. Checked with the rest of the scene (also after `--dx`).
pub(super) fn spacing_errors(scene: &Scene) -> Vec<FieldError> {
    let dx = scene.fluid.as_ref().map_or(0.0, |f| f.dx);
    too_fine(scene)
        .into_iter()
        .map(|(i, j)| {
            let spacing = scene.slides[i].joint_sets[j].spacing;
            fail(
                i,
                &format!("joint_set[{j}].spacing"),
                spacing,
                &format!(
                    "is below a quarter of fluid.dx = {} m: the slabs between these joints \
                     would be thinner than the water can resolve ({:.3e} m)",
                    readable(dx),
                    MIN_SPACING_OF_DX * dx
                ),
                &format!(
                    "use spacing >= {:.3e} m, or a fluid.dx <= {:.3e} m (4 × the spacing)",
                    MIN_SPACING_OF_DX * dx,
                    spacing / MIN_SPACING_OF_DX
                ),
            )
        })
        .collect()
}

/// How far a slide's cutting is, for a progress bar ([`report_cutting_progress`]).
#[derive(Debug, Clone)]
pub struct CuttingProgress<'a> {
    /// The slide's name.
    pub slide: &'a str,
    /// The joint set cutting now (1-based) and how many there are.
    pub set: usize,
    pub sets: usize,
    /// Pieces after this set so far, and the most expected at the end (the smaller of the
    /// sets' bound and `max_blocks`).
    pub pieces: usize,
    pub expected: usize,
    /// The cutting of this slide is over.
    pub done: bool,
}

/// Where the cutting's progress goes.
pub type CuttingReport = dyn Fn(&CuttingProgress<'_>) + Send + Sync;

static PROGRESS: std::sync::OnceLock<Box<CuttingReport>> = std::sync::OnceLock::new();

/// Cutting shorter than this reports no progress.
const PROGRESS_AFTER: std::time::Duration = std::time::Duration::from_secs(1);

/// Sets, once per process, where the cutting of a slide that takes more than a second reports
/// its progress (the coupler draws a bar; the nodes set nothing and cut silently).
pub fn report_cutting_progress(report: Box<CuttingReport>) {
    let _ = PROGRESS.set(report);
}

/// Joint sets whose triples [`fewest_pieces`] tries (the first ones; a slide has a handful).
const TRIPLE_SETS: usize = 12;

/// The fewest pieces `families` (crossing the region `counts` planes each) can cut a convex
/// region of `volume` into, before cutting: a family of m planes across a convex region makes
/// m + 1 pieces, and every piece lies inside one parallelepiped cell of any three sets whose
/// normals span space, of volume s₁s₂s₃ / |n₁·(n₂×n₃)|, so there are at least volume / that.
fn fewest_pieces(families: &[PlaneFamily], counts: &[u64], volume: Real) -> Real {
    let mut least = counts.iter().map(|&n| n as Real + 1.0).fold(1.0, Real::max);
    let f = &families[..families.len().min(TRIPLE_SETS)];
    for a in 0..f.len() {
        for b in a + 1..f.len() {
            for c in b + 1..f.len() {
                let det = f[a].normal.dot(&f[b].normal.cross(&f[c].normal)).abs();
                if det > 1e-6 {
                    let cell = f[a].spacing * f[b].spacing * f[c].spacing / det;
                    least = least.max(volume / cell);
                }
            }
        }
    }
    least
}

/// Points the problems of a cut block (`block[k]`, which the scene file does not hold) at the
/// slide it was cut from, naming the block and what to change.
pub(super) fn attribute(scene: &Scene, errors: &mut [FieldError]) {
    for e in errors.iter_mut() {
        let (Some(Seg::Key(k)), Some(Seg::Index(i))) = (e.segments.first(), e.segments.get(1))
        else {
            continue;
        };
        let Some(b) = scene.blocks.get(*i).filter(|_| k == "block") else {
            continue;
        };
        let Some(m) = b.slide else { continue };
        e.segments = vec![Seg::Key("slide".into()), Seg::Index(m.slide)];
        e.path = render_path(&e.segments);
        e.problem = format!("cut block '{}': {}", b.name, e.problem);
        e.fix = format!(
            "{} — the block was cut from this slide: raise min_block_volume to drop such blocks, or change the joint sets' spacing",
            e.fix
        );
    }
}

/// Cuts every slide of `scene` and appends the blocks (done once, by [`Scene::parse_checked`]).
/// Returns the problems; the summaries go to [`Scene::slide_cuts`].
pub(super) fn expand(scene: &mut Scene) -> Vec<FieldError> {
    if scene.blocks.iter().any(|b| b.slide.is_some()) {
        return Vec::new(); // already expanded
    }
    let mut errors = Vec::new();
    let mut cuts = Vec::new();
    let mut names = std::collections::HashSet::new();
    // Slides with joints too close for the water are not cut (their many thin blocks would
    // only hide the one error [`spacing_errors`] names).
    let skip: Vec<usize> = too_fine(scene).into_iter().map(|(i, _)| i).collect();
    for (i, s) in scene.slides.iter().enumerate() {
        if !names.insert(s.name.as_str()) {
            errors.push(fail(
                i,
                "name",
                &s.name,
                "is used by an earlier slide",
                "give every slide a unique name",
            ));
        }
        if skip.contains(&i) {
            continue;
        }
        match cut_slide(i, s) {
            Ok((blocks, mut summary)) => {
                summary.first_block = scene.blocks.len();
                scene.blocks.extend(blocks);
                cuts.push(summary);
            }
            Err(e) => errors.extend(e),
        }
    }
    scene.slide_cuts = cuts;
    errors
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A scene with one slide: a box region cut by three orthogonal sets.
    fn scene(region: &str, spacing: f64, offset: f64, extra: &str) -> String {
        let mut s = format!(
            "name = \"cut\"\n[time]\nend = 0.1\n[domain]\nmin = [-10, -10, -10]\nmax = [10, 10, 10]\n\
             [[slide]]\nname = \"rock\"\nregion = {region}\n{extra}\n"
        );
        for (dip, dir) in [(90.0, 90.0), (90.0, 0.0), (0.0, 0.0)] {
            s += &format!(
                "[[slide.joint_set]]\ndip = {dip}\ndip_direction = {dir}\nspacing = {spacing}\n\
                 offset = [{offset}, {offset}, {offset}]\n"
            );
        }
        s
    }

    const UNIT_BOX: &str = "{ type = \"box\", min = [0, 0, 0], max = [1, 1, 1] }";

    #[test]
    fn three_orthogonal_sets_cut_a_box_into_cubes() {
        let s = Scene::parse(&scene(UNIT_BOX, 0.25, 0.0, ""), "t").unwrap();
        let cut = &s.slide_cuts[0];
        assert_eq!(cut.blocks, 64);
        assert_eq!(s.blocks.len(), 64);
        assert_eq!(cut.planes_used, vec![3, 3, 3]);
        assert_eq!(cut.slivers, 0);
        assert!((cut.kept_volume - 1.0).abs() < 1e-12, "{cut}");
        assert!((cut.min_volume - 1.0 / 64.0).abs() < 1e-12, "{cut}");
        assert!((cut.max_volume - 1.0 / 64.0).abs() < 1e-12, "{cut}");
        assert_eq!(s.blocks[17].name, "rock/17");
        assert!(
            s.blocks
                .iter()
                .all(|b| b.slide == Some(SlideMember { slide: 0 }))
        );
    }

    #[test]
    fn slivers_are_dropped_and_accounted() {
        // Planes at 0.1, 0.35, 0.6, 0.85 on each axis: widths 0.1, 0.25, 0.25, 0.25, 0.15.
        // Below 0.002 m³: the 0.1³ corner and the three 0.1·0.1·0.15 blocks.
        let text = scene(UNIT_BOX, 0.25, 0.1, "min_block_volume = 0.002");
        let s = Scene::parse(&text, "t").unwrap();
        let cut = &s.slide_cuts[0];
        assert_eq!(cut.blocks + cut.slivers, 125, "{cut}");
        assert_eq!(cut.slivers, 4, "{cut}");
        assert!((cut.sliver_volume - 0.0055).abs() < 1e-12, "{cut}");
        assert!(
            (cut.kept_volume + cut.sliver_volume - 1.0).abs() < 1e-12,
            "{cut}"
        );
    }

    #[test]
    fn a_tilted_set_cuts_a_convex_region_with_its_volume_kept() {
        // A triangular prism (a slope) cut by a dipping set and a vertical one.
        let text = "name = \"cut\"\n[time]\nend = 0.1\n[domain]\nmin = [-10, -10, -10]\nmax = [10, 10, 10]\n\
            [[slide]]\nname = \"slope\"\n\
            region = { type = \"prism\", axis = \"y\", profile = [[0, 0], [4, 0], [4, 3]], extent = [0, 2] }\n\
            [[slide.joint_set]]\ndip = 35\ndip_direction = 270\nspacing = 0.7\n\
            [[slide.joint_set]]\ndip = 80\ndip_direction = 20\nspacing = 0.9\noffset = [0.3, 0, 0]\n";
        let s = Scene::parse(text, "t").unwrap();
        let cut = &s.slide_cuts[0];
        assert!(cut.blocks > 10, "{cut}");
        assert!(
            (cut.kept_volume + cut.sliver_volume - 12.0).abs() < 1e-9,
            "{cut}"
        );
        // Every block is a valid convex block of the scene.
        for b in &s.blocks {
            assert!(Polyhedron::from_shape(&b.shape).is_ok(), "{}", b.name);
        }
    }

    #[test]
    fn the_written_scene_keeps_the_slide_not_its_blocks() {
        let s = Scene::parse(&scene(UNIT_BOX, 0.5, 0.0, ""), "t").unwrap();
        let text = toml::to_string(&s).unwrap();
        assert!(!text.contains("rock/0"), "{text}");
        let again = Scene::parse(&text, "again").unwrap();
        assert_eq!(again.blocks, s.blocks);
        assert_eq!(again.slide_cuts, s.slide_cuts);
    }

    #[test]
    fn a_set_that_cuts_nothing_is_named() {
        let text = scene(UNIT_BOX, 0.25, 0.0, "")
            .replacen("spacing = 0.25", "spacing = 5.0", 1)
            .replacen("offset = [0, 0, 0]", "offset = [2.5, 0, 0]", 1);
        let msg = Scene::parse(&text, "t").unwrap_err().to_string();
        assert!(
            msg.contains("slide[0].joint_set[0]") && msg.contains("cuts no block"),
            "{msg}"
        );
    }

    #[test]
    fn a_million_blocks_are_refused_with_the_count() {
        let region = "{ type = \"box\", min = [0, 0, 0], max = [10, 10, 10] }";
        let text = scene(region, 0.1, 0.0, "");
        let msg = Scene::parse(&text, "t").unwrap_err().to_string();
        assert!(
            msg.contains("1.000e6") && msg.contains("max_blocks = 10000"),
            "{msg}"
        );
        // Below even the fewest pieces (64 cells of 0.25³ in 1 m³): refused before cutting.
        let text = scene(UNIT_BOX, 0.25, 0.0, "max_blocks = 60");
        let msg = Scene::parse(&text, "t").unwrap_err().to_string();
        assert!(msg.contains("at least 6.400e1"), "{msg}");
        // Above the fewest (64) but below the 125 pieces planes off the corners make: cut
        // until the limit, then refused.
        let text = scene(UNIT_BOX, 0.25, 0.1, "max_blocks = 100");
        let msg = Scene::parse(&text, "t").unwrap_err().to_string();
        assert!(msg.contains("more than 100"), "{msg}");
    }

    #[test]
    fn a_cut_block_too_small_for_the_water_names_its_slide() {
        // dx = 1 m: moving blocks under dx/4 = 0.25 m across are refused, and the corner
        // block cut at offset 0.1 is 0.1 m across.
        let text =
            scene(UNIT_BOX, 0.25, 0.1, "").replace("[[slide]]", "[fluid]\ndx = 1.0\n[[slide]]");
        let msg = Scene::parse(&text, "t").unwrap_err().to_string();
        assert!(
            msg.contains("slide[0]")
                && msg.contains("cut block 'rock/0'")
                && msg.contains("min_block_volume")
                && !msg.contains("block[0]"),
            "{msg}"
        );
    }

    #[test]
    fn spacings_that_cut_millions_are_refused_before_cutting_even_at_the_limit() {
        let region = "{ type = \"box\", min = [0, 0, 0], max = [10, 10, 10] }";
        for spacing in [0.1, 0.02, 1e-3] {
            let text = scene(
                region,
                spacing,
                0.0,
                &format!("max_blocks = {MAX_BLOCKS_LIMIT}"),
            );
            let msg = Scene::parse(&text, "t").unwrap_err().to_string();
            assert!(
                msg.contains("slide[0].joint_set")
                    && msg.contains("at least")
                    && msg.contains(&format!("max_blocks = {MAX_BLOCKS_LIMIT}"))
                    && msg.contains("several [[slide]]s"),
                "{msg}"
            );
        }
        let text = scene(UNIT_BOX, 0.25, 0.0, "max_blocks = 10000000");
        let msg = Scene::parse(&text, "t").unwrap_err().to_string();
        assert!(
            msg.contains("slide[0].max_blocks") && msg.contains(&format!("1..={MAX_BLOCKS_LIMIT}")),
            "{msg}"
        );
    }

    #[test]
    fn the_fewest_pieces_bound_the_count_from_below() {
        // Oblique sets through the jointed slide of the repository: the estimate stays below
        // what the cutting makes (blocks and slivers).
        let text = include_str!("../../../scenes/jointed_slide.toml");
        let s = Scene::parse(text, "t").unwrap();
        let (slide, cut) = (&s.slides[0], &s.slide_cuts[0]);
        let families: Vec<PlaneFamily> =
            slide.joint_sets.iter().map(JointSetSpec::family).collect();
        let counts: Vec<u64> = cut.planes_used.iter().map(|&n| n as u64).collect();
        let least = fewest_pieces(&families, &counts, cut.region_volume);
        assert!(
            least >= 6.0 && least <= (cut.blocks + cut.slivers) as Real,
            "{least} {cut}"
        );
    }

    #[test]
    fn an_offset_far_away_is_refused_at_once() {
        let text = scene(UNIT_BOX, 0.25, 0.0, "").replacen(
            "offset = [0, 0, 0]",
            "offset = [1e300, 0, 0]",
            1,
        );
        let msg = Scene::parse(&text, "t").unwrap_err().to_string();
        assert!(
            msg.contains("slide[0].joint_set[0].offset")
                && msg.contains("1e7 m")
                && msg.contains("fix:"),
            "{msg}"
        );
    }

    #[test]
    fn joints_closer_than_a_quarter_of_dx_are_named_before_cutting() {
        // dx = 1 m: joints every 0.1 m make slabs the water cannot see.
        let text = scene(UNIT_BOX, 0.1, 0.0, "")
            .replace("[[slide]]", "[fluid]\ndx = 1.0\n[[fluid.water]]\nshape = { type = \"box\", min = [-9, -9, -9], max = [9, 9, -5] }\n[[slide]]");
        let msg = Scene::parse(&text, "t").unwrap_err().to_string();
        assert!(
            msg.contains("slide[0].joint_set[0].spacing = 0.1")
                && msg.contains("quarter of fluid.dx")
                && msg.contains("spacing >= 2.500e-1")
                && msg.contains("line ")
                && !msg.contains("cut block"),
            "{msg}"
        );
        // The same after a finer scene is given a coarser dx (`--dx`).
        let text = text.replace("dx = 1.0", "dx = 0.2");
        let mut s = Scene::parse(&text, "t").unwrap();
        s.set_dx(1.0);
        let errors = s.validate();
        assert!(
            errors
                .iter()
                .any(|e| e.path == "slide[0].joint_set[2].spacing"),
            "{errors:?}"
        );
    }

    #[test]
    fn bad_joint_fields_are_named() {
        let text = scene(UNIT_BOX, 0.25, 0.0, "").replacen("dip = 90", "dip = 120", 1);
        let msg = Scene::parse(&text, "t").unwrap_err().to_string();
        assert!(msg.contains("slide[0].joint_set[0].dip"), "{msg}");
    }
}
