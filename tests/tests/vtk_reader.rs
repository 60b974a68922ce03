//! Our VTK output read by a reader nobody here wrote: VTK's own Python package (`pip install
//! vtk`, see `.ci/run`) reads a coarse default-scene run's `.pvd` series and every frame, once
//! with binary frames (the default) and once with `output.vtk_format = "ascii"`, through
//! `tests/scripts/read_run.py`. Both must give the particle count of `summary.json`, the arrays
//! ParaView users rely on, polygons for the blocks, and the very same numbers.
//!
//! Without python3 or its `vtk` module the test fails when `CI` is set and is skipped (with a
//! message) otherwise. `ROCKWAVE_PYTHON` names the interpreter (default `python3`).

mod common;
use common::*;
use serde_json::Value;
use std::path::Path;
use std::process::Command;

fn python() -> String {
    std::env::var("ROCKWAVE_PYTHON").unwrap_or_else(|_| "python3".into())
}

/// True when the interpreter imports `vtk`; otherwise fails under CI or says why it skips.
fn have_vtk() -> bool {
    let py = python();
    let why = match Command::new(&py).args(["-c", "import vtk"]).output() {
        Ok(o) if o.status.success() => return true,
        Ok(o) => format!(
            "`{py} -c 'import vtk'` failed: {}",
            String::from_utf8_lossy(&o.stderr).trim()
        ),
        Err(e) => format!("cannot start `{py}`: {e}"),
    };
    let fix =
        "install it with `python3 -m pip install vtk` (as .ci/run does) or set ROCKWAVE_PYTHON";
    if std::env::var_os("CI").is_some() {
        panic!("CI is set and VTK's Python package is unavailable: {why}; {fix}");
    }
    eprintln!("SKIPPED vtk_reader: VTK's Python package is unavailable: {why}; {fix}");
    false
}

/// Runs the default scene coarse into a fresh directory with `vtk_format`; returns the directory.
fn coarse_run(format: &str) -> std::path::PathBuf {
    let (id, dir) = fresh(&format!("vtk-{format}"));
    let default = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/sliding_wedge.toml");
    let text = std::fs::read_to_string(&default).unwrap();
    assert_eq!(
        text.matches("\n[output]\n").count(),
        1,
        "{}",
        default.display()
    );
    let text = text.replace(
        "\n[output]\n",
        &format!("\n[output]\nvtk_format = \"{format}\"\n"),
    );
    let scene = std::env::temp_dir().join(format!("rockwave-vtk-{format}-{id}.toml"));
    std::fs::write(&scene, text).unwrap();
    let o = run(coupler(
        &id,
        &dir,
        &[scene.to_str().unwrap(), "--dx", "0.08", "--end", "0.1"],
    ));
    assert!(o.status.success(), "{format} run: {}", stderr(&o));
    assert!(leftovers(&id).is_empty());
    std::fs::remove_file(&scene).unwrap();
    dir
}

/// What VTK read, as JSON.
fn read_with_vtk(dir: &Path) -> Value {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/read_run.py");
    let o = Command::new(python())
        .arg(&script)
        .arg(dir)
        .output()
        .expect("python starts");
    assert!(
        o.status.success(),
        "read_run.py {}: {}",
        dir.display(),
        String::from_utf8_lossy(&o.stderr)
    );
    serde_json::from_slice(&o.stdout).expect("read_run.py prints JSON")
}

/// The particle count: summary.json's `fluid.particles`, else the ASCII frame's header.
fn particle_count(dir: &Path) -> u64 {
    let summary: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    if let Some(n) = summary["fluid"]["particles"].as_u64() {
        return n;
    }
    let text = std::fs::read_to_string(dir.join("particles_00000.vtp")).unwrap();
    text.split("NumberOfPoints=\"")
        .nth(1)
        .unwrap()
        .split('"')
        .next()
        .unwrap()
        .parse()
        .unwrap()
}

fn check_run(dir: &Path, read: &Value, format: &str) {
    let n = particle_count(dir);
    let particles = read["series"]["particles.pvd"]["frames"]
        .as_array()
        .expect("particles.pvd read");
    // Frames at t = 0, 0.05 and 0.1.
    assert_eq!(particles.len(), 3, "{format}: {particles:?}");
    for f in particles {
        let file = f["file"].as_str().unwrap();
        assert_eq!(f["class"], "vtkPolyData", "{format} {file}");
        assert_eq!(
            f["points"].as_u64(),
            Some(n),
            "{format} {file}: point count"
        );
        assert_eq!(
            f["verts"].as_u64(),
            Some(n),
            "{format} {file}: vertex cells"
        );
        for (name, components) in [("density", 1), ("pressure", 1), ("velocity", 3)] {
            let a = &f["point_data"][name];
            assert_eq!(a["components"], components, "{format} {file}: {name}: {a}");
            assert_eq!(a["tuples"].as_u64(), Some(n), "{format} {file}: {name}");
        }
        let rho = f["point_data"]["density"]["first"][0][0].as_f64().unwrap();
        assert!(
            (900.0..1100.0).contains(&rho),
            "{format} {file}: density {rho}"
        );
        // The file is in the encoding asked for.
        let raw = std::fs::read(dir.join(file)).unwrap();
        let header = String::from_utf8_lossy(&raw[..raw.len().min(4096)]).into_owned();
        let expected = if format == "binary" {
            "format=\"appended\""
        } else {
            "format=\"ascii\""
        };
        assert!(header.contains(expected), "{format} {file}: {header}");
    }
    let blocks = read["series"]["blocks.pvd"]["frames"]
        .as_array()
        .expect("blocks.pvd read");
    assert_eq!(blocks.len(), 3, "{format}: {blocks:?}");
    for f in blocks {
        assert!(f["points"].as_u64().unwrap() > 0, "{format}: {f}");
        assert!(
            f["polys"].as_u64().unwrap() > 0,
            "{format}: block frame without polygons"
        );
        assert_eq!(f["cell_data"]["kind"]["components"], 1, "{format}: {f}");
    }
    // VTK's numbers are ours: the first points of the last frame, bit for bit, from our reader.
    let last = particles.last().unwrap();
    let ours = shared::vtk::read_vtp(&dir.join(last["file"].as_str().unwrap())).unwrap();
    let coords = ours.array("Points", "Points").unwrap().values.to_f64();
    // (Bit patterns, not JSON floats: serde_json's default float parsing may be 1 ulp off.)
    for (k, p) in last["first_points_bits"]
        .as_array()
        .unwrap()
        .iter()
        .enumerate()
    {
        for c in 0..3 {
            let theirs = p[c].as_u64().unwrap();
            assert_eq!(theirs, coords[3 * k + c].to_bits(), "{format}: point {k}");
        }
    }
}

#[test]
fn vtk_reads_binary_and_ascii_runs_alike() {
    if !have_vtk() {
        return;
    }
    let binary = coarse_run("binary");
    let ascii = coarse_run("ascii");
    let (b, a) = (read_with_vtk(&binary), read_with_vtk(&ascii));
    check_run(&binary, &b, "binary");
    check_run(&ascii, &a, "ascii");
    // Same run, two encodings: every count, name, sample value and exact sum VTK reports agrees.
    assert_eq!(
        b["series"], a["series"],
        "binary and ASCII frames read differently"
    );
    std::fs::remove_dir_all(&binary).unwrap();
    std::fs::remove_dir_all(&ascii).unwrap();
}
