//! `[[terrain]]`: the checks that need no file (the file itself is read by
//! [`crate::terrain::Terrain::load`]).

use crate::geometry::MAX_COORDINATE;
use crate::scene::error::{FieldError, Seg, render_path};
use crate::scene::schema::{DomainSpec, TerrainFormat, TerrainSpec};
use crate::terrain::TerrainError;

/// An error at `terrain[index].field`.
pub(crate) fn terrain_field_error(
    index: usize,
    field: &str,
    value: String,
    problem: &str,
    fix: &str,
) -> FieldError {
    indexed_field_error("terrain", index, field, value, problem, fix)
}

/// An error at `table[index].field` (`field` empty: the table itself), e.g. a block that a
/// terrain buries.
pub(crate) fn indexed_field_error(
    table: &str,
    index: usize,
    field: &str,
    value: String,
    problem: &str,
    fix: &str,
) -> FieldError {
    let mut segments = vec![Seg::Key(table.into()), Seg::Index(index)];
    if !field.is_empty() {
        segments.push(Seg::Key(field.into()));
    }
    FieldError {
        path: render_path(&segments),
        segments,
        value,
        problem: problem.into(),
        fix: fix.into(),
        line: None,
    }
}

/// The placed terrain's bounds `lo`..`hi` reaching past [`MAX_COORDINATE`], the largest
/// coordinate a block may have: the solid node holds a terrain as a block, whose corners it
/// refuses there, and past ~1e154 its centroid overflows (a DEM with one cell of 1e300 passed
/// `coupler check` and failed at the solid node's step 0: "block 'valley': vertex {-inf, -inf,
/// -inf} is not finite"). A problem of the file (a spike, a cell in other units) or of `scale`.
pub(crate) fn terrain_reach_problem(lo: [f64; 3], hi: [f64; 3]) -> Option<TerrainError> {
    let far = lo.iter().chain(&hi).any(|x| x.abs() > MAX_COORDINATE);
    far.then(|| TerrainError {
        field: "file",
        value: format!("terrain bounds {lo:?} to {hi:?}"),
        problem: format!(
            "places a vertex beyond ±{MAX_COORDINATE:e} m, past any scene (the solid node refuses \
             such a block corner): a spike in the file, a cell in other units, or a scale too large"
        ),
        fix: "correct the file's outlying cell or vertex, or keep the ground near the domain with \
              crop = { min = [x, y, z], max = [x, y, z] }, or check scale"
            .into(),
    })
}

/// The checks of the `[[terrain]]` tables that need no file.
/// `blocks` are the scene's block names: a terrain is a block to the solid node (its
/// contacts, its messages), so the names must differ.
pub(super) fn check(
    terrains: &[TerrainSpec],
    domain: &DomainSpec,
    blocks: &[&str],
) -> Vec<FieldError> {
    let mut out = Vec::new();
    let mut fail = |i: usize, field: &str, value: String, problem: &str, fix: &str| {
        out.push(terrain_field_error(i, field, value, problem, fix))
    };
    for (i, t) in terrains.iter().enumerate() {
        if blocks.contains(&t.name.as_str()) || terrains[..i].iter().any(|o| o.name == t.name) {
            fail(
                i,
                "name",
                format!("{:?}", t.name),
                "is used by a block or an earlier terrain",
                "give every terrain a name of its own, e.g. name = \"valley\"",
            );
        }
        if t.name.trim().is_empty()
            || t.name
                .chars()
                .any(|c| matches!(c, ',' | '"' | '\'' | ';') || c.is_control())
        {
            fail(
                i,
                "name",
                format!("{:?}", t.name),
                "must be a short name without separators or quotes",
                "use letters, digits, '_', '-' or '.', e.g. name = \"fjord\"",
            );
        }
        if TerrainFormat::of(&t.file).is_none() {
            fail(
                i,
                "file",
                format!("{:?}", t.file.display().to_string()),
                "has no known terrain extension",
                "give a .stl, .obj or .ply triangle mesh or an .asc (ESRI ASCII grid) or .tif (GeoTIFF) elevation model",
            );
        }
        for (field, v) in [("offset", t.offset), ("rotation", t.rotation)] {
            if v.iter().any(|x| !x.is_finite()) {
                fail(
                    i,
                    field,
                    format!("{v:?}"),
                    "must be finite",
                    "give three finite numbers",
                );
            }
        }
        if t.scale.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
            fail(
                i,
                "scale",
                format!("{:?}", t.scale),
                "must be three positive finite factors",
                "give e.g. scale = [1.0, 1.0, 1.0]; mirror a mesh in its own tool, not here",
            );
        }
        if let Some(c) = &t.crop {
            if (0..3).any(|k| {
                c.max[k].partial_cmp(&c.min[k]) != Some(std::cmp::Ordering::Greater)
                    || !c.min[k].is_finite()
            }) {
                fail(
                    i,
                    "crop",
                    format!("{c:?}"),
                    "is empty or not finite (max must be above min on every axis)",
                    "give crop = { min = [x, y, z], max = [x, y, z] } with max > min",
                );
            } else if (0..3).any(|k| c.max[k] < domain.min[k] || c.min[k] > domain.max[k]) {
                fail(
                    i,
                    "crop",
                    format!("{c:?}"),
                    "lies wholly outside [domain]: no triangle could be kept",
                    "give a crop box that overlaps [domain]",
                );
            }
        }
        if let Some(n) = t.decimate {
            let dem = matches!(
                TerrainFormat::of(&t.file),
                Some(TerrainFormat::EsriAscii | TerrainFormat::GeoTiff)
            );
            if n == 0 {
                fail(
                    i,
                    "decimate",
                    format!("{n}"),
                    "must be at least 1 (every n-th row and column is kept)",
                    "give decimate = 1 to keep every cell, or e.g. decimate = 4",
                );
            } else if !dem {
                fail(
                    i,
                    "decimate",
                    format!("{n}"),
                    "applies to DEMs (.asc, .tif) only",
                    "remove decimate, and simplify the mesh in its own tool (e.g. a quadric decimation)",
                );
            }
        }
        for (field, v, fix) in [
            (
                "friction_angle",
                t.friction_angle,
                "give an angle in degrees in [0, 90), e.g. 30",
            ),
            ("cohesion", t.cohesion, "give a cohesion ≥ 0 in Pa"),
        ] {
            if let Some(v) = v {
                let ok = v.is_finite() && v >= 0.0 && (field != "friction_angle" || v < 90.0);
                if !ok {
                    fail(i, field, format!("{v}"), "is out of range", fix);
                }
            }
        }
    }
    out
}
