//! Files from the outside world cannot take the process down (issue 45): a table of hostile
//! inputs — headers that lie, sparse and device files, a FIFO, a deflate bomb, scenes with wrong
//! types or values that would be accepted though wrong, damaged checkpoints, network endpoints
//! that cannot exist — each given to the real `coupler` under a 1 GiB address-space limit
//! (`setrlimit(RLIMIT_AS)`, inherited by the nodes it starts). Every case must end within seconds in a clear error: a nonzero exit code
//! (not a signal: no abort, no panic, no out-of-memory kill), a message naming the file or
//! field and the fix, and no hang.
//!
//! The files are made by the test itself, in a fresh temporary directory per case.

mod common;

use common::*;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

/// The address space every command below may use: far below what the lying inputs claim
/// (6–16 GB), far above what an honest `coupler check` of these scenes needs.
const MEMORY_LIMIT: u64 = 1 << 30;

/// How long a case may take: "within seconds", with room for a loaded CI host.
const TIME_LIMIT: Duration = Duration::from_secs(30);

/// One hostile input: what it is, how to make it and call the coupler on it, and what the
/// error must say.
struct Case {
    name: &'static str,
    /// Makes the input files in `dir` and returns the `coupler` arguments.
    make: fn(&Path) -> Vec<String>,
    /// Each must appear in the command's output (stderr or stdout), case-insensitive.
    says: &'static [&'static str],
}

