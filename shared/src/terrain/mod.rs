//! Fixed terrain read from files (`[[terrain]]`): a surveyed triangle mesh or a digital
//! elevation model, placed in the scene, checked, and held as a parry [`TriMesh`] with its
//! bounding-volume tree, so every query (nearest surface point, signed distance, the triangles
//! near a block) costs O(log n) in the triangle count n.
//!
//! The ground is on the inner side of the surface: inside a closed mesh, under an open one
//! (its triangles wound counter-clockwise seen from the water). Signed distances use parry's
//! pseudo-normals (Bærentzen & Aanæs 2005, the angle-weighted normals at vertices and edges), so
//! the inside test is exact at edges and corners of a non-convex surface too.
//!
//! The checks name the field and the fix: a mesh not manifold or not consistently wound, normals
//! pointing into the ground (`flip_normals`), an open mesh whose rim lies inside the domain
//! (water would run under it), DEM no-data cells (refused or filled, `nodata`), a terrain that
//! misses the domain.

pub mod dem;
pub mod files;
pub mod geotiff;
pub mod reuse;
pub mod topology;

use crate::math::{Point, Real, Rotation, Vector, readable};
use crate::scene::{DomainSpec, FieldError, NoData, Scene, TerrainFormat, TerrainSpec};
use crate::scene::{indexed_field_error, terrain_field_error};
use files::RawMesh;
use parry3d_f64::query::{PointQueryWithLocation, Ray, RayCast};
use parry3d_f64::shape::{TriMesh, TriMeshFlags};
use std::path::PathBuf;

/// A terrain in scene coordinates, ready for queries.
#[derive(Clone)]
pub struct Terrain {
    pub name: String,
    pub file: PathBuf,
    /// The surface, oriented (pseudo-normals computed) with its BVH.
    pub mesh: TriMesh,
    /// Every edge shared by two triangles (a solid); otherwise an open surface with the ground
    /// under it.
    pub closed: bool,
    /// DEM cells that were no-data and filled (`nodata = "fill"`).
    pub filled_cells: usize,
    /// Degenerate (zero-area) triangles dropped at load.
    pub dropped_degenerate: usize,
    pub friction_angle: Option<Real>,
    pub cohesion: Option<Real>,
}

impl std::fmt::Debug for Terrain {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Terrain({})", self.summary())
    }
}

/// The surface point nearest to a query point.
#[derive(Debug, Clone, Copy)]
pub struct Surface {
    /// Signed distance [m]: negative inside the ground.
    pub distance: Real,
    /// The nearest point on the surface.
    pub point: Point,
    /// Unit normal out of the ground at that point (towards the query point when outside).
    pub normal: Vector,
    /// The triangle it lies on.
    pub triangle: u32,
}

/// Why a terrain cannot be used: the field of `[[terrain]]` to change, the problem, the fix.
#[derive(Debug, Clone)]
pub struct TerrainError {
    pub field: &'static str,
    pub value: String,
    pub problem: String,
    pub fix: String,
}

fn fail(
    field: &'static str,
    value: impl Into<String>,
    problem: impl Into<String>,
    fix: &str,
) -> TerrainError {
    TerrainError {
        field,
        value: value.into(),
        problem: problem.into(),
        fix: fix.into(),
    }
}

