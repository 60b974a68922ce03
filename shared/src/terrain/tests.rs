use super::*;
use crate::scene::CropSpec;
use files::MAX_MESH_TRIANGLES;
use std::path::Path;

/// A scratch folder for a test's files, removed when the returned guard drops.
fn dir(name: &str) -> tempfile::TempDir {
    tempfile::Builder::new()
        .prefix(&format!("rockwave-terrain-{name}-"))
        .tempdir()
        .unwrap()
}

fn spec(file: &Path) -> TerrainSpec {
    toml::from_str(&format!("file = {:?}", file.display().to_string())).unwrap()
}

fn domain(min: [f64; 3], max: [f64; 3]) -> DomainSpec {
    DomainSpec {
        min,
        max,
        open_top: false,
    }
}

/// The eight corners and twelve outward triangles of the box [lo, hi].
fn box_mesh(lo: [f64; 3], hi: [f64; 3]) -> RawMesh {
    let mut vertices = Vec::new();
    for k in 0..8 {
        vertices.push([
            if k & 1 == 0 { lo[0] } else { hi[0] },
            if k & 2 == 0 { lo[1] } else { hi[1] },
            if k & 4 == 0 { lo[2] } else { hi[2] },
        ]);
    }
    let quads = [
        [0, 2, 3, 1], // z = lo, normal −z
        [4, 5, 7, 6], // z = hi, +z
        [0, 1, 5, 4], // y = lo, −y
        [2, 6, 7, 3], // y = hi, +y
        [0, 4, 6, 2], // x = lo, −x
        [1, 3, 7, 5], // x = hi, +x
    ];
    let triangles = quads
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect();
    RawMesh {
        vertices,
        triangles,
    }
}

fn write_stl(path: &Path, m: &RawMesh, ascii: bool) {
    if ascii {
        let mut s = String::from("solid t\n");
        for t in &m.triangles {
            s += " facet normal 0 0 0\n  outer loop\n";
            for &i in t {
                let v = m.vertices[i as usize];
                s += &format!("   vertex {} {} {}\n", v[0], v[1], v[2]);
            }
            s += "  endloop\n endfacet\n";
        }
        s += "endsolid t\n";
        std::fs::write(path, s).unwrap();
    } else {
        let tris: Vec<stl_io::Triangle> = m
            .triangles
            .iter()
            .map(|t| stl_io::Triangle {
                normal: stl_io::Vector::new([0.0; 3]),
                vertices: t.map(|i| {
                    let v = m.vertices[i as usize];
                    stl_io::Vector::new([v[0] as f32, v[1] as f32, v[2] as f32])
                }),
            })
            .collect();
        let mut f = std::fs::File::create(path).unwrap();
        stl_io::write_stl(&mut f, tris.iter()).unwrap();
    }
}