/// `coupler ARGS` under [`MEMORY_LIMIT`], its outputs captured.
fn limited(args: &[String]) -> Command {
    let mut c = Command::new(bin("coupler"));
    c.args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    // SAFETY: setrlimit is async-signal-safe; nothing else runs between fork and exec.
    unsafe {
        c.pre_exec(|| {
            let lim = libc::rlimit {
                rlim_cur: MEMORY_LIMIT,
                rlim_max: MEMORY_LIMIT,
            };
            if libc::setrlimit(libc::RLIMIT_AS, &lim) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    c
}

/// The repository's scene `name` (scenes/NAME.toml) as text.
fn repo_scene(name: &str) -> String {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../scenes/{name}.toml"));
    std::fs::read_to_string(p).unwrap()
}

fn fjord_toml() -> String {
    repo_scene("fjord")
}

/// `coupler check` on scene `name` with `from` replaced by `to` (which must be there).
fn edited(dir: &Path, name: &str, from: &str, to: &str) -> Vec<String> {
    let text = repo_scene(name);
    assert!(text.contains(from), "{name}.toml has no {from:?}");
    check(&scene_at(dir, &text.replacen(from, to, 1)))
}

/// `coupler check` on scene `name` with `text` appended.
fn appended(dir: &Path, name: &str, text: &str) -> Vec<String> {
    check(&scene_at(dir, &(repo_scene(name) + "\n" + text)))
}

/// A cube of `size` metres cut by three orthogonal joint sets `spacing` apart.
fn cube_slide(size: f64, spacing: f64, max_blocks: &str) -> String {
    let mut s = format!(
        "[[slide]]\nname = \"cube\"\ndensity = 2500.0\n{max_blocks}\n\
         region = {{ type = \"box\", min = [1.0, 0.2, 0.6], max = [{}, {}, {}] }}\n",
        1.0 + size,
        0.2 + size,
        0.6 + size
    );
    for (dip, dir) in [(0.0, 0.0), (90.0, 0.0), (90.0, 90.0)] {
        s += &format!(
            "[[slide.joint_set]]\ndip = {dip:?}\ndip_direction = {dir:?}\nspacing = {spacing:?}\n\
             offset = [1.0, 0.2, 0.6]\n"
        );
    }
    s
}

/// `dir/name` holding `head` and then zeros to `len` bytes, which take no disk (a sparse file).
fn sparse(dir: &Path, name: &str, head: &[u8], len: u64) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, head).unwrap();
    resize(&p, len);
    p
}

/// Cuts `file` to, or extends it with zeros to, `len` bytes.
fn resize(file: &Path, len: u64) {
    let f = std::fs::OpenOptions::new().write(true).open(file).unwrap();
    f.set_len(len).unwrap();
}

/// Strings as owned arguments.
fn args(words: &[&str]) -> Vec<String> {
    words.iter().map(|w| w.to_string()).collect()
}

/// The fjord scene with its terrain read from `file` instead of its DEM; written to
/// `dir/scene.toml`, whose path is returned.
fn fjord_with_terrain(dir: &Path, file: &Path) -> PathBuf {
    let text = fjord_toml().replace(
        "file = \"fjord/fjord.asc\"",
        &format!("file = {:?}", file.display().to_string()),
    );
    assert!(text.contains(&file.display().to_string()));
    scene_at(dir, &text)
}

/// `text` written as `dir/scene.toml`.
fn scene_at(dir: &Path, text: &str) -> PathBuf {
    let p = dir.join("scene.toml");
    std::fs::write(&p, text).unwrap();
    p
}

fn check(scene: &Path) -> Vec<String> {
    vec!["check".into(), scene.display().to_string()]
}

/// `coupler check` on the fjord with its terrain from `dir/name` holding `bytes`.
fn terrain_file(dir: &Path, name: &str, bytes: &[u8]) -> Vec<String> {
    let f = dir.join(name);
    std::fs::write(&f, bytes).unwrap();
    check(&fjord_with_terrain(dir, &f))
}

/// An ASCII STL of the box [lo, hi], its triangles facing out.
fn box_stl(lo: [f64; 3], hi: [f64; 3]) -> String {
    let corner = |k: usize| [0, 1, 2].map(|a| if k >> a & 1 == 0 { lo[a] } else { hi[a] });
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let mut s = String::from("solid box\n");
    for q in quads {
        for t in [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] {
            s += " facet normal 0 0 0\n  outer loop\n";
            for k in t {
                let [x, y, z] = corner(k);
                s += &format!("   vertex {x} {y} {z}\n");
            }
            s += "  endloop\n endfacet\n";
        }
    }
    s + "endsolid box\n"
}

/// A dry unit-cube scene whose terrain is the closed box [0.2, 0.8]×[0.2, 0.6]×[0, 0.5]
/// (`terrain_extra` lines added to its `[[terrain]]`), with a free block `rock` at `rock`.
fn boxed_terrain(dir: &Path, terrain_extra: &str, rock: ([f64; 3], [f64; 3])) -> Vec<String> {
    let stl = dir.join("box.stl");
    std::fs::write(&stl, box_stl([0.2, 0.2, 0.0], [0.8, 0.6, 0.5])).unwrap();
    let text = format!(
        "name = \"boxed\"\n[time]\nend = 0.1\ndt_max = 1e-3\n\
         [domain]\nmin = [0.0, 0.0, 0.0]\nmax = [1.0, 1.0, 1.0]\n\
         [[terrain]]\nname = \"terrain\"\nfile = {:?}\n{terrain_extra}\n\
         [[block]]\nname = \"rock\"\nkind = \"free\"\n\
         shape = {{ type = \"box\", min = {:?}, max = {:?} }}\n",
        stl.display().to_string(),
        rock.0,
        rock.1
    );
    check(&scene_at(dir, &text))
}

static CHECKPOINTED: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();

/// A finished coarse run of the default scene with checkpoints (made once, copied for each
/// case that damages one): its directory.
fn checkpointed_run() -> &'static Path {
    CHECKPOINTED.get_or_init(|| {
        let (id, dir) = fresh("hostile-checkpoints");
        let o = run(coupler(
            &id,
            &dir,
            &[
                "--dx",
                "0.08",
                "--end",
                "0.4",
                "--checkpoint-interval",
                "0.1",
            ],
        ));
        assert!(o.status.success(), "the checkpointed run: {}", stderr(&o));
        dir
    })
}

/// A copy of [`checkpointed_run`] in `dir/run`, its newest `role` checkpoint file changed by
/// `damage`; `coupler run --resume` of it.
fn damaged_checkpoint(dir: &Path, role: &str, damage: fn(&Path)) -> Vec<String> {
    let copy = dir.join("run");
    let status = Command::new("cp")
        .arg("-a")
        .arg(checkpointed_run())
        .arg(&copy)
        .status()
        .unwrap();
    assert!(status.success());
    let newest = std::fs::read_dir(copy.join("checkpoints"))
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            p.file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with(&format!("{role}-")))
        })
        .max()
        .expect("a checkpoint");
    damage(&newest);
    args(&["run", "--quiet", "--resume", &copy.display().to_string()])
}

/// Flips one bit in each of nine bytes spread over the file's middle.
fn flip_nine_bits(file: &Path) {
    let mut bytes = std::fs::read(file).unwrap();
    let n = bytes.len();
    for k in 0..9 {
        bytes[n / 3 + k * (n / 30)] ^= 1 << (k % 8);
    }
    std::fs::write(file, bytes).unwrap();
}

