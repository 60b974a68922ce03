//! Coupled runs as real processes, for the sweeps: `coupler chart` and `coupler stability`
//! start this very executable as `coupler run` (so every run has its own nodes, shared memory
//! and run directory, exactly as a user's run would), then read `summary.json` and the CSV
//! files it left.
//!
//! A scene variant (another density, another penalty stiffness) is written as a TOML file into
//! the sweep's scratch directory: the scene is data, the command line stays the user's one.

use shared::scene::Scene;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

/// How one coupled run ended, as `summary.json` and the exit code tell it.
#[derive(Debug, Clone)]
pub struct RunOutcome {
    /// `completed`, `unstable`, `failed` (or `no summary` when the coupler died before writing one).
    pub status: String,
    /// The run's message: for an unstable run, node, step, time and cause.
    pub message: String,
    pub exit_code: i32,
    /// Wall time of the whole `coupler run` process, start-up included [s].
    pub wall_seconds: f64,
    /// Warnings the nodes reported and the last of them.
    pub warnings: u64,
    pub last_warning: Option<String>,
    pub steps: u64,
    /// Simulated time reached [s].
    pub time: f64,
    pub dir: PathBuf,
}

impl RunOutcome {
    pub fn completed(&self) -> bool {
        self.status == "completed"
    }

    /// One line for a table or a stability map: what happened and how it was detected.
    pub fn detail(&self) -> String {
        match self.status.as_str() {
            "completed" => match &self.last_warning {
                Some(w) => format!("completed with {} warning(s): {w}", self.warnings),
                None => format!("completed, {} steps", self.steps),
            },
            _ => self.message.clone(),
        }
    }
}

/// Writes `scene` as TOML to `path` (for a variant of a scene file).
pub fn write_scene(scene: &Scene, path: &Path) -> Result<(), String> {
    let text = toml::to_string(scene).map_err(|e| format!("cannot serialise scene: {e}"))?;
    std::fs::write(path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))
}

/// Runs `coupler run <scene> <args> --quiet --out <out>` with this executable and waits.
/// `out` must not exist yet.
pub fn coupler_run(scene: &Path, args: &[String], out: &Path) -> Result<RunOutcome, String> {
    let exe = std::env::current_exe().map_err(|e| format!("cannot find my own executable: {e}"))?;
    coupler_run_with(&exe, scene, args, out)
}

/// As [`coupler_run`], with the coupler executable given (the tests pass the built binary).
pub fn coupler_run_with(
    exe: &Path,
    scene: &Path,
    args: &[String],
    out: &Path,
) -> Result<RunOutcome, String> {
    let start = Instant::now();
    let output = Command::new(exe)
        .arg("run")
        .arg(scene)
        .args(args)
        .arg("--quiet")
        .arg("--out")
        .arg(out)
        .stdin(Stdio::null())
        .output()
        .map_err(|e| format!("cannot start {}: {e}", exe.display()))?;
    let wall_seconds = start.elapsed().as_secs_f64();
    let exit_code = output.status.code().unwrap_or(-1);
    let summary = std::fs::read_to_string(out.join("summary.json"))
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok());
    let Some(s) = summary else {
        let err = String::from_utf8_lossy(&output.stderr);
        return Ok(RunOutcome {
            status: "no summary".into(),
            message: err.lines().last().unwrap_or("").to_string(),
            exit_code,
            wall_seconds,
            warnings: 0,
            last_warning: None,
            steps: 0,
            time: 0.0,
            dir: out.to_path_buf(),
        });
    };
    let stats = &s["stats"];
    Ok(RunOutcome {
        status: s["status"].as_str().unwrap_or("?").to_string(),
        message: s["message"].as_str().unwrap_or("").to_string(),
        exit_code,
        wall_seconds,
        warnings: stats["warnings"].as_u64().unwrap_or(0),
        last_warning: stats["last_warning"].as_str().map(str::to_string),
        steps: stats["steps"].as_u64().unwrap_or(0),
        time: stats["time"].as_f64().unwrap_or(0.0),
        dir: out.to_path_buf(),
    })
}

/// A CSV file with a header, as named columns of text cells.
pub struct Table {
    pub header: Vec<String>,
    pub rows: Vec<Vec<String>>,
}