impl Terrain {
    /// Reads, places and checks one `[[terrain]]` table.
    pub fn load(spec: &TerrainSpec, domain: &DomainSpec) -> Result<Terrain, TerrainError> {
        let file = spec.file.display().to_string();
        let file_err = |e: String| file_error(&file, e);
        let format = TerrainFormat::of(&spec.file).ok_or_else(|| {
            fail(
                "file",
                format!("{file:?}"),
                "has no known terrain extension",
                "give a .stl, .obj, .ply, .asc or .tif file",
            )
        })?;
        // A FIFO would block the read for ever and a device (/dev/zero) never end it: only a
        // regular file has the length its contents are bounded by.
        files::regular(&spec.file).map_err(|e| {
            let fix = if spec.file.exists() {
                "name the terrain file itself (a regular file), not a pipe, device or directory"
            } else {
                "check the file's name and folder: a relative path is read from the scene file's folder"
            };
            fail("file", format!("{file:?}"), e, fix)
        })?;
        let mut filled_cells = 0;
        let raw = match format {
            TerrainFormat::Stl => files::read_stl(&spec.file).map_err(file_err)?,
            TerrainFormat::Obj => files::read_obj(&spec.file).map_err(file_err)?,
            TerrainFormat::Ply => files::read_ply(&spec.file).map_err(file_err)?,
            TerrainFormat::EsriAscii | TerrainFormat::GeoTiff => {
                let mut grid = read_dem(spec, format)?;
                filled_cells = grid
                    .resolve(spec.nodata)
                    .map_err(|e| {
                        let fix = if spec.nodata == NoData::Refuse {
                            "fill the holes in the DEM, or set nodata = \"fill\" to fill each from its neighbours"
                        } else {
                            "give a DEM with elevations"
                        };
                        fail("nodata", format!("{:?}", spec.nodata), format!("{file}: {e}"), fix)
                    })?
                    .cells;
                grid.triangulate()
            }
        };
        if let Some(v) = raw
            .vertices
            .iter()
            .find(|v| v.iter().any(|x| !x.is_finite()))
        {
            return Err(file_err(format!(
                "holds a vertex that is not finite: {v:?}"
            )));
        }
        if raw.triangles.is_empty() {
            return Err(file_err("holds no triangle".into()));
        }
        let (vertices, triangles, dropped_degenerate) = place(spec, raw);
        // A closed mesh is a solid: a crop that cuts it leaves a shell whose inside is no
        // longer defined. (A DEM is open from the start.)
        let solid = spec.crop.is_some()
            && !matches!(format, TerrainFormat::EsriAscii | TerrainFormat::GeoTiff)
            && topology::analyse(&triangles).closed();
        let whole = triangles.len();
        let triangles = crop(spec, &vertices, triangles)?;
        if solid && triangles.len() < whole {
            return Err(crop_opens_a_solid(spec, &vertices, triangles.len(), whole));
        }
        let (vertices, triangles) = compact(vertices, triangles);
        check_bounds(&vertices, domain)?;
        let topo = topology::analyse(&triangles);
        check_topology(&topo)?;
        check_orientation(spec, &vertices, &triangles, topo.closed())?;
        if !topo.closed() {
            check_rim(&vertices, &triangles, &topo.rim, domain)?;
        }
        let points = vertices.iter().map(|v| Point::from(*v)).collect();
        let mesh = TriMesh::with_flags(points, triangles, TriMeshFlags::ORIENTED)
            .map_err(|e| file_err(format!("cannot be made a triangle mesh: {e}")))?;
        Ok(Terrain {
            name: spec.name.clone(),
            file: spec.file.clone(),
            mesh,
            closed: topo.closed(),
            filled_cells,
            dropped_degenerate,
            friction_angle: spec.friction_angle,
            cohesion: spec.cohesion,
        })
    }

    /// Every `[[terrain]]` of a scene; the error names the table and field.
    pub fn load_all(scene: &Scene) -> Result<Vec<Terrain>, String> {
        each_terrain(scene, Terrain::load)
    }

    /// [`Self::load_all`], each terrain loaded once under a [`reuse::Reuse`] guard.
    pub fn load_all_kept(scene: &Scene) -> Result<Vec<std::sync::Arc<Terrain>>, String> {
        each_terrain(scene, reuse::load)
    }

    pub fn triangles(&self) -> usize {
        self.mesh.num_triangles()
    }

    /// Bounding box of the surface.
    pub fn bounds(&self) -> (Point, Point) {
        let b = self.mesh.local_aabb();
        (b.mins, b.maxs)
    }

    /// One line for `coupler check` and the logs.
    pub fn summary(&self) -> String {
        let (lo, hi) = self.bounds();
        let mut s = format!(
            "terrain '{}': {} triangles, {} surface, bounds [{:.4}, {:.4}, {:.4}] to [{:.4}, {:.4}, {:.4}] m, from {}",
            self.name,
            self.triangles(),
            if self.closed {
                "closed"
            } else {
                "open (ground under it)"
            },
            lo.x,
            lo.y,
            lo.z,
            hi.x,
            hi.y,
            hi.z,
            self.file.display()
        );
        if self.filled_cells > 0 {
            s += &format!(", {} no-data cells filled", self.filled_cells);
        }
        if self.dropped_degenerate > 0 {
            s += &format!(", {} degenerate triangles dropped", self.dropped_degenerate);
        }
        s
    }

