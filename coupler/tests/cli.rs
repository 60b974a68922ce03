//! The coupler's command line on bad input: clear errors, nothing written.

use shared::math::long_number;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn coupler() -> Command {
    Command::new(env!("CARGO_BIN_EXE_coupler"))
}

/// `Command::output` with a deadline: a command that hangs fails its test (killed, named)
/// instead of holding the whole test run until CI's time limit.
trait OutputWithin {
    fn output_within(&mut self, limit: Duration) -> Output;
}

impl OutputWithin for Command {
    fn output_within(&mut self, limit: Duration) -> Output {
        let mut child = self
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // Drained while the command runs, so a chatty one never blocks on a full pipe.
        let drain = |mut r: Box<dyn std::io::Read + Send>| {
            std::thread::spawn(move || {
                let mut v = Vec::new();
                let _ = r.read_to_end(&mut v);
                v
            })
        };
        let out = drain(Box::new(child.stdout.take().unwrap()));
        let err = drain(Box::new(child.stderr.take().unwrap()));
        let start = Instant::now();
        let status = loop {
            if let Some(s) = child.try_wait().unwrap() {
                break s;
            }
            if start.elapsed() > limit {
                let _ = child.kill();
                let _ = child.wait();
                panic!("{self:?} did not end within {limit:?}; killed");
            }
            std::thread::sleep(Duration::from_millis(20));
        };
        Output {
            status,
            stdout: out.join().unwrap(),
            stderr: err.join().unwrap(),
        }
    }
}

/// Long enough for any command here on a loaded machine; short beside CI's limit.
const LIMIT: Duration = Duration::from_secs(120);

/// A scratch folder for a test's files, removed when the guard drops (also on a failed assert).
struct Temp(tempfile::TempDir);

impl std::ops::Deref for Temp {
    type Target = std::path::Path;
    fn deref(&self) -> &std::path::Path {
        self.0.path()
    }
}

impl AsRef<std::path::Path> for Temp {
    fn as_ref(&self) -> &std::path::Path {
        self.0.path()
    }
}

impl AsRef<std::ffi::OsStr> for Temp {
    fn as_ref(&self) -> &std::ffi::OsStr {
        self.0.path().as_os_str()
    }
}

fn temp(name: &str) -> Temp {
    Temp(
        tempfile::Builder::new()
            .prefix(&format!("rockwave-cli-{name}-"))
            .tempdir()
            .unwrap(),
    )
}

#[test]
fn check_accepts_the_default_scene() {
    let o = coupler().arg("check").output_within(LIMIT);
    assert!(o.status.success());
    assert!(String::from_utf8_lossy(&o.stdout).contains("sliding_wedge"));
}

/// `coupler run scene --out dir/run`, which must be refused (exit 1) having written nothing;
/// returns its error output.
fn refused_run(scene: &std::path::Path, dir: &std::path::Path) -> String {
    let out = dir.join("run");
    let o = coupler()
        .arg("run")
        .arg(scene)
        .arg("--out")
        .arg(&out)
        .output_within(LIMIT);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(!out.exists(), "{} was written", out.display());
    assert!(
        long_number(&err).is_none(),
        "a number of many digits: {err}"
    );
    err
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
        let o = coupler().arg("check").arg(&f).output_within(LIMIT);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{}: {err}", f.display());
    }
}

/// `scene` with `line` in its `[fluid.wcsph]` table: added to the table where the scene has one
/// (the default scene does; a second table of that name would be a TOML error, not the field's).
fn with_wcsph(scene: &str, line: &str) -> String {
    const TABLE: &str = "\n[fluid.wcsph]\n";
    if scene.contains(TABLE) {
        scene.replacen(TABLE, &format!("{TABLE}{line}\n"), 1)
    } else {
        format!("{scene}{TABLE}{line}\n")
    }
}