const CASES: &[Case] = &[
    Case {
        name: "terrain path is a FIFO",
        make: |dir| {
            let f = dir.join("valley.asc");
            let c = std::ffi::CString::new(f.display().to_string()).unwrap();
            assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
            check(&fjord_with_terrain(dir, &f))
        },
        says: &["terrain[0].file", "not a regular file"],
    },
    Case {
        name: "terrain .stl is /dev/zero",
        make: |dir| {
            let f = dir.join("zero.stl");
            std::os::unix::fs::symlink("/dev/zero", &f).unwrap();
            check(&fjord_with_terrain(dir, &f))
        },
        says: &["terrain[0].file", "not a regular file"],
    },
    Case {
        name: "ESRI grid header claims 10^9 cells",
        make: |dir| {
            terrain_file(
                dir,
                "lie.asc",
                b"ncols 40000\nnrows 25000\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2 3\n",
            )
        },
        says: &["terrain[0].file", "1000000000 cells", "fix"],
    },
    Case {
        name: "ESRI grid header ncols 1e300",
        make: |dir| {
            terrain_file(
                dir,
                "huge.asc",
                b"ncols 1e300\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2 3\n",
            )
        },
        says: &["terrain[0].file", "ncols"],
    },
    Case {
        name: "ESRI grid with a header and no values",
        make: |dir| {
            terrain_file(
                dir,
                "empty.asc",
                b"ncols 3\nnrows 3\nxllcorner 0\nyllcorner 0\ncellsize 1\n",
            )
        },
        says: &["terrain[0].file", "fix"],
    },
    // Scene files and the command line.
    Case {
        name: "scene path is /dev/zero",
        make: |_| args(&["check", "/dev/zero"]),
        says: &["/dev/zero", "not a regular file", "fix"],
    },
    Case {
        name: "coupler run of /dev/zero",
        make: |dir| {
            let out = dir.join("run").display().to_string();
            args(&["run", "/dev/zero", "--quiet", "--out", &out])
        },
        says: &["/dev/zero", "not a regular file"],
    },
    Case {
        name: "scene file of 2 MB (sparse)",
        make: |dir| check(&sparse(dir, "big.toml", b"", 2 << 20)),
        says: &["big.toml", "more than a scene may hold"],
    },
    Case {
        name: "negative max_blocks",
        make: |dir| {
            appended(
                dir,
                "sliding_wedge",
                &cube_slide(0.2, 0.1, "max_blocks = -5"),
            )
        },
        says: &["slide[0].max_blocks", "whole number", "-5", "e.g."],
    },
    Case {
        name: "fractional solid_substeps",
        make: |dir| edited(dir, "fjord", "solid_substeps = 10", "solid_substeps = 2.5"),
        says: &["coupling.solid_substeps", "whole number", "2.5"],
    },
    Case {
        name: "a number where a terrain path belongs",
        make: |dir| edited(dir, "fjord", "file = \"fjord/fjord.asc\"", "file = 5"),
        says: &["terrain[0].file", "file path"],
    },
    Case {
        name: "negative number after --end",
        make: |dir| {
            let out = dir.join("run").display().to_string();
            args(&["run", "--end", "-1", "--quiet", "--out", &out])
        },
        says: &["time.end", "-1", "fix"],
    },
    Case {
        name: "negative cell of make-site",
        make: |dir| {
            let out = dir.join("site").display().to_string();
            args(&["make-site", "--cell", "-1", "--out", &out])
        },
        says: &["--cell", "-1"],
    },
    // Accepted though wrong.
    Case {
        name: "run-up box reaching infinity",
        make: |dir| {
            appended(
                dir,
                "sliding_wedge",
                "[[runup]]\nname = \"beach\"\nmin = [0.0, 0.0]\nmax = [inf, 0.8]\n",
            )
        },
        says: &["runup[0].max", "fix"],
    },
    Case {
        name: "probe window of 1e-300 s",
        make: |dir| {
            edited(
                dir,
                "sliding_wedge",
                "position = [4.95, 0.4, 0.05]",
                "position = [4.95, 0.4, 0.05]\nwindow = 1e-300",
            )
        },
        says: &["probe[0].window", "1e-300", "fix"],
    },
    Case {
        name: "probe window longer than the run (milliseconds read as seconds)",
        make: |dir| {
            edited(
                dir,
                "sliding_wedge",
                "position = [4.95, 0.4, 0.05]",
                "position = [4.95, 0.4, 0.05]\nwindow = 1000",
            )
        },
        says: &["probe[0].window", "longer than the run", "in seconds"],
    },
    Case {
        name: "slide blocks below a quarter of dx",
        make: |dir| edited(dir, "jointed_slide", "spacing = 0.12", "spacing = 0.005"),
        says: &["slide[0].joint_set[0].spacing", "quarter", "fix"],
    },
    Case {
        name: "joint offset of 1e300",
        make: |dir| {
            edited(
                dir,
                "jointed_slide",
                "offset = [1.5, 0.0, 0.0]",
                "offset = [1e300, 0.0, 0.0]",
            )
        },
        says: &["slide[0].joint_set[0].offset", "1e7"],
    },
    Case {
        name: "joints cutting 10^5 blocks",
        make: |dir| {
            appended(
                dir,
                "sliding_wedge",
                &cube_slide(0.6, 0.011, "max_blocks = 20000"),
            )
        },
        says: &["slide[0]", "max_blocks", "fix"],
    },
    Case {
        name: "max_blocks raised to 10^7",
        make: |dir| {
            appended(
                dir,
                "sliding_wedge",
                &cube_slide(1.0, 0.01, "max_blocks = 10000000"),
            )
        },
        says: &["slide[0].max_blocks", "20000"],
    },
    Case {
        name: "--slides-vtk names a directory",
        make: |dir| {
            let mut a = check(&scene_at(dir, &repo_scene("jointed_slide")));
            a.extend(args(&["--slides-vtk", &dir.display().to_string()]));
            a
        },
        says: &["not a regular file", "fix"],
    },
    // Runs that crawl.
    Case {
        name: "dt_max = 1e-9",
        make: |dir| {
            edited(
                dir,
                "sliding_wedge",
                "dt_max = 1e-3",
                "dt_max = 1e-9\ndt_min = 1e-12",
            )
        },
        says: &["time.dt_max", "crawl", "--allow-long"],
    },
    Case {
        name: "a viscosity that collapses the step",
        make: |dir| {
            edited(
                dir,
                "sliding_wedge",
                "density = 1000.0\ndx = 0.04",
                "density = 1000.0\ndx = 0.04\nkinematic_viscosity = 1e5",
            )
        },
        says: &["fluid.kinematic_viscosity", "crawl", "fix"],
    },
    // Terrain meshes and grids that lie about their size.
    Case {
        name: "binary STL whose count disagrees with its length",
        make: |dir| {
            let mut b = vec![0u8; 80];
            b.extend(12u32.to_le_bytes());
            b.extend(vec![0u8; 590]);
            terrain_file(dir, "short.stl", &b)
        },
        says: &["terrain[0].file", "12 triangles", "fix"],
    },
    Case {
        name: "sparse 10 GB STL",
        make: |dir| {
            let f = sparse(dir, "zeros.stl", b"", 10 << 30);
            check(&fjord_with_terrain(dir, &f))
        },
        says: &["terrain[0].file", "limit", "fix"],
    },
    Case {
        name: "ASCII STL of one endless line (sparse 1 GB)",
        make: |dir| {
            let f = sparse(dir, "line.stl", b"solid x\n", 1 << 30);
            check(&fjord_with_terrain(dir, &f))
        },
        says: &["terrain[0].file", "line longer", "fix"],
    },
    Case {
        name: "sparse 10 GB ESRI grid",
        make: |dir| {
            let f = sparse(dir, "zeros.asc", b"", 10 << 30);
            check(&fjord_with_terrain(dir, &f))
        },
        says: &["terrain[0].file", "fix"],
    },
    Case {
        name: "PLY header claiming 10^12 vertices",
        make: |dir| {
            terrain_file(
                dir,
                "lie.ply",
                b"ply\nformat ascii 1.0\nelement vertex 1000000000000\nproperty float x\n\
                  property float y\nproperty float z\nelement face 1\n\
                  property list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n",
            )
        },
        says: &["terrain[0].file", "claims", "fix"],
    },
    Case {
        name: "deflate bomb: a 64 M-cell GeoTIFF in a small file",
        make: |dir| {
            let f = dir.join("bomb.tif");
            let n = 8192usize;
            shared::terrain::geotiff::write(
                &f,
                (n as u32, n as u32),
                [0.0, n as f64],
                1.0,
                256,
                true,
                &vec![0.0f32; n * n],
            )
            .unwrap();
            assert!(std::fs::metadata(&f).unwrap().len() < 8 << 20);
            check(&fjord_with_terrain(dir, &f))
        },
        says: &["terrain[0]", "67108864 cells", "MAX_DEM_CELLS", "decimate"],
    },
    Case {
        name: "a crop that cuts a closed mesh open",
        make: |dir| {
            boxed_terrain(
                dir,
                "crop = { min = [0.0, 0.0, 0.0], max = [0.5, 1.0, 1.0] }",
                ([0.0, 0.0, 0.8], [0.1, 0.1, 0.9]),
            )
        },
        says: &["terrain[0].crop", "open", "fix"],
    },
    Case {
        name: "a free block inside the ground",
        make: |dir| boxed_terrain(dir, "", ([0.4, 0.3, 0.1], [0.5, 0.4, 0.2])),
        says: &["block[0]", "inside the ground", "fix"],
    },
    Case {
        name: "make-site at 1 mm (1.6 TB)",
        make: |dir| {
            let out = dir.join("site.asc").display().to_string();
            args(&["make-site", "--cell", "1e-3", "--out", &out])
        },
        says: &["--cell", "MAX_SITE_CELLS", "fix"],
    },
    // Checkpoints.
    Case {
        name: "nine flipped bits in a solid checkpoint",
        make: |dir| damaged_checkpoint(dir, "solid", flip_nine_bits),
        says: &["solid-", "checksum", "fix"],
    },
    Case {
        name: "a fluid checkpoint cut short",
        make: |dir| damaged_checkpoint(dir, "fluid", |f| resize(f, 1000)),
        says: &["fluid-", "truncated", "fix"],
    },
    Case {
        name: "a coupler checkpoint renamed to a later step",
        make: |dir| {
            damaged_checkpoint(dir, "coupler", |f| {
                std::fs::rename(f, f.with_file_name("coupler-0000009999.ckpt")).unwrap()
            })
        },
        says: &["coupler-0000009999.ckpt", "renamed", "fix"],
    },
    // Network endpoints.
    Case {
        name: "a zenoh endpoint without a port",
        make: |dir| {
            let out = dir.join("run").display().to_string();
            args(&[
                "run",
                "--transport",
                "zenoh",
                "--listen",
                "garbage",
                "--quiet",
                "--out",
                &out,
            ])
        },
        says: &["'garbage' is not a zenoh endpoint", "fix"],
    },
    Case {
        name: "a zenoh endpoint that cannot exist",
        make: |dir| {
            let out = dir.join("run").display().to_string();
            args(&[
                "run",
                "--transport",
                "zenoh",
                "--connect",
                "tcp/999.1.1.1:99999",
                "--quiet",
                "--out",
                &out,
            ])
        },
        says: &["tcp/999.1.1.1:99999", "65535", "fix"],
    },
];