fn write_obj(path: &Path, m: &RawMesh) {
    let mut s = String::new();
    for v in &m.vertices {
        s += &format!("v {} {} {}\n", v[0], v[1], v[2]);
    }
    for t in &m.triangles {
        s += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    std::fs::write(path, s).unwrap();
}

fn write_ply(path: &Path, m: &RawMesh) {
    let mut s = format!(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        m.vertices.len(),
        m.triangles.len()
    );
    for v in &m.vertices {
        s += &format!("{} {} {}\n", v[0], v[1], v[2]);
    }
    for t in &m.triangles {
        s += &format!("3 {} {} {}\n", t[0], t[1], t[2]);
    }
    std::fs::write(path, s).unwrap();
}

/// A closed box read from every mesh format: 12 triangles, closed, the same signed distances.
#[test]
fn a_closed_box_reads_the_same_from_every_mesh_format() {
    let tmp = dir("formats");
    let d = tmp.path();
    let m = box_mesh([0.2, 0.2, 0.0], [0.8, 0.6, 0.5]);
    let files = [
        ("box_ascii.stl", 0),
        ("box_binary.stl", 1),
        ("box.obj", 2),
        ("box.ply", 3),
    ];
    let dom = domain([0.0; 3], [1.0; 3]);
    for (name, kind) in files {
        let p = d.join(name);
        match kind {
            0 => write_stl(&p, &m, true),
            1 => write_stl(&p, &m, false),
            2 => write_obj(&p, &m),
            _ => write_ply(&p, &m),
        }
        let t = Terrain::load(&spec(&p), &dom).unwrap_or_else(|e| panic!("{name}: {e:?}"));
        assert_eq!(t.triangles(), 12, "{name}");
        assert!(t.closed, "{name}");
        let inside = t.nearest(&Point::new(0.5, 0.4, 0.45), Real::MAX).unwrap();
        assert!((inside.distance + 0.05).abs() < 1e-6, "{name}: {inside:?}");
        assert!((inside.normal - Vector::z()).norm() < 1e-6, "{name}");
        // Off a corner: the distance to the corner, pointing away from it.
        let out = t.nearest(&Point::new(0.9, 0.7, 0.6), Real::MAX).unwrap();
        assert!(
            (out.distance - 0.03f64.sqrt()).abs() < 1e-6,
            "{name}: {out:?}"
        );
        assert!(t.contains(&Point::new(0.3, 0.3, 0.1)) && !t.contains(&Point::new(0.1, 0.1, 0.1)));
        assert!(t.summary().contains("12 triangles"));
    }
}

#[test]
fn inward_normals_are_named_and_flip_normals_fixes_them() {
    let tmp = dir("flipped");
    let d = tmp.path();
    let mut m = box_mesh([0.2, 0.2, 0.0], [0.8, 0.6, 0.5]);
    m.triangles.iter_mut().for_each(|t| t.swap(1, 2));
    let p = d.join("inward.obj");
    write_obj(&p, &m);
    let dom = domain([0.0; 3], [1.0; 3]);
    let e = Terrain::load(&spec(&p), &dom).unwrap_err();
    assert_eq!(e.field, "flip_normals");
    assert!(
        e.problem.contains("into the ground") && e.fix.contains("flip_normals = true"),
        "{e:?}"
    );
    let mut s = spec(&p);
    s.flip_normals = true;
    assert!(Terrain::load(&s, &dom).unwrap().closed);
    // One face turned over: not consistent, named by its triangles.
    let mut m = box_mesh([0.2, 0.2, 0.0], [0.8, 0.6, 0.5]);
    m.triangles[3].swap(1, 2);
    write_obj(&p, &m);
    let e = Terrain::load(&spec(&p), &dom).unwrap_err();
    assert!(e.problem.contains("wound opposite ways"), "{e:?}");
}

/// A DEM of a sloped bed: the surface is where the grid says, open, ground under it.
#[test]
fn a_dem_slope_is_an_open_surface_with_ground_under_it() {
    let tmp = dir("dem");
    let d = tmp.path();
    let g = dem::Grid::from_fn(11, 6, 0.0, 0.0, 0.1, |x, _| 0.1 + 0.2 * x);
    let p = d.join("slope.asc");
    std::fs::write(&p, g.to_asc()).unwrap();
    let dom = domain([0.0, 0.0, -0.5], [1.0, 0.5, 1.0]);
    let t = Terrain::load(&spec(&p), &dom).unwrap();
    assert_eq!(t.triangles(), 2 * 10 * 5);
    assert!(!t.closed);
    assert!((t.top_at(0.55, 0.25).unwrap() - 0.21).abs() < 1e-12);
    // 0.1 m straight above the slope z = 0.1 + 0.2x: the distance is 0.1·cos θ.
    let cos = 1.0 / (1.0f64 + 0.04).sqrt();
    let s = t.nearest(&Point::new(0.5, 0.25, 0.3), Real::MAX).unwrap();
    assert!((s.distance - 0.1 * cos).abs() < 1e-12, "{s:?}");
    let s = t.nearest(&Point::new(0.5, 0.25, 0.1), Real::MAX).unwrap();
    assert!((s.distance + 0.1 * cos).abs() < 1e-12, "{s:?}");
    // Transformed: offset and vertical exaggeration.
    let mut sp = spec(&p);
    sp.offset = [0.0, 0.0, -0.1];
    sp.scale = [1.0, 1.0, 2.0];
    let t = Terrain::load(&sp, &dom).unwrap();
    assert!((t.top_at(0.55, 0.25).unwrap() - (2.0 * 0.21 - 0.1)).abs() < 1e-12);
    // Cropped to the west half: its rim is now inside the domain.
    sp.crop = Some(CropSpec {
        min: [0.0, 0.0, -1.0],
        max: [0.5, 0.5, 1.0],
    });
    let e = Terrain::load(&sp, &dom).unwrap_err();
    assert!(
        e.problem.contains("not closed") && e.problem.contains("under the ground"),
        "{e:?}"
    );
    // A domain as small as the crop takes it.
    let small = domain([0.0, 0.0, -0.5], [0.5, 0.5, 1.0]);
    let t = Terrain::load(&sp, &small).unwrap();
    assert_eq!(t.triangles(), 2 * 5 * 5);
}

#[test]
fn dem_holes_are_refused_or_filled_as_asked() {
    let tmp = dir("holes");
    let d = tmp.path();
    let mut g = dem::Grid::from_fn(5, 5, 0.05, 0.05, 0.1, |_, _| 0.2);
    g.z[12] = None;
    let p = d.join("holes.asc");
    std::fs::write(&p, g.to_asc()).unwrap();
    let dom = domain([0.0, 0.0, 0.0], [0.5, 0.5, 1.0]);
    let e = Terrain::load(&spec(&p), &dom).unwrap_err();
    assert_eq!(e.field, "nodata");
    assert!(
        e.problem.contains("refused") && e.fix.contains("nodata = \"fill\""),
        "{e:?}"
    );
    let mut s = spec(&p);
    s.nodata = NoData::Fill;
    let t = Terrain::load(&s, &dom).unwrap();
    assert_eq!(t.filled_cells, 1);
    assert!((t.top_at(0.25, 0.25).unwrap() - 0.2).abs() < 1e-12);
    assert!(t.summary().contains("1 no-data cells filled"));
}

/// A pipe, a device or a directory named as a terrain file is refused at once, by its field,
/// before a read that would block for ever (a FIFO) or never end (/dev/zero).
#[test]
fn a_terrain_path_that_is_not_a_regular_file_is_refused() {
    let tmp = dir("not-regular");
    let fifo = tmp.path().join("pipe.asc");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    let dom = domain([0.0, 0.0, 0.0], [1.0, 1.0, 1.0]);
    // /dev/zero under a terrain's name: reading it would never end.
    let zero = tmp.path().join("zero.stl");
    std::os::unix::fs::symlink("/dev/zero", &zero).unwrap();
    let mut paths = vec![zero, tmp.path().join("folder.asc")];
    std::fs::create_dir(&paths[1]).unwrap();
    if made.is_ok_and(|s| s.success()) {
        paths.push(fifo);
    }
    for p in paths {
        let t0 = std::time::Instant::now();
        let e = Terrain::load(&spec(&p), &dom).unwrap_err();
        assert_eq!(e.field, "file");
        assert!(
            e.problem.contains("not a regular file") && e.fix.contains("regular file"),
            "{}: {e:?}",
            p.display()
        );
        assert!(t0.elapsed().as_secs() < 5);
    }
}

#[test]
fn a_terrain_outside_the_domain_or_above_an_open_top_is_refused() {
    let tmp = dir("outside");
    let d = tmp.path();
    let p = d.join("far.obj");
    write_obj(&p, &box_mesh([100.0, 0.0, 0.0], [101.0, 1.0, 1.0]));
    let e = Terrain::load(&spec(&p), &domain([0.0; 3], [1.0; 3])).unwrap_err();
    assert_eq!(e.field, "offset");
    assert!(
        e.problem.contains("outside [domain]") && e.fix.contains("units"),
        "{e:?}"
    );
    // A closed box reaching 0.5 m above an open top: the spray would pass through it.
    let p = d.join("tall.obj");
    write_obj(&p, &box_mesh([0.2, 0.2, 0.0], [0.4, 0.4, 1.5]));
    let open = DomainSpec {
        open_top: true,
        ..domain([0.0; 3], [1.0; 3])
    };
    let e = Terrain::load(&spec(&p), &open).unwrap_err();
    assert_eq!(e.field, "offset");
    assert!(e.problem.contains("above the open domain top"), "{e:?}");
    assert!(Terrain::load(&spec(&p), &domain([0.0; 3], [1.0; 3])).is_ok());
    let missing =
        Terrain::load(&spec(&d.join("none.stl")), &domain([0.0; 3], [1.0; 3])).unwrap_err();
    assert_eq!(missing.field, "file");
    assert!(missing.problem.contains("cannot open"), "{missing:?}");
}

/// A scene file names its terrain relative to itself; the scene as run holds the absolute path,
/// and the coupler's check reports problems as scene fields.
#[test]
fn scene_paths_are_relative_to_the_scene_file() {
    let tmp = dir("scene");
    let d = tmp.path();
    std::fs::create_dir_all(d.join("site")).unwrap();
    write_obj(
        &d.join("site/box.obj"),
        &box_mesh([0.2, 0.2, 0.0], [0.8, 0.6, 0.5]),
    );
    let text = "name = \"t\"\n[time]\nend = 0.1\n[domain]\nmin = [0, 0, 0]\nmax = [1, 1, 1]\n\
                [[terrain]]\nfile = \"site/box.obj\"\nrotation = [0, 0, 0]\n";
    std::fs::write(d.join("scene.toml"), text).unwrap();
    let scene = Scene::load(&d.join("scene.toml")).unwrap();
    assert!(scene.terrain[0].file.is_absolute());
    assert!(check_scene(&scene).is_empty());
    let again = Scene::parse(&toml::to_string(&scene).unwrap(), "as run").unwrap();
    assert_eq!(again.terrain, scene.terrain);
    let mut bad = scene.clone();
    bad.terrain[0].offset = [50.0, 0.0, 0.0];
    let errs = check_scene(&bad);
    assert_eq!(errs.len(), 1);
    assert_eq!(errs[0].path, "terrain[0].offset");
    // Schema checks need no file; a terrain's name is not a block's.
    let clash = format!(
        "{text}[[block]]\nname = \"terrain\"\nkind = \"fixed\"\nshape = {{ type = \"box\", min = [0, 0, 0], max = [1, 1, 0.1] }}\n"
    );
    let e = Scene::parse(&clash, "t").unwrap_err();
    assert!(e.to_string().contains("terrain[0].name"), "{e}");
    // decimate: at least 1, and for DEMs only.
    for (line, problem) in [
        ("decimate = 0", "at least 1"),
        ("decimate = 2", "DEMs (.asc, .tif) only"),
    ] {
        let e = Scene::parse(&text.replace("rotation = [0, 0, 0]", line), "t").unwrap_err();
        let e = e.to_string();
        assert!(
            e.contains("terrain[0].decimate") && e.contains(problem) && e.contains("fix:"),
            "{e}"
        );
    }
    let e = Scene::parse(&text.replace("site/box.obj", "site/box.dxf"), "t").unwrap_err();
    assert!(e.to_string().contains("terrain[0].file"), "{e}");
    let e = Scene::parse(
        &text.replace("rotation = [0, 0, 0]", "scale = [1, 0, 1]"),
        "t",
    )
    .unwrap_err();
    assert!(e.to_string().contains("terrain[0].scale"), "{e}");
}

/// A GeoTIFF `[[terrain]]` is the same surface as its ESRI ASCII twin.
#[test]
fn a_geotiff_terrain_is_the_same_surface_as_its_ascii_twin() {
    use super::geotiff::tests::{ascii_twin, temp, write};
    let z: Vec<f32> = (0..12).map(|i| i as f32 * 0.5 - 1.0).collect();
    let path = temp("twin-terrain");
    write(&path, &z, None, false);
    let asc = ascii_twin(&z);
    let asc_path = path.with_extension("asc");
    std::fs::write(&asc_path, &asc).unwrap();
    let domain = DomainSpec {
        min: [1005.0, 2005.0, -10.0],
        max: [1035.0, 2025.0, 10.0],
        open_top: false,
    };
    let load = |p: &Path| {
        let spec = toml::from_str(&format!("file = {:?}", p.display().to_string())).unwrap();
        Terrain::load(&spec, &domain).unwrap()
    };
    let (t, a) = (load(&path), load(&asc_path));
    assert_eq!(t.triangles(), a.triangles());
    for (x, y) in [(1012.0, 2011.0), (1030.0, 2020.0)] {
        assert_eq!(t.top_at(x, y), a.top_at(x, y));
    }
    std::fs::remove_file(&path).unwrap();
    std::fs::remove_file(&asc_path).unwrap();
}

/// Mesh files that lie about their size are refused from their length, before they are parsed:
/// a binary STL cut short, 10 GB of zeros (sparse: nothing is written) as a binary or ASCII
/// STL, 100 MB of zeros after a text mesh's first line (one line that never ends), a binary STL
/// whose count is past MAX_MESH_TRIANGLES, a PLY header claiming 10¹² vertices in a few bytes.
#[test]
fn mesh_files_that_lie_about_their_size_are_refused_from_their_length() {
    let tmp = dir("lying-meshes");
    let d = tmp.path();
    let dom = domain([0.0; 3], [1.0; 3]);
    let sized = |name: &str, head: &[u8], len: u64| {
        let p = d.join(name);
        std::fs::write(&p, head).unwrap();
        std::fs::OpenOptions::new()
            .write(true)
            .open(&p)
            .unwrap()
            .set_len(len)
            .unwrap();
        p
    };
    let short = d.join("short.stl");
    write_stl(&short, &box_mesh([0.2, 0.2, 0.0], [0.8, 0.6, 0.5]), false);
    let len = std::fs::metadata(&short).unwrap().len();
    let short = sized("short.stl", &std::fs::read(&short).unwrap(), len - 10);
    let mut count = [0u8; 84];
    count[80..].copy_from_slice(&(MAX_MESH_TRIANGLES as u32 + 1).to_le_bytes());
    let cases = [
        (short, "claims 12 triangles (684 bytes), but the file is 674 bytes"),
        (
            sized("zeros.stl", b"", 10 << 30),
            "past the 2147483648-byte limit of a terrain mesh (MAX_MESH_FILE_BYTES",
        ),
        (
            sized("zeros_ascii.stl", b"solid x\n", 10 << 30),
            "MAX_MESH_FILE_BYTES",
        ),
        (sized("endless.stl", b"solid x\n", 100 << 20), "MAX_LINE_BYTES"),
        (sized("zeros.obj", b"v 0 0 0\n", 100 << 20), "MAX_LINE_BYTES"),
        (
            sized("zeros.ply", b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n", 100 << 20),
            "MAX_LINE_BYTES",
        ),
        (
            sized("many.stl", &count, 84 + 50 * (MAX_MESH_TRIANGLES as u64 + 1)),
            "holds 8000001 triangles, past the limit of 8000000 (MAX_MESH_TRIANGLES)",
        ),
        (
            sized(
                "huge.ply",
                b"ply\nformat ascii 1.0\nelement vertex 1000000000000\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n3 0 0 0\n",
                184,
            ),
            "claims elements of 3000000000001 values in all",
        ),
    ];
    for (p, claim) in cases {
        let t0 = std::time::Instant::now();
        let e = Terrain::load(&spec(&p), &dom).unwrap_err();
        assert_eq!(e.field, "file");
        assert!(
            e.problem.contains(claim) && !e.problem.contains("fix:") && e.fix.len() > 20,
            "{}: {e:?}",
            p.display()
        );
        assert!(t0.elapsed().as_millis() < 500, "{}", p.display());
    }
}

/// A DEM of `ncols` × `nrows` cells of 2 m with a hill on it, as an ESRI grid and as its
/// GeoTIFF twin (strips of 7 rows), south-west centre at (1001, 2001).
fn hill(d: &Path, ncols: usize, nrows: usize) -> (dem::Grid, [std::path::PathBuf; 2]) {
    let f = |x: f64, y: f64| 3.0 + ((x - 1030.0) * 0.1).sin() * ((y - 2020.0) * 0.07).cos();
    let g = dem::Grid::from_fn(ncols, nrows, 1001.0, 2001.0, 2.0, f);
    let asc = d.join("hill.asc");
    std::fs::write(&asc, g.to_asc()).unwrap();
    let tif = d.join("hill.tif");
    let north = 2000.0 + 2.0 * nrows as f64;
    let z: Vec<f32> = g.z.iter().map(|v| v.unwrap() as f32).collect();
    geotiff::write(
        &tif,
        (ncols as u32, nrows as u32),
        [1000.0, north],
        2.0,
        7,
        true,
        &z,
    )
    .unwrap();
    (g, [asc, tif])
}

/// What the load keeps of a DEM (placed, cropped, compacted) given its grid.
fn kept(spec: &TerrainSpec, mut grid: dem::Grid) -> (Vec<[Real; 3]>, Vec<[u32; 3]>) {
    grid.resolve(NoData::Refuse).unwrap();
    let (v, t, _) = place(spec, grid.triangulate());
    let t = crop(spec, &v, t).unwrap();
    compact(v, t)
}

/// A DEM cropped while it is read (rotated, scaled and moved) keeps exactly the triangles and
/// vertices the whole grid cropped keeps, from far fewer cells, for both formats; decimated,
/// it is the grid of every n-th cell.
#[test]
fn a_dem_cropped_while_read_keeps_what_the_whole_grid_cropped_keeps() {
    let tmp = dir("crop-window");
    let (_, files) = hill(tmp.path(), 60, 45);
    for file in &files {
        let mut s = spec(file);
        // The grid's centre (1060, 2045), rotated 20° about z, to (32, 40).
        s.offset = [-264.64, -2244.21, 0.0];
        s.rotation = [0.0, 0.0, 20.0];
        s.scale = [1.0, 1.0, 2.0];
        s.crop = Some(CropSpec {
            min: [20.0, 30.0, -10.0],
            max: [45.0, 50.0, 20.0],
        });
        let format = TerrainFormat::of(file).unwrap();
        let window = read_dem(&s, format).unwrap();
        assert!(window.z.len() * 4 < 60 * 45, "{}", window.z.len());
        let whole = if format == TerrainFormat::GeoTiff {
            geotiff::read(file)
        } else {
            dem::read(file)
        }
        .unwrap();
        let (a, b) = (kept(&s, window), kept(&s, whole));
        assert!(!a.1.is_empty());
        assert_eq!(a, b, "{}", file.display());
    }
    // Every 3rd row and column of the 60 × 45 grid: 20 × 15 cells of 6 m.
    let mut s = spec(&files[1]);
    s.decimate = Some(3);
    let g = read_dem(&s, TerrainFormat::GeoTiff).unwrap();
    assert_eq!((g.ncols, g.nrows), (20, 15));
    let coarse = dem::Grid::from_fn(20, 15, 0.0, 0.0, 1.0, |_, _| 0.0);
    let (x0, y0) = g.centre(14, 0);
    assert_eq!((x0, y0), (1001.0, 2001.0 + 2.0 * 2.0));
    assert_eq!(g.centre(0, 19), (1001.0 + 57.0 * 2.0, 2001.0 + 44.0 * 2.0));
    assert_eq!(g.z.len(), coarse.z.len());
}

/// A deflate bomb: a GeoTIFF of a few hundred kilobytes whose 8192 × 8192 cells (64 M) decode
/// to 256 MB is refused from its header, before a strip is decoded, naming the fix; cropped to
/// a small window it loads, decoding only the strips there.
#[test]
fn a_deflate_bomb_geotiff_is_refused_before_it_is_decoded() {
    let tmp = dir("bomb");
    let p = tmp.path().join("bomb.tif");
    let n = 8192;
    geotiff::write(
        &p,
        (n, n),
        [0.0, n as f64],
        1.0,
        256,
        true,
        &vec![0.0; (n * n) as usize],
    )
    .unwrap();
    assert!(std::fs::metadata(&p).unwrap().len() < 4 << 20);
    let dom = domain([0.0, 0.0, -1.0], [50.0, 40.0, 1.0]);
    let t0 = std::time::Instant::now();
    let e = Terrain::load(&spec(&p), &dom).unwrap_err();
    assert_eq!(e.field, "crop");
    assert!(
        e.problem.contains("keeps 8192 × 8192 = 67108864 cells")
            && e.problem.contains("MAX_DEM_CELLS")
            && e.fix.contains("decimate = 5"),
        "{e:?}"
    );
    assert!(t0.elapsed().as_millis() < 100);
    let mut s = spec(&p);
    s.crop = Some(CropSpec {
        min: [0.0, 0.0, -1.0],
        max: [50.0, 40.0, 1.0],
    });
    let t0 = std::time::Instant::now();
    let t = Terrain::load(&s, &dom).unwrap();
    assert!(t.triangles() > 2 * 45 * 35 && t.triangles() < 2 * 55 * 45);
    assert!(t0.elapsed().as_millis() < 500);
}

/// A crop that cuts a closed mesh leaves a shell with holes: refused, naming the bounds a crop
/// must hold; a crop that holds the whole mesh keeps it closed.
#[test]
fn a_crop_that_cuts_a_closed_mesh_open_is_refused() {
    let tmp = dir("crop-solid");
    let p = tmp.path().join("box.obj");
    write_obj(&p, &box_mesh([0.2, 0.2, 0.0], [0.8, 0.6, 0.5]));
    let dom = domain([0.0; 3], [1.0; 3]);
    let mut s = spec(&p);
    s.crop = Some(CropSpec {
        min: [0.0, 0.0, 0.0],
        max: [0.5, 1.0, 1.0],
    });
    let e = Terrain::load(&s, &dom).unwrap_err();
    assert_eq!(e.field, "crop");
    assert!(
        e.problem.contains("cuts the closed mesh open")
            && e.fix.contains("[0.2, 0.2, 0.0] to [0.8, 0.6, 0.5]"),
        "{e:?}"
    );
    s.crop = Some(CropSpec {
        min: [0.1, 0.1, -0.1],
        max: [0.9, 0.9, 0.9],
    });
    assert!(Terrain::load(&s, &dom).unwrap().closed);
}

/// A free block inside a closed terrain mesh, or under a DEM, is refused at check, named by
/// its block; one above the ground passes.
#[test]
fn a_free_block_inside_the_ground_is_refused() {
    let tmp = dir("buried");
    let d = tmp.path();
    write_obj(
        &d.join("box.obj"),
        &box_mesh([0.2, 0.2, 0.0], [0.8, 0.6, 0.5]),
    );
    let g = dem::Grid::from_fn(11, 11, 0.0, 0.0, 0.1, |_, _| 0.3);
    std::fs::write(d.join("flat.asc"), g.to_asc()).unwrap();
    for (file, rock) in [
        ("box.obj", "min = [0.4, 0.3, 0.1], max = [0.5, 0.4, 0.2]"),
        ("flat.asc", "min = [0.4, 0.4, 0.05], max = [0.5, 0.5, 0.15]"),
    ] {
        let scene = |rock: &str| {
            let text = format!(
                "name = \"t\"\n[time]\nend = 0.1\n[domain]\nmin = [0, 0, 0]\nmax = [1, 1, 1]\n\
                 [[terrain]]\nfile = \"{file}\"\n\
                 [[block]]\nname = \"rock\"\nkind = \"free\"\nshape = {{ type = \"box\", {rock} }}\n"
            );
            std::fs::write(d.join("scene.toml"), text).unwrap();
            Scene::load(&d.join("scene.toml")).unwrap()
        };
        let errs = check_scene(&scene(rock));
        assert_eq!(errs.len(), 1, "{file}: {errs:?}");
        assert_eq!(errs[0].path, "block[0].shape");
        assert!(
            errs[0].problem.contains("inside the ground of terrain[0]")
                && errs[0].fix.contains("move the block out of the ground"),
            "{file}: {:?}",
            errs[0]
        );
        let above = "min = [0.4, 0.3, 0.7], max = [0.5, 0.4, 0.8]";
        assert!(check_scene(&scene(above)).is_empty(), "{file}");
    }
}