/// A bad value in a solver's own table is named with its field and line by `coupler run`
/// before any node starts, and nothing is written.
#[test]
fn bad_solver_parameter_is_named_before_any_node_starts() {
    let dir = temp("params");
    let scene = dir.join("p.toml");
    let text = format!(
        "{}\n[solid.explicit]\nsafety_factor = 0.0\n",
        with_wcsph(
            shared::scene::DEFAULT_SCENE,
            "integrator = \"verlet\"\ngamma = nan"
        )
    );
    std::fs::write(&scene, &text).unwrap();
    let gamma = text.lines().position(|l| l == "gamma = nan").unwrap() + 1;
    let safety = text
        .lines()
        .position(|l| l == "safety_factor = 0.0")
        .unwrap()
        + 1;
    let err = refused_run(&scene, &dir);
    assert!(
        err.contains(&format!("line {gamma}: fluid.wcsph.gamma"))
            && err.contains(&format!("line {safety}: solid.explicit.safety_factor"))
            && err.contains("fix:"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn malformed_scene_names_field_line_and_fix_and_writes_nothing() {
    let dir = temp("bad");
    let scene = dir.join("bad.toml");
    let text = shared::scene::DEFAULT_SCENE.replace("\ndx = 0.04\n", "\ndx = -0.04\n");
    std::fs::write(&scene, &text).unwrap();
    let line = text.lines().position(|l| l == "dx = -0.04").unwrap() + 1;
    let err = refused_run(&scene, &dir);
    assert!(
        err.contains("fluid.dx") && err.contains(&format!("line {line}")) && err.contains("fix:"),
        "{err}"
    );
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
    let o = coupler().arg("check").arg(&scene).output_within(LIMIT);
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
    let o = coupler().arg("check").arg(&scene).output_within(LIMIT);
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
        .output_within(LIMIT);
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
    let o = coupler().args(["run", "--dx=-1"]).output_within(LIMIT);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--dx"));
    let o = coupler()
        .args(["run", "--step-timeout=-3"])
        .output_within(LIMIT);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--step-timeout"));
    // --dt-max goes through the scene's own check of time.dt_max.
    let o = coupler().args(["run", "--dt-max=-1"]).output_within(LIMIT);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("dt_max"), "{err}");
    // So does --added-mass, through [coupling] added_mass.
    for bad in ["--added-mass=-1", "--added-mass=NaN"] {
        let o = coupler().args(["run", bad]).output_within(LIMIT);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{bad}: {err}");
        assert!(err.contains("coupling.added_mass"), "{bad}: {err}");
    }
    let o = coupler()
        .args(["run", "--scheme", "sideways"])
        .output_within(LIMIT);
    assert_ne!(o.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&o.stderr).contains("sideways"));
    for (args, named) in [
        (&["--checkpoint-interval", "0"][..], "--checkpoint-interval"),
        (
            &["--checkpoint-wall-minutes", "nan"][..],
            "--checkpoint-wall-minutes",
        ),
        (&["--attach", "--retries", "2"][..], "--retries"),
    ] {
        let o = coupler().arg("run").args(args).output_within(LIMIT);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        assert!(
            err.contains(named) && err.contains("Fix"),
            "{args:?}: {err}"
        );
    }
    // --resume continues a run as it was: it takes no scene-changing flag, and needs a run.
    let dir = temp("resume");
    let o = coupler()
        .args(["run", "--dx", "0.1", "--resume"])
        .arg(&dir)
        .output_within(LIMIT);
    assert_ne!(o.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--dx"));
    let o = coupler()
        .args(["run", "--dt-max", "0.002", "--resume"])
        .arg(&dir)
        .output_within(LIMIT);
    assert_ne!(o.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--dt-max"));
    let o = coupler()
        .args(["run", "--resume"])
        .arg(&dir)
        .output_within(LIMIT);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("no scene.toml"), "{err}");
}

/// The default scene plus `extra`, written to `dir/name.toml`; returns the path and the line
/// number of the line that holds `needle` (the last one).
fn scene_with(
    dir: &std::path::Path,
    name: &str,
    text: &str,
    needle: &str,
) -> (std::path::PathBuf, usize) {
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, text).unwrap();
    let line = text
        .lines()
        .enumerate()
        .filter(|(_, l)| l.contains(needle))
        .map(|(i, _)| i + 1)
        .last()
        .unwrap_or_else(|| panic!("{name}: no line holds {needle:?}"));
    (path, line)
}

/// Bad values in the solvers' own tables, and scenes too big for this machine, are refused by
/// `coupler check` naming the field and its line.
#[test]
fn solver_tables_and_sizes_are_refused_by_check_naming_field_and_line() {
    let dir = temp("tables");
    let d = shared::scene::DEFAULT_SCENE;
    let cases: Vec<(&str, String, &str, &str)> = vec![
        (
            "gamma_nan",
            with_wcsph(d, "gamma = nan"),
            "fluid.wcsph.gamma",
            "gamma = nan",
        ),
        (
            "sound_zero",
            with_wcsph(d, "sound_speed = 0.0"),
            "fluid.wcsph.sound_speed",
            "sound_speed",
        ),
        // Below 2·sqrt(2 g H) for the default scene's water: the column at rest is compressed
        // past the density bound before the first step (`wcsph::sound_speed`).
        (
            "sound_too_low",
            with_wcsph(d, "sound_speed = 1.0"),
            "fluid.wcsph.sound_speed",
            "sound_speed",
        ),
        (
            "riemann_sound_too_low",
            format!("{d}\n[fluid.riemann]\nsound_speed = 1.0\n"),
            "fluid.riemann.sound_speed",
            "sound_speed",
        ),
        (
            "smoothing_neg",
            with_wcsph(d, "smoothing_ratio = -1.3"),
            "fluid.wcsph.smoothing_ratio",
            "smoothing_ratio",
        ),
        (
            "cfl_inf",
            with_wcsph(d, "cfl = inf"),
            "fluid.wcsph.cfl",
            "cfl",
        ),
        (
            "skin_too_big",
            with_wcsph(d, "skin = 2.5"),
            "fluid.wcsph.skin",
            "skin",
        ),
        (
            "support_zero",
            format!("{d}\n[fluid.muller]\nsupport_ratio = 0.0\n"),
            "fluid.muller.support_ratio",
            "support_ratio",
        ),
        (
            "stiffness_nan",
            format!("{d}\n[fluid.muller]\nstiffness = nan\n"),
            "fluid.muller.stiffness",
            "stiffness",
        ),
        (
            "unknown_table",
            format!("{d}\n[fluid.sph2]\ngamma = 7.0\n"),
            "fluid.sph2",
            "[fluid.sph2]",
        ),
        (
            "safety_zero",
            format!("{d}\n[solid.explicit]\nsafety_factor = 0.0\n"),
            "solid.explicit.safety_factor",
            "safety_factor",
        ),
        (
            "limit_neg",
            format!("{d}\n[solid.implicit]\ndisplacement_limit = -1.0\n"),
            "solid.implicit.displacement_limit",
            "displacement_limit",
        ),
        (
            "dx_tiny",
            d.replace("\ndx = 0.04\n", "\ndx = 1e-300\n"),
            "fluid.dx",
            "dx = 1e-300",
        ),
        (
            "dx_fine",
            d.replace("\ndx = 0.04\n", "\ndx = 1e-3\n"),
            "fluid.dx",
            "dx = 1e-3",
        ),
    ];
    let mut failures = Vec::new();
    for (name, text, field, needle) in &cases {
        let (path, line) = scene_with(&dir, name, text, needle);
        let o = coupler().arg("check").arg(&path).output_within(LIMIT);
        let err = String::from_utf8_lossy(&o.stderr);
        if o.status.code() != Some(1)
            || !err.contains(&format!("line {line}: {field}"))
            || !err.contains("fix:")
        {
            failures.push(format!("{name}: expected line {line}: {field}; got {err}"));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A spacing that cannot fit in this machine's memory is refused before anything is written,
/// whether given by --dx or chosen by --target-error, with the estimate and the spacing that fits.
#[test]
fn runs_too_big_for_the_machine_are_refused_before_anything_is_allocated() {
    let dir = temp("sizes");
    for flags in [["--dx", "1e-3"], ["--target-error", "1e-9"]] {
        let out = dir.join("run");
        let o = coupler()
            .arg("run")
            .args(flags)
            .arg("--out")
            .arg(&out)
            .output_within(LIMIT);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert!(
            err.contains("fluid.dx") && err.contains("GB of memory") && err.contains("use dx >="),
            "{err}"
        );
        assert!(!out.exists());
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A run estimated to crawl fails `check` and is refused by `run`, naming the field and
/// `--allow-long`; with `--allow-long` the check passes. Bad scene paths and slide files are
/// named by both commands.
#[test]
fn crawling_runs_and_paths_that_are_no_scene_are_refused() {
    let dir = temp("crawl");
    let scene = dir.join("crawl.toml");
    let text =
        shared::scene::DEFAULT_SCENE.replacen("dt_max = 1e-3", "dt_max = 1e-9\ndt_min = 1e-12", 1);
    std::fs::write(&scene, text).unwrap();
    let o = coupler().arg("check").arg(&scene).output_within(LIMIT);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("time.dt_max = 1e-9") && err.contains("--allow-long"),
        "{err}"
    );
    let o = coupler()
        .args(["check", "--allow-long"])
        .arg(&scene)
        .output_within(LIMIT);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let err = refused_run(&scene, &dir);
    assert!(err.contains("time.dt_max = 1e-9"), "{err}");
    for cmd in ["check", "run"] {
        let o = coupler().args([cmd, "/dev/zero"]).output_within(LIMIT);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert!(err.contains("'/dev/zero' is not a regular file"), "{err}");
    }
    let o = coupler()
        .args(["check", "--slides-vtk"])
        .arg(dir.as_ref() as &std::path::Path)
        .output_within(LIMIT);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("not a regular file"), "{err}");
}

#[test]
fn out_pointing_at_a_file_says_it_is_a_file() {
    let dir = temp("outfile");
    let file = dir.join("results.txt");
    std::fs::write(&file, "keep me").unwrap();
    let o = coupler()
        .arg("run")
        .arg("--out")
        .arg(&file)
        .output_within(LIMIT);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("is a file"), "{err}");
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "keep me");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The pids of `pid`'s children.
fn children(pid: u32) -> Vec<u32> {
    std::fs::read_to_string(format!("/proc/{pid}/task/{pid}/children"))
        .unwrap_or_default()
        .split_whitespace()
        .filter_map(|s| s.parse().ok())
        .collect()
}

/// Running (not ended, not a zombie waiting to be reaped).
fn running(pid: u32) -> bool {
    std::fs::read_to_string(format!("/proc/{pid}/stat")).is_ok_and(|s| {
        s.rsplit_once(')')
            .and_then(|(_, rest)| rest.split_whitespace().next())
            .is_some_and(|state| state != "Z" && state != "X")
    })
}

fn sigkill(child: &mut std::process::Child) {
    // SAFETY: kill(2) on our own, not yet reaped child.
    unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGKILL) };
    let _ = child.wait();
}

fn wait_until(what: &str, timeout_s: f64, mut ok: impl FnMut() -> bool) {
    let start = std::time::Instant::now();
    while !ok() {
        assert!(
            start.elapsed().as_secs_f64() < timeout_s,
            "timed out waiting: {what}"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
}

/// A second run on the id of a live run is refused, naming the live run's pid, and leaves the
/// first run alone; once the first coupler is killed (SIGKILL), the id is free again.
#[test]
fn a_live_run_id_is_refused_and_a_killed_one_is_free_again() {
    let dir = temp("runid");
    let id = format!("clilock{}", std::process::id());
    let mut first = coupler()
        .args([
            "run", "--quiet", "--dx", "0.08", "--end", "30", "--run-id", &id, "--out",
        ])
        .arg(dir.join("first"))
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    wait_until("the first run's nodes", 10.0, || {
        children(first.id()).len() == 2
    });
    let o = coupler()
        .args([
            "run", "--quiet", "--dx", "0.08", "--end", "0.1", "--run-id", &id, "--out",
        ])
        .arg(dir.join("second"))
        .output_within(LIMIT);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains(&format!("run id {id} is in use"))
            && err.contains(&format!("pid {}", first.id())),
        "{err}"
    );
    assert!(!dir.join("second").exists());
    assert!(
        first.try_wait().unwrap().is_none(),
        "the first run was disturbed"
    );
    let nodes = children(first.id());
    sigkill(&mut first);
    // Its nodes leave at once (they watch their parent), and the id is free.
    wait_until("the killed run's nodes to leave", 5.0, || {
        !nodes.iter().any(|&p| running(p))
    });
    let o = coupler()
        .args([
            "run", "--quiet", "--dx", "0.08", "--end", "0.02", "--run-id", &id, "--out",
        ])
        .arg(dir.join("third"))
        .output_within(LIMIT);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Nodes started by a coupler that dies during start-up leave at once, not after their
/// 60 s connect timeout.
#[test]
fn nodes_leave_when_their_coupler_dies_during_start_up() {
    let dir = temp("startup");
    let id = format!("clistart{}", std::process::id());
    let mut c = coupler()
        .args(["run", "--quiet", "--run-id", &id, "--out"])
        .arg(dir.join("run"))
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    wait_until("the nodes to start", 10.0, || children(c.id()).len() == 2);
    let nodes = children(c.id());
    sigkill(&mut c);
    wait_until("the orphaned nodes to leave", 5.0, || {
        !nodes.iter().any(|&p| running(p))
    });
    let _ = coupler().args(["clean", &id]).output_within(LIMIT);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A node stuck inside the transport during start-up (here: told to stall before its hello)
/// gives up once start-up outlasts twice its connect timeout plus the watchdog's grace, naming
/// the cause and the fix, instead of living on without a coupler.
#[test]
fn a_node_stuck_in_start_up_gives_up_and_says_why() {
    let node = std::path::Path::new(env!("CARGO_BIN_EXE_coupler")).with_file_name("solid-node");
    let id = format!("clistuck{}", std::process::id());
    let start = Instant::now();
    let o = Command::new(node)
        .args([
            "--prefix",
            &id,
            "--connect-timeout",
            "0.2",
            "--stall-startup",
        ])
        .output_within(LIMIT);
    let took = start.elapsed().as_secs_f64();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(
        err.contains("start-up did not finish within 10.4 s"),
        "{err}"
    );
    assert!(err.contains(&format!("coupler clean {id}")), "{err}");
    assert!((10.3..40.0).contains(&took), "gave up after {took:.1} s");
    let _ = coupler().args(["clean", &id]).output_within(LIMIT);
}

/// A node that finds no coupler names the flag form of the attach command.
#[test]
fn a_lonely_node_names_the_attach_command() {
    let node = std::path::Path::new(env!("CARGO_BIN_EXE_coupler")).with_file_name("fluid-node");
    let id = format!("clilonely{}", std::process::id());
    let o = Command::new(node)
        .args(["--prefix", &id, "--connect-timeout", "0.3"])
        .output_within(LIMIT);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains(&format!("coupler run --attach --run-id {id}")),
        "{err}"
    );
    let _ = coupler().args(["clean", &id]).output_within(LIMIT);
}

/// `coupler check | head -1`: the reader closes the pipe after its first line, and the check
/// ends quietly (by SIGPIPE, as Unix filters do), not with a panic and a backtrace.
#[test]
fn check_into_a_closed_pipe_ends_quietly() {
    use std::os::fd::FromRawFd;
    use std::os::unix::process::ExitStatusExt;
    // A pipe whose reader is closed before the check starts: its first line meets it.
    let mut fds = [0; 2];
    // SAFETY: `pipe` fills the two descriptors; the read end is closed once, the write end
    // owned by the `OwnedFd` handed to the child as its stdout.
    let stdout = unsafe {
        assert_eq!(libc::pipe(fds.as_mut_ptr()), 0);
        libc::close(fds[0]);
        std::os::fd::OwnedFd::from_raw_fd(fds[1])
    };
    let out = coupler()
        .arg("check")
        .stdout(Stdio::from(stdout))
        .stderr(Stdio::piped())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(
        out.status.signal(),
        Some(libc::SIGPIPE),
        "{:?}: {err}",
        out.status
    );
}

/// `coupler ARGS`, which must be refused with exit code `code`, no panic and nothing at `out`;
/// returns its error output.
fn refused(args: &[&str], code: i32, out: &std::path::Path) -> String {
    let o = coupler().args(args).output_within(LIMIT);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(code), "{args:?}: {err}");
    assert!(!err.contains("panicked"), "{args:?}: {err}");
    assert!(!out.exists(), "{args:?}: {} was written", out.display());
    assert!(
        long_number(&err).is_none(),
        "{args:?}: a number of many digits: {err}"
    );
    err
}

/// Run flags that got through and then failed late or badly are refused by name, with the fix,
/// before the run directory exists: a checkpoint interval that hung the coupler, a wall interval
/// past `Duration`'s range (a panic), a solver no node offers (found by the node, after the run
/// directory was made), a dt factor that would never end, a timeout no healthy node meets.
#[test]
fn run_flags_that_failed_late_are_refused_before_anything_is_written() {
    let dir = temp("late");
    let out = dir.join("run");
    let o = out.to_str().unwrap();
    let wall = dir.join("wall.toml");
    std::fs::write(
        &wall,
        shared::scene::DEFAULT_SCENE.replacen(
            "[output]\n",
            "[output]\ncheckpoint_wall_minutes = 1e300\n",
            1,
        ),
    )
    .unwrap();
    let cases: &[(&[&str], &[&str])] = &[
        (
            &["--checkpoint-interval", "1e-300"],
            &["--checkpoint-interval 1e-300", "time.dt_min", "Fix"],
        ),
        (
            &["--checkpoint-wall-minutes", "1e300"],
            &["--checkpoint-wall-minutes 1e300", "Fix"],
        ),
        (
            &[wall.to_str().unwrap()],
            &["output.checkpoint_wall_minutes 1e300", "in [output]"],
        ),
        (
            &["--fluid-solver", "wcsphx"],
            &["--fluid-solver 'wcsphx'", "wcsph, muller", "Fix"],
        ),
        (
            &["--solid-solver", ""],
            &["--solid-solver ''", "explicit, implicit"],
        ),
        (
            &["--dt-factor", "1e-300"],
            &["--dt-factor 1e-300", "crawl", "--allow-long"],
        ),
        (&["--step-timeout", "1e-300"], &["--step-timeout", "Fix"]),
        (
            &["--connect-timeout", "0.01"],
            &["--connect-timeout", "Fix"],
        ),
        (&["--setup-timeout", "0.5"], &["--setup-timeout", "Fix"]),
    ];
    for (flags, says) in cases {
        let args = [
            &["run", "--quiet", "--dx", "0.08", "--end", "0.05"],
            *flags,
            &["--out", o],
        ]
        .concat();
        let err = refused(&args, 1, &out);
        for s in *says {
            assert!(err.contains(s), "{flags:?}: no {s:?} in {err}");
        }
    }
    // A node of one's own may offer solvers the built-in ones do not: its name is its own.
    let o2 = coupler()
        .args([
            "run",
            "--quiet",
            "--dx",
            "0.08",
            "--end",
            "0.05",
            "--fluid-cmd",
            "/bin/true",
        ])
        .args(["--fluid-solver", "lite", "--out", o])
        .output_within(LIMIT);
    let err = String::from_utf8_lossy(&o2.stderr);
    assert!(err.contains("'/bin/true' exited"), "{err}");
}

/// `coupler check --dx` checks the scene at that spacing as `coupler run --dx` does: a
/// spacing coarser than the domain was called valid.
#[test]
fn check_at_another_spacing_refuses_what_run_refuses() {
    let o = coupler()
        .args(["check", "--dx", "1e300"])
        .output_within(LIMIT);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("--dx 1e300") && err.contains("fluid.dx = 1e300") && err.contains("fix:"),
        "{err}"
    );
}

/// A misspelt `--only` of `chart` and `stability` ran nothing, said nothing and exited 0.
#[test]
fn a_misspelt_chart_or_map_is_named_with_those_there_are() {
    let dir = temp("only");
    let out = dir.join("charts");
    for (cmd, bad, good) in [
        ("chart", "fluids", "loads"),
        ("stability", "dtt", "damping"),
    ] {
        let err = refused(
            &[cmd, "--only", bad, "--out", out.to_str().unwrap()],
            2,
            &out,
        );
        assert!(
            err.contains(&format!("'{bad}'")) && err.contains(good),
            "{cmd}: {err}"
        );
    }
}

/// `coupler spread`'s arguments for its runs (after `--`) are checked as `coupler run` checks
/// them before the first run: a bad one failed every member in turn, and the spread exited 0.
#[test]
fn a_spreads_bad_run_arguments_are_named_before_any_run() {
    let dir = temp("spread");
    for (words, says) in [
        (&["--end", "nan"][..], "time.end = NaN"),
        (&["--quiet"][..], "'--quiet' cannot be used multiple times"),
        (&["--fluid-solver", "x"][..], "--fluid-solver 'x'"),
        (&["--step-timeout", "0"][..], "--step-timeout"),
    ] {
        let out = dir.join(words.join("_"));
        let o = coupler()
            .args(["spread", "--vary", "fluid.wcsph.alpha=0,0.01", "--out"])
            .arg(&out)
            .arg("--")
            .args(words)
            .output_within(LIMIT);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{words:?}: {err}");
        assert!(
            err.contains(&format!("-- {}", words.join(" "))) && err.contains(says),
            "{words:?}: {err}"
        );
        assert!(!out.join("runs/00").exists(), "{words:?}: a member ran");
    }
}

/// Every file under `dir` with its bytes, by path: what a refused command must leave as it was.
fn files_under(dir: &std::path::Path) -> std::collections::BTreeMap<std::path::PathBuf, Vec<u8>> {
    let mut found = std::collections::BTreeMap::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                todo.push(p);
            } else {
                found.insert(p.clone(), std::fs::read(&p).unwrap());
            }
        }
    }
    found
}