impl Table {
    pub fn read(path: &Path) -> Result<Table, String> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
        let mut lines = text.lines().filter(|l| !l.trim().is_empty());
        let header = lines
            .next()
            .ok_or_else(|| format!("{} is empty", path.display()))?
            .split(',')
            .map(|s| s.trim().to_string())
            .collect();
        let rows = lines
            .map(|l| l.split(',').map(|s| s.trim().to_string()).collect())
            .collect();
        Ok(Table { header, rows })
    }

    pub fn column(&self, name: &str) -> Result<usize, String> {
        self.header
            .iter()
            .position(|h| h == name)
            .ok_or_else(|| format!("no column '{name}' in {:?}", self.header))
    }

    /// Numeric value of `col` in `row` (NaN when not a number).
    pub fn num(&self, row: usize, col: usize) -> f64 {
        self.rows[row]
            .get(col)
            .and_then(|c| c.parse().ok())
            .unwrap_or(f64::NAN)
    }
}

/// Mean draft of a floating box-shaped block over `[t0, t1]`: the mean free-surface elevation at
/// the gauges minus the mean height of the block's bottom (centroid z − height/2), from the
/// run's `gauges.csv` and `blocks.csv`. Also returns the block's largest |vz| in the window.
pub fn mean_draft(
    dir: &Path,
    block: &str,
    height: f64,
    t0: f64,
    t1: f64,
) -> Result<(f64, f64), String> {
    let gauges = Table::read(&dir.join("gauges.csv"))?;
    let mut surface = (0.0, 0usize);
    for r in 0..gauges.rows.len() {
        let t = gauges.num(r, 0);
        if t >= t0 && t <= t1 {
            // The surface columns, not the `<name>_spray` ones (highest droplet).
            for c in (1..gauges.header.len()).filter(|&c| !gauges.header[c].ends_with("_spray")) {
                let v = gauges.num(r, c);
                if v.is_finite() {
                    surface.0 += v;
                    surface.1 += 1;
                }
            }
        }
    }
    let blocks = Table::read(&dir.join("blocks.csv"))?;
    let (cb, cz, cvz) = (
        blocks.column("block")?,
        blocks.column("z")?,
        blocks.column("vz")?,
    );
    let mut bottom = (0.0, 0usize);
    let mut vmax: f64 = 0.0;
    for r in 0..blocks.rows.len() {
        let t = blocks.num(r, 0);
        if blocks.rows[r].get(cb).map(String::as_str) == Some(block) && t >= t0 && t <= t1 {
            bottom.0 += blocks.num(r, cz) - 0.5 * height;
            bottom.1 += 1;
            vmax = vmax.max(blocks.num(r, cvz).abs());
        }
    }
    if surface.1 == 0 || bottom.1 == 0 {
        return Err(format!(
            "no gauge or block samples between t = {t0} and {t1} s in {}",
            dir.display()
        ));
    }
    let draft = surface.0 / surface.1 as f64 - bottom.0 / bottom.1 as f64;
    if !draft.is_finite() {
        return Err(format!("the draft in {} is not finite", dir.display()));
    }
    Ok((draft, vmax))
}

/// The last row of block `block` in `blocks.csv`: (bottom height, |velocity|).
pub fn final_block(dir: &Path, block: &str, height: f64) -> Result<(f64, f64), String> {
    let blocks = Table::read(&dir.join("blocks.csv"))?;
    let (cb, cz) = (blocks.column("block")?, blocks.column("z")?);
    let (cvx, cvy, cvz) = (
        blocks.column("vx")?,
        blocks.column("vy")?,
        blocks.column("vz")?,
    );
    let r = (0..blocks.rows.len())
        .rev()
        .find(|&r| blocks.rows[r].get(cb).map(String::as_str) == Some(block))
        .ok_or_else(|| format!("block '{block}' not in blocks.csv"))?;
    let v = (blocks.num(r, cvx).powi(2) + blocks.num(r, cvy).powi(2) + blocks.num(r, cvz).powi(2))
        .sqrt();
    Ok((blocks.num(r, cz) - 0.5 * height, v))
}

/// Scratch directory for a sweep's runs, removed on drop unless asked to keep it.
pub struct Scratch {
    pub path: PathBuf,
    pub keep: bool,
}

impl Scratch {
    pub fn new(tag: &str) -> Result<Scratch, String> {
        let path = std::env::temp_dir().join(format!(
            "rockwave-{tag}-{}-{}",
            std::process::id(),
            shared::transport::RunId::fresh()
        ));
        std::fs::create_dir_all(&path)
            .map_err(|e| format!("cannot create {}: {e}", path.display()))?;
        Ok(Scratch { path, keep: false })
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        if !self.keep {
            let _ = std::fs::remove_dir_all(&self.path);
        }
    }
}