    /// The surface point nearest to `x`, if closer than `max_dist` (use `Real::MAX` for any).
    /// O(log n): parry's best-first descent of the BVH.
    pub fn nearest(&self, x: &Point, max_dist: Real) -> Option<Surface> {
        let (proj, (tri, _)) = self
            .mesh
            .project_local_point_and_get_location_with_max_dist(x, false, max_dist)?;
        let d = x - proj.point;
        let len = d.norm();
        let sign = if proj.is_inside { -1.0 } else { 1.0 };
        let face = || {
            self.mesh
                .triangle(tri)
                .normal()
                .map_or(Vector::z(), |n| n.into_inner())
        };
        let normal = if len > 1e-12 * (1.0 + x.coords.norm()) {
            d * (sign / len)
        } else {
            face()
        };
        Some(Surface {
            distance: sign * len,
            point: proj.point,
            normal,
            triangle: tri,
        })
    }

    /// False when every point of the surface is farther than `dist` from `x` (no triangle's
    /// bounding box meets the cube of half-side `dist` around it): a BVH descent that stops at
    /// the first box, far cheaper than [`Self::nearest`] for the many points that are not near.
    #[inline]
    pub fn may_be_within(&self, x: &Point, dist: Real) -> bool {
        let d = Vector::repeat(dist);
        let aabb = parry3d_f64::bounding_volume::Aabb::new(x - d, x + d);
        self.mesh.bvh().intersect_aabb(&aabb).next().is_some()
    }

    /// True when `x` is inside the ground (under an open surface).
    pub fn contains(&self, x: &Point) -> bool {
        self.nearest(x, Real::MAX).is_some_and(|s| s.distance < 0.0)
    }

    /// Elevation of the highest surface point on the vertical through (x, y), if any.
    pub fn top_at(&self, x: Real, y: Real) -> Option<Real> {
        let (lo, hi) = self.bounds();
        let start = hi.z + 1.0 + (hi.z - lo.z);
        let ray = Ray::new(Point::new(x, y, start), -Vector::z());
        self.mesh
            .cast_local_ray(&ray, start - lo.z + 1.0, false)
            .map(|t| start - t)
    }
}

/// The bed under (x, y): the highest of the scene's fixed blocks and terrain surfaces on the
/// vertical through it, or the domain floor ([`Scene::bed_elevation`] with the terrain).
pub fn bed_elevation(scene: &Scene, terrain: &[Terrain], x: Real, y: Real) -> Real {
    terrain
        .iter()
        .filter_map(|t| t.top_at(x, y))
        .fold(scene.bed_elevation(x, y), Real::max)
}

/// A [`TerrainError`] of `terrain[index]` as a scene field error.
pub fn to_field_error(index: usize, e: TerrainError) -> FieldError {
    terrain_field_error(index, e.field, e.value, &e.problem, &e.fix)
}

/// `load` of every `[[terrain]]` of the scene; the first error names its table and field.
fn each_terrain<T>(
    scene: &Scene,
    load: impl Fn(&TerrainSpec, &DomainSpec) -> Result<T, TerrainError>,
) -> Result<Vec<T>, String> {
    scene
        .terrain
        .iter()
        .enumerate()
        .map(|(i, t)| load(t, &scene.domain).map_err(|e| to_field_error(i, e).to_string()))
        .collect()
}

/// Loads every terrain of the scene and reports what is wrong with each (the coupler's check
/// before any node starts), and every moving block buried in one.
pub fn check_scene(scene: &Scene) -> Vec<FieldError> {
    let mut out = Vec::new();
    for (i, t) in scene.terrain.iter().enumerate() {
        match reuse::load(t, &scene.domain) {
            Err(e) => out.push(to_field_error(i, e)),
            Ok(terrain) => out.extend(buried_blocks(scene, i, &terrain)),
        }
    }
    out
}