/// Whether the fluid node beside the coupler says it was built without MPI
/// (`fluid-node --ranks-support`); one built with MPI (`--features tests/mpi`) says so, and the
/// tests of the refusal have nothing to check.
fn node_built_without_mpi() -> bool {
    let node = std::path::Path::new(env!("CARGO_BIN_EXE_coupler")).with_file_name("fluid-node");
    let o = Command::new(&node)
        .arg("--ranks-support")
        .output_within(LIMIT);
    let said = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(o.status.success(), "{said}");
    if said.starts_with("MPI ranks: yes") {
        return false;
    }
    assert!(
        said.starts_with("MPI ranks: no: built without MPI"),
        "{said}"
    );
    true
}

/// More than one fluid rank on a fluid node built without MPI failed only once the launcher had
/// started the node: after the run directory was made, and, under `--resume`, after the run had
/// been cut back to its checkpoint (its last frame and table rows lost). The node is asked first
/// (`fluid-node --ranks-support`), and the run refused with its fix before anything is written.
/// A node built with MPI (`--features tests/mpi`) says so, and only that answer is checked.
#[test]
fn ranks_on_a_node_built_without_mpi_are_refused_before_anything_is_written() {
    if !node_built_without_mpi() {
        return;
    }
    let dir = temp("nompi");
    let out = dir.join("run");
    let o = out.to_str().unwrap();
    let says = [
        "cannot run as 2 MPI ranks: built without MPI",
        "--features fluid-node/mpi",
        "--fluid-ranks 1",
    ];
    let quick = ["--quiet", "--dx", "0.08", "--end", "0.05"];
    let err = refused(
        &[&["run"][..], &quick, &["--fluid-ranks", "2", "--out", o]].concat(),
        1,
        &out,
    );
    for s in ["--fluid-ranks 2: ", says[0], says[1], says[2]] {
        assert!(err.contains(s), "no {s:?} in {err}");
    }
    // The scene's own `[fluid] ranks` is named as such.
    let scene = two_ranks_scene(&dir);
    let err = refused(
        &[&["run", scene.to_str().unwrap()][..], &quick, &["--out", o]].concat(),
        1,
        &out,
    );
    assert!(
        err.contains("[fluid] ranks = 2: ") && err.contains(says[0]),
        "{err}"
    );
    // A finished run with checkpoints, resumed on two ranks: every file stays as it was.
    let done = dir.join("done");
    let run = coupler()
        .arg("run")
        .args(quick)
        .args(["--checkpoint-interval", "0.02", "--out"])
        .arg(&done)
        .output_within(LIMIT);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let before = files_under(&done);
    assert!(before.keys().any(|p| p.ends_with("particles_00001.vtp")));
    let err = refused(
        &[
            "run",
            "--resume",
            done.to_str().unwrap(),
            "--fluid-ranks",
            "2",
        ],
        1,
        &out,
    );
    assert!(err.contains(says[0]), "{err}");
    assert!(
        files_under(&done) == before,
        "the resumed run's files changed"
    );
}

