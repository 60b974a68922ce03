//! `coupler check` and `coupler run` with a `[[terrain]]`: the terrain is reported (triangles,
//! bounds), a bad terrain file is refused before any node starts, naming the field and the fix.

use std::process::Command;

fn coupler() -> Command {
    Command::new(env!("CARGO_BIN_EXE_coupler"))
}

#[test]
fn check_reports_the_fjord_terrain() {
    let scene = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/fjord.toml");
    let o = coupler().arg("check").arg(&scene).output().unwrap();
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(out.contains("1 terrain(s)"), "{out}");
    assert!(
        out.contains("terrain 'valley': 13000 triangles")
            && out.contains("bounds [0.0000, 0.0000, -40.0000] to [400.0000, 260.0000"),
        "{out}"
    );
}

#[test]
fn a_terrain_with_inward_normals_is_refused_by_check_and_run() {
    let d = std::env::temp_dir().join(format!("rockwave-cli-terrain-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(d.join("site")).unwrap();
    // flip_normals on a DEM (whose normals are right by construction) turns them into the
    // ground: the load finds it and says to remove it.
    let grid = shared::terrain::dem::Grid::from_fn(11, 11, 0.0, 0.0, 0.1, |x, _| 0.1 * x);
    std::fs::write(d.join("site/bed.asc"), grid.to_asc()).unwrap();
    let scene = d.join("scene.toml");
    std::fs::write(
        &scene,
        "name = \"t\"\n[time]\nend = 0.1\n[domain]\nmin = [0, 0, -1]\nmax = [1, 1, 1]\n\
         [[terrain]]\nfile = \"site/bed.asc\"\nflip_normals = true\n",
    )
    .unwrap();
    let o = coupler().arg("check").arg(&scene).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("terrain[0].flip_normals")
            && err.contains("point into the ground")
            && err.contains("line 9"),
        "{err}"
    );
    let out = d.join("run");
    let o = coupler()
        .arg("run")
        .arg(&scene)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(!out.exists(), "a refused run wrote {}", out.display());
    let _ = std::fs::remove_dir_all(&d);
}