/// The free and kinematic blocks whose centre lies inside the ground of `terrain` (enclosed by a
/// closed mesh, or under an open surface): such a block starts deep in the rock, where contact
/// would throw it out at the first step or hold it for ever. A block resting on the ground has
/// its centre above it.
fn buried_blocks(scene: &Scene, index: usize, terrain: &Terrain) -> Vec<FieldError> {
    let mut out = Vec::new();
    let mut written = 0;
    for b in &scene.blocks {
        let at = match b.slide {
            Some(m) => ("slide", m.slide, ""),
            None => {
                written += 1;
                ("block", written - 1, "shape")
            }
        };
        if b.kind == crate::scene::BlockKind::Fixed {
            continue;
        }
        let Ok(points) = crate::geometry::shape_points(&b.shape) else {
            continue;
        };
        let c = Point::from(
            points.iter().map(|p| p.coords).sum::<Vector>() / points.len().max(1) as Real,
        );
        let Some(s) = terrain.nearest(&c, Real::MAX).filter(|s| s.distance < 0.0) else {
            continue;
        };
        out.push(indexed_field_error(
            at.0,
            at.1,
            at.2,
            format!("block '{}' centred at [{:.4}, {:.4}, {:.4}]", b.name, c.x, c.y, c.z),
            &format!(
                "lies {:.4} m inside the ground of terrain[{index}] '{}' ({}): the block would start in the rock",
                -s.distance,
                terrain.name,
                if terrain.closed {
                    "enclosed by its closed mesh"
                } else {
                    "under its surface"
                }
            ),
            &format!(
                "move the block out of the ground (the surface nearest its centre is at [{:.4}, {:.4}, {:.4}]), or check the terrain's offset, scale and flip_normals",
                s.point.x, s.point.y, s.point.z
            ),
        ));
    }
    out
}

/// An error of the file `file` itself: a reader's message, whose own fix (after "; fix: ")
/// becomes the error's, or the general one.
fn file_error(file: &str, e: String) -> TerrainError {
    let (problem, fix) = match e.split_once("; fix: ") {
        Some((p, f)) => (p.to_string(), f.to_string()),
        None => (
            e,
            "give a readable file of the format its extension names".into(),
        ),
    };
    fail("file", format!("{file:?}"), problem, &fix)
}

/// A DEM's header, then the cells its crop and decimation keep, read so: nothing else is held.
fn read_dem(spec: &TerrainSpec, format: TerrainFormat) -> Result<dem::Grid, TerrainError> {
    let file = spec.file.display().to_string();
    let file_err = |e: String| file_error(&file, e);
    enum Source {
        Asc(dem::AscReader<std::io::BufReader<std::fs::File>>),
        Tif(Box<geotiff::TifReader>),
    }
    let source = if format == TerrainFormat::GeoTiff {
        Source::Tif(Box::new(geotiff::open(&spec.file).map_err(file_err)?))
    } else {
        Source::Asc(dem::open(&spec.file).map_err(file_err)?)
    };
    let header = match &source {
        Source::Asc(r) => r.header(),
        Source::Tif(r) => r.header(),
    }
    .clone();
    let w = window(spec, &header);
    let (rows, cols) = w.size();
    if let Some(c) = &spec.crop
        && (rows < 2 || cols < 2)
    {
        return Err(crop_keeps_nothing(c));
    }
    header.check_kept(&w).map_err(|e| {
        let step = w.step as f64 * (w.cells() as f64 / dem::MAX_DEM_CELLS as f64).sqrt();
        let fix = format!(
            "crop the DEM to the part the water reaches (crop = {{ min = [x, y, z], max = [x, y, z] }}, scene coordinates), or keep every n-th cell with decimate = {} or more",
            step.ceil() as usize
        );
        let (field, value) = match (&spec.crop, spec.decimate) {
            (None, _) => ("crop", "none".to_string()),
            (Some(_), None) => ("decimate", "none (every cell)".to_string()),
            (Some(c), Some(n)) => ("decimate", format!("{n}, crop {c:?}")),
        };
        fail(field, value, format!("{file}: {e}"), &fix)
    })?;
    match source {
        Source::Asc(r) => r.read(&w),
        Source::Tif(r) => r.read(&w),
    }
    .map_err(|e| file_err(format!("'{file}': {e}")))
}