/// `coupler check --fluid-ranks 2` did not ask the fluid node, as `coupler run` does: it called
/// the ranks fine on a node built without MPI that `run` then refused. It refuses them with
/// `run`'s message, as it does the scene's `[fluid] ranks`; one rank still passes.
#[test]
fn check_refuses_ranks_on_a_node_built_without_mpi_as_run_does() {
    if !node_built_without_mpi() {
        return;
    }
    let dir = temp("check-nompi");
    let nothing = dir.join("nothing");
    let err = refused(&["check", "--fluid-ranks", "2"], 1, &nothing);
    for s in [
        "--fluid-ranks 2: ",
        "cannot run as 2 MPI ranks: built without MPI",
        "--features fluid-node/mpi",
        "--fluid-ranks 1",
    ] {
        assert!(err.contains(s), "no {s:?} in {err}");
    }
    let scene = two_ranks_scene(&dir);
    let err = refused(&["check", scene.to_str().unwrap()], 1, &nothing);
    assert!(
        err.contains("[fluid] ranks = 2: ") && err.contains("cannot run as 2 MPI ranks"),
        "{err}"
    );
    let o = coupler()
        .args(["check", "--fluid-ranks", "1"])
        .output_within(LIMIT);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// `coupler spread -- --fluid-ranks 2` on a node built without MPI ran every member in turn,
/// each refused by its `coupler run`, and exited 0 with a table of "no summary" rows. It is
/// refused once, before the first run, and leaves no --out.
#[test]
fn a_spread_on_ranks_a_node_cannot_run_is_refused_once_before_any_run() {
    if !node_built_without_mpi() {
        return;
    }
    let dir = temp("spread-nompi");
    let out = dir.join("spread");
    let err = refused(
        &[
            "spread",
            "--vary",
            "fluid.wcsph.alpha=0,0.01",
            "--out",
            out.to_str().unwrap(),
            "--",
            "--fluid-ranks",
            "2",
        ],
        1,
        &out,
    );
    assert_eq!(err.matches("cannot run as 2 MPI ranks").count(), 1, "{err}");
    assert!(
        err.contains("-- --fluid-ranks 2: --fluid-ranks 2: ")
            && err.contains("--features fluid-node/mpi"),
        "{err}"
    );
}

/// A number far from 1 in a refused flag or field came back with every digit (Rust's `{}`:
/// `--dx=-1e300` as 301 digits, `--cell 1e-300` as 300 zeros); it prints as `-1e300` now
/// (`shared::math::readable`), and ordinary numbers as before (`--step-timeout 0.5`).
#[test]
fn numbers_far_from_one_are_printed_readably_when_refused() {
    let dir = temp("digits");
    let out = dir.join("out");
    let o = out.to_str().unwrap();
    let margin = dir.join("margin.toml");
    std::fs::write(
        &margin,
        shared::scene::DEFAULT_SCENE.replacen("[coupling]\n", "[coupling]\nmargin = 1e300\n", 1),
    )
    .unwrap();
    let m = margin.to_str().unwrap();
    let cases: &[(&[&str], &str)] = &[
        (&["run", "--dx=-1e300", "--out", o], "--dx -1e300: "),
        (
            &["run", "--dt-factor=-1e300", "--out", o],
            "--dt-factor -1e300: ",
        ),
        (
            &["run", "--target-error", "1e300", "--out", o],
            "--target-error 1e300: ",
        ),
        (
            &["run", "--target-error=-1e-300", "--out", o],
            "--target-error -1e-300: ",
        ),
        (&["run", "--end", "1e300", "--out", o], "time.end = 1e300 s"),
        (
            &["run", "--step-timeout", "0.5", "--out", o],
            "--step-timeout 0.5: ",
        ),
        (&["check", m], "is 2.500e301 particle spacings"),
        (
            &["make-site", "--cell", "1e-300", "--out", o],
            "--cell 1e-300: ",
        ),
        (
            &["make-site", "--cell", "1e300", "--out", o],
            "--cell 1e300: ",
        ),
    ];
    for (args, says) in cases {
        let err = refused(args, 1, &out);
        assert!(err.contains(says), "{args:?}: no {says:?} in {err}");
    }
}

/// `coupler stability --rows TEXT` that matches no row ran nothing, redrew the map from the CSV
/// in --out and exited 0 (without a CSV: failed naming the file, after making --out). It is
/// refused before anything is written, with the rows there are.
#[test]
fn stability_rows_that_match_no_row_are_refused_with_the_rows_there_are() {
    let dir = temp("rows");
    let charts = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/charts");
    std::fs::copy(
        charts.join("stability_density.csv"),
        dir.join("stability_density.csv"),
    )
    .unwrap();
    let d = dir.to_str().unwrap();
    let err = refused(
        &[
            "stability",
            "--only",
            "density",
            "--rows",
            "no such row",
            "--out",
            d,
        ],
        1,
        &dir.join("stability_density.svg"),
    );
    assert!(
        err.contains("--rows 'no such row' matches no row of the density map")
            && err.contains("wcsph+explicit/parallel"),
        "{err}"
    );
    let out = dir.join("new");
    let err = refused(
        &[
            "stability",
            "--only",
            "dt",
            "--rows",
            "nosuch",
            "--out",
            out.to_str().unwrap(),
        ],
        1,
        &out,
    );
    assert!(
        err.contains("no row of the dt map") && err.contains("explicit DDA, resting block"),
        "{err}"
    );
}

/// `coupler chart --replot --out DIR` with none of the charts' CSV files in DIR (empty, or not
/// there: it was made) said each chart was skipped and exited 0. It is refused naming the files
/// it looks for, and makes nothing.
#[test]
fn a_replot_of_a_directory_without_charts_is_refused_naming_the_files() {
    let dir = temp("replot");
    let missing = dir.join("missing");
    for (out, written) in [
        (&*dir, dir.join("fluid_speed_accuracy.svg")),
        (&missing, missing.clone()),
    ] {
        let err = refused(
            &["chart", "--replot", "--out", out.to_str().unwrap()],
            1,
            &written,
        );
        assert!(
            err.contains(&format!(
                "{} holds none of the charts' CSV files",
                out.display()
            )) && err.contains("fluid_speed_accuracy.csv")
                && err.contains("Fix"),
            "{err}"
        );
    }
}

/// `coupler chart --only loads --replot` redrew every chart whose CSV was in --out, and
/// `coupler stability --only dt --replot` every map (failing at the first CSV absent, after
/// redrawing the others). `--only` picks the charts and maps redrawn; one whose CSV is absent is
/// refused, naming the file and the fix, before anything is redrawn.
#[test]
fn a_replot_redraws_only_the_charts_named_and_refuses_those_not_there() {
    let dir = temp("replot-only");
    let charts = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/charts");
    for f in [
        "loads_peak_speed_accuracy.csv",
        "loads_impulse_speed_accuracy.csv",
        "solid_speed_accuracy.csv",
        "stability_dt_factor.csv",
        "stability_density.csv",
    ] {
        std::fs::copy(charts.join(f), dir.join(f)).unwrap();
    }
    let d = dir.to_str().unwrap();
    for (cmd, only, drawn, not_drawn) in [
        (
            "chart",
            "loads",
            "loads_impulse_speed_accuracy.svg",
            "solid_speed_accuracy.svg",
        ),
        (
            "stability",
            "dt",
            "stability_dt_factor.svg",
            "stability_density.svg",
        ),
    ] {
        let o = coupler()
            .args([cmd, "--only", only, "--replot", "--out", d])
            .output_within(LIMIT);
        assert!(
            o.status.success(),
            "{cmd}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(dir.join(drawn).is_file(), "{cmd}: no {drawn}");
        assert!(!dir.join(not_drawn).exists(), "{cmd}: {not_drawn} redrawn");
    }
    for (cmd, only, absent, kept) in [
        (
            "chart",
            "solid,coupled",
            "coupled_speed_accuracy.csv",
            "solid_speed_accuracy.svg",
        ),
        (
            "stability",
            "density,stiffness",
            "stability_stiffness.csv",
            "stability_density.svg",
        ),
    ] {
        let err = refused(
            &[cmd, "--only", only, "--replot", "--out", d],
            1,
            &dir.join(kept),
        );
        assert!(
            err.contains(&dir.join(absent).display().to_string())
                && err.contains(&format!("--only {only}"))
                && err.contains("Fix"),
            "{cmd}: {err}"
        );
    }
}

/// `coupler povray` on a run directory whose block frame is damaged (a polygon naming a point
/// past the last) panicked with an index out of bounds. It names the file, the polygon and the
/// point, and writes nothing.
#[test]
fn povray_on_a_damaged_frame_names_the_file_and_what_is_wrong() {
    use shared::scene::VtkFormat;
    let dir = temp("povray");
    std::fs::write(dir.join("scene.toml"), shared::scene::DEFAULT_SCENE).unwrap();
    let frame = dir.join("blocks_00000.vtp");
    let corners = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let faces = vec![vec![0, 2, 1], vec![0, 1, 3], vec![0, 3, 2], vec![1, 2, 3]];
    shared::vtk::write_polyhedra(&frame, &[(&corners, &faces)], &[], VtkFormat::Ascii).unwrap();
    shared::vtk::write_pvd(&dir.join("blocks.pvd"), &[(0.0, "blocks_00000.vtp".into())]).unwrap();
    // The second face's last corner, 3, becomes 7: past the four points.
    let text = std::fs::read_to_string(&frame).unwrap();
    assert!(text.contains("0 2 1 0 1 3 0 3 2 1 2 3"), "{text}");
    std::fs::write(&frame, text.replace("0 2 1 0 1 3 ", "0 2 1 0 1 7 ")).unwrap();
    let err = refused(&["povray", dir.to_str().unwrap()], 1, &dir.join("povray"));
    assert!(
        err.contains(&format!(
            "{}: polygon 1 names point 7, but the file has 4 points",
            frame.display()
        )) && err.contains("damaged")
            && err.contains("Fix"),
        "{err}"
    );
}

/// The default scene with `[fluid] ranks = 2`, written into `dir`.
fn two_ranks_scene(dir: &std::path::Path) -> std::path::PathBuf {
    let scene = dir.join("ranks.toml");
    std::fs::write(
        &scene,
        shared::scene::DEFAULT_SCENE.replacen("[fluid]\n", "[fluid]\nranks = 2\n", 1),
    )
    .unwrap();
    scene
}
