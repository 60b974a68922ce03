//! The coupler's command line on bad input: clear errors, nothing written.

use std::process::Command;

fn coupler() -> Command {
    Command::new(env!("CARGO_BIN_EXE_coupler"))
}

fn temp(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("rockwave-cli-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn check_accepts_the_default_scene() {
    let o = coupler().arg("check").output().unwrap();
    assert!(o.status.success());
    assert!(String::from_utf8_lossy(&o.stdout).contains("sliding_wedge"));
}

/// Every scene in the repository passes `coupler check`, solver tables included.
#[test]
fn every_repository_scene_passes_check() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes");
    let mut files = Vec::new();
    for dir in [root.clone(), root.join("validation")] {
        for e in std::fs::read_dir(dir).unwrap().flatten() {
            if e.path().extension().is_some_and(|x| x == "toml") {
                files.push(e.path());
            }
        }
    }
    assert!(files.len() >= 5, "{files:?}");
    for f in files {
        let o = coupler().arg("check").arg(&f).output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{}: {err}", f.display());
    }
}

/// A bad value in a solver's own table is named with its field and line by `coupler run`
/// before any node starts, and nothing is written.
#[test]
fn bad_solver_parameter_is_named_before_any_node_starts() {
    let dir = temp("params");
    let scene = dir.join("p.toml");
    let text = format!(
        "{}\n[fluid.wcsph]\nintegrator = \"verlet\"\ngamma = nan\n\n[solid.explicit]\nsafety_factor = 0.0\n",
        shared::scene::DEFAULT_SCENE
    );
    std::fs::write(&scene, &text).unwrap();
    let gamma = text.lines().position(|l| l == "gamma = nan").unwrap() + 1;
    let safety = text
        .lines()
        .position(|l| l == "safety_factor = 0.0")
        .unwrap()
        + 1;
    let out = dir.join("run");
    let o = coupler()
        .arg("run")
        .arg(&scene)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains(&format!("line {gamma}: fluid.wcsph.gamma"))
            && err.contains(&format!("line {safety}: solid.explicit.safety_factor"))
            && err.contains("fix:"),
        "{err}"
    );
    assert!(!out.exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn malformed_scene_names_field_line_and_fix_and_writes_nothing() {
    let dir = temp("bad");
    let scene = dir.join("bad.toml");
    let text = shared::scene::DEFAULT_SCENE.replace("\ndx = 0.04\n", "\ndx = -0.04\n");
    std::fs::write(&scene, &text).unwrap();
    let line = text.lines().position(|l| l == "dx = -0.04").unwrap() + 1;
    let out = dir.join("run");
    let o = coupler()
        .arg("run")
        .arg(&scene)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("fluid.dx") && err.contains(&format!("line {line}")) && err.contains("fix:"),
        "{err}"
    );
    assert!(!out.exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn syntax_error_and_unknown_field_are_reported() {
    let dir = temp("syntax");
    let scene = dir.join("s.toml");
    std::fs::write(
        &scene,
        shared::scene::DEFAULT_SCENE.replace("[time]\n", "[time]\nendd = 2.0\n"),
    )
    .unwrap();
    let o = coupler().arg("check").arg(&scene).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1));
    assert!(err.contains("endd") && err.contains("line"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn impossible_geometry_is_refused() {
    let dir = temp("geom");
    let scene = dir.join("g.toml");
    // A "convex" block with a vertex inside the hull.
    let text = format!(
        "{}\n[[block]]\nname = \"dent\"\nkind = \"fixed\"\nshape = {{ type = \"convex\", vertices = [[0,0,0],[1,0,0],[0,1,0],[0,0,1],[0.1,0.1,0.1]] }}\n",
        shared::scene::DEFAULT_SCENE
    );
    std::fs::write(&scene, text).unwrap();
    let o = coupler().arg("check").arg(&scene).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        err.contains("block[6].shape") && err.contains("not convex"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn existing_run_directory_is_never_overwritten() {
    let dir = temp("exists");
    std::fs::write(dir.join("precious.csv"), "keep me").unwrap();
    let o = coupler()
        .arg("run")
        .arg("--out")
        .arg(&dir)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("already exists"), "{err}");
    assert_eq!(
        std::fs::read_to_string(dir.join("precious.csv")).unwrap(),
        "keep me"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bad_overrides_are_named() {
    let o = coupler().args(["run", "--dx=-1"]).output().unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--dx"));
    let o = coupler()
        .args(["run", "--step-timeout=-3"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--step-timeout"));
    let o = coupler()
        .args(["run", "--scheme", "sideways"])
        .output()
        .unwrap();
    assert_ne!(o.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&o.stderr).contains("sideways"));
}