/// The rows and columns of a DEM that `crop` and `decimate` keep: the cells within a cell (of
/// the decimated grid) of the crop box carried back into the file's frame, on the lattice of
/// every `decimate`-th row and column from the north-west corner. Every triangle whose centroid
/// is in the crop box has its corners there, so the crop of the triangles that follows keeps
/// exactly what it would keep of the whole grid.
fn window(spec: &TerrainSpec, h: &dem::Header) -> dem::Window {
    let step = spec.decimate.unwrap_or(1).max(1);
    let Some(c) = &spec.crop else {
        return dem::Window::all(h, step);
    };
    let r = spec.rotation.map(Real::to_radians);
    let back = Rotation::from_euler_angles(r[0], r[1], r[2]).inverse();
    let (s, o) = (Vector::from(spec.scale), Vector::from(spec.offset));
    let (mut lo, mut hi) = ([Real::INFINITY; 2], [Real::NEG_INFINITY; 2]);
    for k in 0..8 {
        let corner = Vector::from(std::array::from_fn::<Real, 3, _>(|a| {
            if k >> a & 1 == 0 { c.min[a] } else { c.max[a] }
        }));
        let p = (back * (corner - o)).component_div(&s);
        for a in 0..2 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    let margin = 2.0 * step as Real * h.cell;
    // Cells (from the west, from the south) whose centres lie in [lo − margin, hi + margin].
    let span = |lo: Real, hi: Real, origin: Real, n: usize| {
        let first = ((lo - margin - origin) / h.cell)
            .ceil()
            .clamp(0.0, n as Real) as usize;
        let end = (((hi + margin - origin) / h.cell).floor() + 1.0).clamp(0.0, n as Real) as usize;
        (first, end.max(first))
    };
    let cols = span(lo[0], hi[0], h.x0, h.ncols);
    let south = span(lo[1], hi[1], h.y0, h.nrows);
    let rows = (h.nrows - south.1, h.nrows - south.0);
    let align = |(a, b): (usize, usize)| (a / step * step, b);
    dem::Window {
        rows: align(rows),
        cols: align(cols),
        step,
    }
}

fn crop_opens_a_solid(
    spec: &TerrainSpec,
    vertices: &[[Real; 3]],
    kept: usize,
    whole: usize,
) -> TerrainError {
    let (lo, hi) = bounds_of(vertices);
    fail(
        "crop",
        format!("{:?}", spec.crop.expect("cropped")),
        format!(
            "cuts the closed mesh open (keeps {kept} of its {whole} triangles): a cut solid is a shell with holes, with no inside"
        ),
        &format!(
            "give a crop box that holds the whole mesh (its placed bounds are {lo:?} to {hi:?}), or remove crop; to keep part of a solid, cut it closed in a mesh tool"
        ),
    )
}

fn crop_keeps_nothing(c: &crate::scene::CropSpec) -> TerrainError {
    fail(
        "crop",
        format!("{c:?}"),
        "keeps no triangle of the placed terrain",
        "give a crop box (scene coordinates, after offset/scale/rotation) that holds part of the terrain",
    )
}

/// x_scene = R·(scale ∘ x_file) + offset, the winding reversed for `flip_normals`, degenerate
/// triangles (a repeated corner or zero area) dropped, exact duplicate corners merged.
fn place(spec: &TerrainSpec, raw: RawMesh) -> (Vec<[Real; 3]>, Vec<[u32; 3]>, usize) {
    let r = spec.rotation.map(Real::to_radians);
    let rot = Rotation::from_euler_angles(r[0], r[1], r[2]);
    let s = Vector::from(spec.scale);
    let o = Vector::from(spec.offset);
    let mut vertices: Vec<[Real; 3]> = raw
        .vertices
        .iter()
        .map(|v| {
            let p = rot * Vector::from(*v).component_mul(&s) + o;
            [p.x, p.y, p.z]
        })
        .collect();
    // Merge exactly equal corners (an STL or an OBJ without shared indices repeats them):
    // the edges' topology is read from the indices.
    let mut order: Vec<u32> = (0..vertices.len() as u32).collect();
    let key = |v: &[Real; 3]| v.map(|x| (x + 0.0).to_bits());
    order.sort_unstable_by_key(|&i| (key(&vertices[i as usize]), i));
    let mut canon: Vec<u32> = (0..vertices.len() as u32).collect();
    for w in order.windows(2) {
        if key(&vertices[w[0] as usize]) == key(&vertices[w[1] as usize]) {
            canon[w[1] as usize] = canon[w[0] as usize];
        }
    }
    let before = raw.triangles.len();
    let triangles: Vec<[u32; 3]> = raw
        .triangles
        .iter()
        .map(|t| {
            let t = t.map(|i| canon[i as usize]);
            if spec.flip_normals {
                [t[0], t[2], t[1]]
            } else {
                t
            }
        })
        .filter(|t| {
            let [a, b, c] = t.map(|i| Vector::from(vertices[i as usize]));
            t[0] != t[1] && t[1] != t[2] && t[0] != t[2] && (b - a).cross(&(c - a)).norm() > 0.0
        })
        .collect();
    let dropped = before - triangles.len();
    vertices.shrink_to_fit();
    (vertices, triangles, dropped)
}

/// Keeps the triangles whose centroid is in the crop box.
fn crop(
    spec: &TerrainSpec,
    vertices: &[[Real; 3]],
    triangles: Vec<[u32; 3]>,
) -> Result<Vec<[u32; 3]>, TerrainError> {
    if triangles.is_empty() {
        return Err(fail(
            "file",
            format!("{:?}", spec.file.display().to_string()),
            "holds only degenerate (zero-area) triangles",
            "give a mesh with area",
        ));
    }
    let Some(c) = &spec.crop else {
        return Ok(triangles);
    };
    let kept: Vec<[u32; 3]> = triangles
        .into_iter()
        .filter(|t| {
            let m = t
                .iter()
                .map(|&i| Vector::from(vertices[i as usize]))
                .sum::<Vector>()
                / 3.0;
            (0..3).all(|k| m[k] >= c.min[k] && m[k] <= c.max[k])
        })
        .collect();
    if kept.is_empty() {
        return Err(crop_keeps_nothing(c));
    }
    Ok(kept)
}

/// Drops unused vertices and renumbers.
fn compact(vertices: Vec<[Real; 3]>, triangles: Vec<[u32; 3]>) -> (Vec<[Real; 3]>, Vec<[u32; 3]>) {
    let mut new = vec![u32::MAX; vertices.len()];
    let mut out = Vec::new();
    let triangles = triangles
        .into_iter()
        .map(|t| {
            t.map(|i| {
                if new[i as usize] == u32::MAX {
                    new[i as usize] = out.len() as u32;
                    out.push(vertices[i as usize]);
                }
                new[i as usize]
            })
        })
        .collect();
    (out, triangles)
}

fn bounds_of(vertices: &[[Real; 3]]) -> ([Real; 3], [Real; 3]) {
    vertices.iter().fold(
        ([Real::INFINITY; 3], [Real::NEG_INFINITY; 3]),
        |(mut lo, mut hi), v| {
            for k in 0..3 {
                lo[k] = lo[k].min(v[k]);
                hi[k] = hi[k].max(v[k]);
            }
            (lo, hi)
        },
    )
}

fn check_bounds(vertices: &[[Real; 3]], domain: &DomainSpec) -> Result<(), TerrainError> {
    let (lo, hi) = bounds_of(vertices);
    if let Some(e) = crate::scene::terrain_reach_problem(lo, hi) {
        return Err(e);
    }
    if (0..3).any(|k| hi[k] < domain.min[k] || lo[k] > domain.max[k]) {
        return Err(fail(
            "offset",
            format!("terrain bounds {lo:?} to {hi:?}"),
            format!(
                "the placed terrain lies outside [domain] ({:?} to {:?})",
                domain.min, domain.max
            ),
            "check offset, scale (the file's units: metres?) and rotation, or move [domain] over the terrain",
        ));
    }
    // Above an open top the water meets no wall (boundary particles end at the top): ground
    // rising higher would let the spray pass through it.
    if domain.open_top && hi[2] > domain.max[2] {
        return Err(fail(
            "offset",
            format!("terrain top z = {} m", readable(hi[2])),
            format!(
                "rises above the open domain top (max[2] = {} m), where the spray would pass through it",
                readable(domain.max[2])
            ),
            "raise [domain] max[2] over the terrain's highest point, or crop the terrain below the top",
        ));
    }
    Ok(())
}

fn check_topology(topo: &topology::Topology) -> Result<(), TerrainError> {
    if let Some((e, n)) = topo.non_manifold {
        return Err(fail(
            "file",
            format!("edge between vertices {} and {}", e[0], e[1]),
            format!("is shared by {n} triangles: the mesh is not a surface (not manifold)"),
            "repair the mesh (remove duplicated or internal faces) so every edge joins at most two triangles",
        ));
    }
    if let Some((a, b)) = topo.inconsistent {
        return Err(fail(
            "file",
            format!("triangles {a} and {b}"),
            format!(
                "{} edge(s) join triangles wound opposite ways: the normals are not consistent (some point into the ground)",
                topo.inconsistent_count
            ),
            "re-export the mesh with consistent outward normals (e.g. 'recalculate normals outside' in the mesh tool)",
        ));
    }
    Ok(())
}

/// A closed mesh encloses positive volume with outward normals; an open surface has the ground
/// under it, so its area-weighted normal points up. Anything else is flipped.
fn check_orientation(
    spec: &TerrainSpec,
    vertices: &[[Real; 3]],
    triangles: &[[u32; 3]],
    closed: bool,
) -> Result<(), TerrainError> {
    let (mut volume, mut area_normal) = (0.0, Vector::zeros());
    for t in triangles {
        let [a, b, c] = t.map(|i| Vector::from(vertices[i as usize]));
        volume += a.dot(&b.cross(&c)) / 6.0;
        area_normal += 0.5 * (b - a).cross(&(c - a));
    }
    let flipped = if closed {
        volume < 0.0
    } else {
        area_normal.z < 0.0
    };
    if flipped {
        let (what, measure) = if closed {
            ("encloses negative volume", format!("{volume:.4e} m³"))
        } else {
            (
                "has its area-weighted normal pointing down",
                format!(
                    "({:.4e}, {:.4e}, {:.4e}) m²",
                    area_normal.x, area_normal.y, area_normal.z
                ),
            )
        };
        let fix = if spec.flip_normals {
            "remove flip_normals = true: the file's normals already point out of the ground"
        } else {
            "set flip_normals = true (or re-export the mesh with normals pointing out of the ground, towards the water)"
        };
        return Err(fail(
            "flip_normals",
            format!("{}", spec.flip_normals),
            format!(
                "the {} mesh {what} ({measure}): its normals point into the ground",
                if closed { "closed" } else { "open" }
            ),
            fix,
        ));
    }
    Ok(())
}

/// An open surface holds water only if its rim is at the domain's sides (or above the domain):
/// elsewhere water runs round the edge and under the ground.
fn check_rim(
    vertices: &[[Real; 3]],
    triangles: &[[u32; 3]],
    rim: &[[u32; 2]],
    domain: &DomainSpec,
) -> Result<(), TerrainError> {
    // A cropped rim lies within one triangle of the crop plane: the longest edge is the slack.
    let mut tol: Real = 0.0;
    for t in triangles {
        for k in 0..3 {
            let (a, b) = (
                Vector::from(vertices[t[k] as usize]),
                Vector::from(vertices[t[(k + 1) % 3] as usize]),
            );
            tol = tol.max((b - a).norm());
        }
    }
    let (lo, hi) = (domain.min, domain.max);
    let sealed = |p: &Vector| {
        p.x <= lo[0] + tol
            || p.x >= hi[0] - tol
            || p.y <= lo[1] + tol
            || p.y >= hi[1] - tol
            || p.z >= hi[2] - tol
    };
    let open: Vec<Vector> = rim
        .iter()
        .map(|e| {
            (Vector::from(vertices[e[0] as usize]) + Vector::from(vertices[e[1] as usize])) * 0.5
        })
        .filter(|m| !sealed(m))
        .collect();
    if let Some(m) = open.first() {
        return Err(fail(
            "file",
            format!("open mesh, {} rim edges", rim.len()),
            format!(
                "the mesh is not closed and {} edge(s) of its rim lie inside the domain, away from its sides (the first at [{:.4}, {:.4}, {:.4}]): water would run round the edge and under the ground",
                open.len(),
                m.x,
                m.y,
                m.z
            ),
            "extend the terrain to the domain's sides (or shrink [domain] to within it, or crop it to the domain), or give a closed mesh",
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests;
