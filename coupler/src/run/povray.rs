//! POV-Ray export, as the paper rendered its figures: one scene file per output frame, built
//! from the run directory's VTK frames (particles as spheres, blocks as triangle meshes), and
//! rendered to PNG when `povray` is installed (Debian package `povray`).

use shared::math::readable;
use shared::scene::Scene;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Points and polygons read back from one of our .vtp files.
#[derive(Debug, Default)]
pub struct PolyData {
    pub points: Vec<[f64; 3]>,
    pub polys: Vec<Vec<usize>>,
    /// Block kind of each polygon when the file has it (0 fixed, 1 kinematic, 2 free).
    pub kind: Vec<f64>,
}

/// What to do about a frame that reads but does not hold together.
const DAMAGED_FIX: &str = "the file is damaged (cut short or overwritten). Fix: restore it, or run \
     the scene again; a frame can be left out by removing its line from particles.pvd or blocks.pvd";

/// Reads a PolyData frame that `shared::vtk` writes, binary or ASCII. Its polygons are checked
/// against its points: a damaged file (a polygon naming a point past the last) panicked in
/// [`scene_file`] instead of naming the file.
pub fn read_vtp(path: &Path) -> Result<PolyData, String> {
    let file =
        shared::vtk::read_vtp(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let array = |section: &str, name: &str| file.array(section, name).map(|a| &a.values);
    let coords = array("Points", "Points")
        .ok_or_else(|| format!("{}: no points", path.display()))?
        .to_f64();
    if coords.len() % 3 != 0 {
        return Err(format!(
            "{}: {} point coordinates, not three per point: {DAMAGED_FIX}",
            path.display(),
            coords.len()
        ));
    }
    let points: Vec<[f64; 3]> = coords.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    let polys = match (array("Polys", "connectivity"), array("Polys", "offsets")) {
        (Some(conn), Some(offsets)) => polygons(&conn.to_f64(), &offsets.to_f64(), points.len())
            .map_err(|e| format!("{}: {e}: {DAMAGED_FIX}", path.display()))?,
        _ => Vec::new(),
    };
    let kind = array("CellData", "kind")
        .map(|k| k.to_f64())
        .unwrap_or_default();
    Ok(PolyData {
        points,
        polys,
        kind,
    })
}

/// The polygons of `connectivity` cut at `offsets` (each polygon's end), every index a point of
/// the `points` there are; the error says which polygon is wrong and how.
fn polygons(
    connectivity: &[f64],
    offsets: &[f64],
    points: usize,
) -> Result<Vec<Vec<usize>>, String> {
    let index = |v: f64| (v >= 0.0 && v.fract() == 0.0).then_some(v as usize);
    let mut polys = Vec::with_capacity(offsets.len());
    let mut start = 0usize;
    for (k, &end) in offsets.iter().enumerate() {
        let face = index(end)
            .filter(|&end| end >= start)
            .and_then(|end| connectivity.get(start..end))
            .ok_or_else(|| {
                format!(
                    "polygon {k} ends at offset {}, outside {start}..={} (the connectivity's length)",
                    readable(end),
                    connectivity.len()
                )
            })?;
        let mut poly = Vec::with_capacity(face.len());
        for &v in face {
            match index(v).filter(|&i| i < points) {
                Some(i) => poly.push(i),
                None => {
                    let have = match points {
                        0 => "no points".to_string(),
                        n => format!("{n} points, numbered 0 to {}", n - 1),
                    };
                    return Err(format!(
                        "polygon {k} names point {}, but the file has {have}",
                        readable(v)
                    ));
                }
            }
        }
        polys.push(poly);
        start += face.len();
    }
    Ok(polys)
}

/// Writes the .pov scene of one frame: camera framing the domain from the front-left, water
/// particles as blue spheres of radius dx/2, blocks as grey triangle meshes, the terrain (the
/// run's `terrain.vtp`) as an opaque ground.
pub fn scene_file(
    scene: &Scene,
    particles: Option<&PolyData>,
    blocks: Option<&PolyData>,
    terrain: Option<&PolyData>,
    time: f64,
) -> String {
    let (lo, hi) = (scene.domain.min, scene.domain.max);
    let centre = [
        (lo[0] + hi[0]) / 2.0,
        (lo[1] + hi[1]) / 2.0,
        (lo[2] + hi[2]) / 3.0,
    ];
    let size = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
    // POV-Ray is y-up and left-handed: write <x, z, y>.
    let v = |p: [f64; 3]| format!("<{:.5},{:.5},{:.5}>", p[0], p[2], p[1]);
    let eye = [
        centre[0] - 0.25 * size,
        centre[1] - 0.9 * size,
        centre[2] + 0.7 * size,
    ];
    let mut s = String::new();
    let _ = writeln!(
        s,
        "// rockwave frame at t = {time:.4} s, scene '{}'",
        scene.name
    );
    let _ = writeln!(s, "#version 3.7;\nglobal_settings {{ assumed_gamma 1.0 }}");
    let _ = writeln!(s, "background {{ rgb <0.92, 0.94, 0.97> }}");
    let _ = writeln!(
        s,
        "camera {{ location {} look_at {} angle 50 }}",
        v(eye),
        v(centre)
    );
    let _ = writeln!(
        s,
        "light_source {{ {} color rgb 1.0 }}",
        v([eye[0], eye[1] - size, eye[2] + 2.0 * size])
    );
    let _ = writeln!(
        s,
        "light_source {{ {} color rgb 0.4 shadowless }}",
        v([hi[0] + size, lo[1] - size, hi[2] + size])
    );
    if let (Some(p), Some(fluid)) = (particles, scene.fluid.as_ref()) {
        let r = 0.5 * fluid.dx;
        let _ = writeln!(
            s,
            "#declare Water = texture {{ pigment {{ rgb <0.15, 0.45, 0.85> }} finish {{ phong 0.4 }} }}"
        );
        s.push_str("union {\n");
        for q in &p.points {
            let _ = writeln!(s, "sphere {{ {}, {r:.5} }}", v(*q));
        }
        s.push_str("texture { Water } }\n");
    }
    if let Some(t) = terrain {
        let mut mesh = String::new();
        for poly in &t.polys {
            for k in 1..poly.len().saturating_sub(1) {
                let (p0, p1, p2) = (t.points[poly[0]], t.points[poly[k]], t.points[poly[k + 1]]);
                let _ = writeln!(mesh, "triangle {{ {}, {}, {} }}", v(p0), v(p1), v(p2));
            }
        }
        if !mesh.is_empty() {
            let _ = writeln!(
                s,
                "mesh {{\n{mesh}texture {{ pigment {{ rgb <0.62, 0.6, 0.52> }} finish {{ diffuse 0.8 }} }} }}"
            );
        }
    }
    if let Some(b) = blocks {
        // Walls, slopes and beaches are drawn as faint glass so they do not hide the water;
        // moving rock is drawn solid.
        let fixed = |i: usize| b.kind.get(i).is_none_or(|&k| k == 0.0);
        for (want_fixed, texture) in [
            (
                true,
                "texture { pigment { rgbt <0.7, 0.68, 0.64, 0.8> } finish { diffuse 0.6 } }",
            ),
            (
                false,
                "texture { pigment { rgb <0.55, 0.35, 0.25> } finish { diffuse 0.8 } }",
            ),
        ] {
            let mut mesh = String::new();
            for (_, poly) in b
                .polys
                .iter()
                .enumerate()
                .filter(|(i, _)| fixed(*i) == want_fixed)
            {
                for k in 1..poly.len().saturating_sub(1) {
                    let (p0, p1, p2) =
                        (b.points[poly[0]], b.points[poly[k]], b.points[poly[k + 1]]);
                    let _ = writeln!(mesh, "triangle {{ {}, {}, {} }}", v(p0), v(p1), v(p2));
                }
            }
            if !mesh.is_empty() {
                let _ = writeln!(s, "mesh {{\n{mesh}{texture} }}");
            }
        }
    }
    s
}

/// Runs `coupler povray` on a run directory; returns the process exit code.
pub fn run(run_dir: &Path, render: bool, width: u32, height: u32) -> u8 {
    match export(run_dir, render, width, height) {
        Ok(files) => {
            println!(
                "wrote {} POV-Ray frame(s) in {}",
                files.len(),
                run_dir.join("povray").display()
            );
            0
        }
        Err(e) => {
            eprintln!("coupler: error: {e}");
            1
        }
    }
}

/// Writes `povray/frame_NNNNN.pov` for every frame in the run directory's .pvd series and, when
/// `render` is set, renders each to PNG with `povray`. Returns the scene files written.
pub fn export(
    run_dir: &Path,
    render: bool,
    width: u32,
    height: u32,
) -> Result<Vec<PathBuf>, String> {
    let scene = Scene::load(&run_dir.join("scene.toml")).map_err(|e| e.to_string())?;
    let frames = pvd_frames(&run_dir.join("particles.pvd"));
    let block_frames = pvd_frames(&run_dir.join("blocks.pvd"));
    let times: Vec<f64> = if frames.is_empty() {
        block_frames.iter().map(|f| f.0).collect()
    } else {
        frames.iter().map(|f| f.0).collect()
    };
    if times.is_empty() {
        return Err(format!(
            "{} has no frames (particles.pvd / blocks.pvd)",
            run_dir.display()
        ));
    }
    if render && which("povray").is_none() {
        return Err("rendering needs POV-Ray: install it (Debian: apt-get install povray), or export without --render".into());
    }
    let out = run_dir.join("povray");
    let terrain_file = run_dir.join("terrain.vtp");
    let terrain = terrain_file
        .is_file()
        .then(|| read_vtp(&terrain_file))
        .transpose()?;
    let mut written = Vec::new();
    for (i, &t) in times.iter().enumerate() {
        let particles = frames
            .get(i)
            .map(|f| read_vtp(&run_dir.join(&f.1)))
            .transpose()?;
        let blocks = block_frames
            .iter()
            .find(|f| (f.0 - t).abs() < 1e-9)
            .map(|f| read_vtp(&run_dir.join(&f.1)))
            .transpose()?;
        if written.is_empty() {
            // Once the first frame has been read: a damaged one leaves nothing behind.
            std::fs::create_dir_all(&out)
                .map_err(|e| format!("cannot create {}: {e}", out.display()))?;
        }
        let path = out.join(format!("frame_{i:05}.pov"));
        std::fs::write(
            &path,
            scene_file(
                &scene,
                particles.as_ref(),
                blocks.as_ref(),
                terrain.as_ref(),
                t,
            ),
        )
        .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        if render {
            let status = std::process::Command::new("povray")
                .arg(format!("+I{}", path.display()))
                .arg(format!("+O{}", path.with_extension("png").display()))
                .args([
                    format!("+W{width}"),
                    format!("+H{height}"),
                    "-D".into(),
                    "+A0.3".into(),
                    "-GA".into(),
                ])
                .stdout(std::process::Stdio::null())
                .stderr(std::process::Stdio::null())
                .status()
                .map_err(|e| format!("cannot run povray: {e}"))?;
            if !status.success() {
                return Err(format!("povray failed on {}", path.display()));
            }
        }
        written.push(path);
    }
    Ok(written)
}

/// (time, file) pairs of a .pvd collection.
pub fn pvd_frames(path: &Path) -> Vec<(f64, String)> {
    let Ok(text) = std::fs::read_to_string(path) else {
        return Vec::new();
    };
    text.lines()
        .filter_map(|l| {
            let t = l
                .split("timestep=\"")
                .nth(1)?
                .split('"')
                .next()?
                .parse()
                .ok()?;
            let f = l.split("file=\"").nth(1)?.split('"').next()?.to_string();
            Some((t, f))
        })
        .collect()
}

fn which(program: &str) -> Option<PathBuf> {
    std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|d| d.join(program))
            .find(|p| p.is_file())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared::scene::VtkFormat;

    /// Polygons that do not fit their points or their connectivity are named, not indexed.
    #[test]
    fn polygons_past_their_points_or_connectivity_are_named() {
        let conn = [0.0, 1.0, 2.0, 2.0, 1.0, 3.0];
        assert_eq!(
            polygons(&conn, &[3.0, 6.0], 4),
            Ok(vec![vec![0, 1, 2], vec![2, 1, 3]])
        );
        for (conn, offsets, says) in [
            (
                &conn[..],
                &[3.0, 6.0][..],
                "polygon 1 names point 3, but the file has 3 points",
            ),
            (
                &[0.0, -1.0, 2.0][..],
                &[3.0][..],
                "polygon 0 names point -1",
            ),
            (
                &[0.0, 1.5, 2.0][..],
                &[3.0][..],
                "polygon 0 names point 1.5",
            ),
            (
                &conn[..],
                &[3.0, 7.0][..],
                "polygon 1 ends at offset 7, outside 3..=6",
            ),
            (&conn[..], &[3.0, 2.0][..], "polygon 1 ends at offset 2"),
            (&conn[..], &[1e300][..], "polygon 0 ends at offset 1e300"),
        ] {
            let points = if says.contains("3 points") { 3 } else { 4 };
            let e = polygons(conn, offsets, points).unwrap_err();
            assert!(e.contains(says), "{says}: {e}");
        }
    }

    #[test]
    fn reads_back_what_vtk_writes() {
        let dir = std::env::temp_dir().join(format!("rockwave-pov-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let verts = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let faces = vec![vec![0, 2, 1], vec![0, 1, 3], vec![0, 3, 2], vec![1, 2, 3]];
        for format in [VtkFormat::Ascii, VtkFormat::Binary] {
            shared::vtk::write_polyhedra(&dir.join("b.vtp"), &[(&verts, &faces)], &[], format)
                .unwrap();
            let b = read_vtp(&dir.join("b.vtp")).unwrap();
            assert_eq!(b.points.len(), 4);
            assert_eq!(
                b.polys,
                vec![vec![0, 2, 1], vec![0, 1, 3], vec![0, 3, 2], vec![1, 2, 3]]
            );
        }
        let b = read_vtp(&dir.join("b.vtp")).unwrap();
        let scene = Scene::default_scene();
        let pov = scene_file(&scene, None, Some(&b), None, 0.5);
        assert_eq!(pov.matches("triangle").count(), 4);
        assert!(pov.contains("camera"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