/// Waits for `child` up to [`TIME_LIMIT`]; kills it and returns `None` past that.
fn bounded(child: std::process::Child) -> Option<(std::process::Output, Duration)> {
    let start = std::time::Instant::now();
    let pid = child.id();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(child.wait_with_output());
    });
    match rx.recv_timeout(TIME_LIMIT) {
        Ok(out) => Some((out.expect("wait"), start.elapsed())),
        Err(_) => {
            unsafe_kill(pid, 9);
            None
        }
    }
}

#[test]
fn every_hostile_input_ends_in_a_clear_error_within_seconds_under_1_gib() {
    let mut failures = Vec::new();
    for case in CASES {
        let dir = tempfile::Builder::new()
            .prefix("rockwave-hostile-")
            .tempdir()
            .unwrap();
        let args = (case.make)(dir.path());
        let child = limited(&args).spawn().expect("coupler starts");
        let Some((out, took)) = bounded(child) else {
            failures.push(format!(
                "{}: still running after {TIME_LIMIT:?} (killed)\n  coupler {}",
                case.name,
                args.join(" ")
            ));
            continue;
        };
        let text = format!(
            "{}{}",
            String::from_utf8_lossy(&out.stderr),
            String::from_utf8_lossy(&out.stdout)
        );
        let lower = text.to_lowercase();
        let mut wrong = Vec::new();
        match out.status.code() {
            None => wrong.push(format!("ended by a signal ({:?})", out.status)),
            Some(0) => wrong.push("exit code 0 (accepted)".to_string()),
            Some(_) => {}
        }
        if took >= TIME_LIMIT {
            wrong.push(format!("took {took:?} (limit {TIME_LIMIT:?})"));
        }
        if lower.contains("panicked") {
            wrong.push("panicked".into());
        }
        for s in case.says {
            if !lower.contains(&s.to_lowercase()) {
                wrong.push(format!("does not say {s:?}"));
            }
        }
        if !wrong.is_empty() {
            failures.push(format!(
                "{}: {}\n  coupler {}\n  output: {}",
                case.name,
                wrong.join("; "),
                args.join(" "),
                text.trim()
            ));
        }
    }
    if let Some(dir) = CHECKPOINTED.get() {
        let _ = std::fs::remove_dir_all(dir);
    }
    assert!(
        failures.is_empty(),
        "{} of {} hostile inputs not handled:\n{}",
        failures.len(),
        CASES.len(),
        failures.join("\n")
    );
}
