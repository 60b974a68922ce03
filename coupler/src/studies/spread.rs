//! `coupler spread`: how far a scene's gauge crests move when knobs that are not physics turn.
//!
//! A crest is one number read off one run; whether it is a property of the flow or of the run is a
//! question only more runs answer. `coupler spread` runs the scene once as written (the *base*) and
//! once per value of each `--vary KEY=V1,V2,…` (one knob at a time, every other setting as the
//! scene has it, after any `--set KEY=VALUE` that every run takes): an artificial viscosity, a
//! sound speed, a step, a solver tolerance. For each gauge it tables the base run's crest, the
//! members' median, lowest and highest, and where the base run falls among them; with `--against
//! DIR` (another spread's directory, e.g. the same scene under another solver) each gauge's median
//! against that spread's median and range. Crests are read off `gauges.csv` as `coupler run`'s
//! summary reads them (the surface column, not `<name>_spray`; height above the gauge's first
//! reading, the still water), within `--window GAUGE=T0:T1` where one is given.
//!
//! Every member is a real `coupler run` of its own (its own nodes, shared memory and run directory,
//! [`crate::studies::runner`]); its scene is the base scene's TOML with one key set, written beside
//! its run directory, so each member can be rerun alone. All member scenes are checked before the
//! first run starts, with the run arguments and the fluid node on its ranks: a misspelt key is
//! named at once, not after an hour of runs, and nothing is left in `--out`. A member that
//! stops (unstable, failed) is tabled with its status and left out of the statistics; a crest whose
//! window the run did not reach is left empty.

use crate::studies::runner::{self, RunOutcome, Table};
use clap::Args;
use shared::report::median_range;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

#[derive(Debug, Args)]
pub struct SpreadArgs {
    /// Scene file; default: the embedded default scene.
    pub scene: Option<PathBuf>,
    /// A scene key and the values it takes, one run per value, every other setting as the
    /// scene has it, e.g. `fluid.wcsph.alpha=0,0.005,0.02` (repeatable).
    #[arg(long = "vary", value_name = "KEY=V1,V2,…", required = true)]
    pub vary: Vec<String>,
    /// A scene key set for every run, the base included, e.g. `time.dt_max=0.002` (repeatable):
    /// a spread around a setting the scene file does not have.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Read a gauge's crest within [T0, T1] only, e.g. `G1=0.7:1.3` (repeatable; default: the
    /// whole run).
    #[arg(long = "window", value_name = "GAUGE=T0:T1")]
    pub windows: Vec<String>,
    /// Another spread's directory (its `spread.csv`): each gauge's median against its median
    /// and range.
    #[arg(long, value_name = "DIR")]
    pub against: Option<PathBuf>,
    /// Directory for the member scenes, their run directories and `spread.csv`; must not exist
    /// or be empty.
    #[arg(long)]
    pub out: PathBuf,
    /// Arguments for every `coupler run`, after `--`, e.g. `-- --fluid-solver dfsph --dt-max
    /// 0.002 --solid-substeps 8 --end 3.0`.
    #[arg(last = true)]
    pub run_args: Vec<String>,
}

pub fn run(args: SpreadArgs) -> u8 {
    match run_inner(&args) {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("coupler spread: error: {e}");
            1
        }
    }
}

/// One run of the spread: the base (no key) or one key set to one value.
#[derive(Debug, Clone, PartialEq)]
struct Member {
    key: String,
    value: String,
}

impl Member {
    fn label(&self) -> String {
        if self.key.is_empty() {
            "base (the scene as written, with any --set)".into()
        } else {
            format!("{} = {}", self.key, self.value)
        }
    }
}

/// `KEY=V1,V2,…` as members, one per value.
fn parse_vary(text: &str) -> Result<Vec<Member>, String> {
    let fix = "Fix: write --vary KEY=V1,V2,…, e.g. --vary fluid.wcsph.alpha=0,0.005,0.02";
    let (key, values) = text
        .split_once('=')
        .ok_or_else(|| format!("--vary '{text}' has no '='. {fix}"))?;
    let key = key.trim();
    if key.is_empty() || key.split('.').any(str::is_empty) {
        return Err(format!(
            "--vary '{text}': '{key}' is not a dotted key. {fix}"
        ));
    }
    let values: Vec<&str> = values.split(',').map(str::trim).collect();
    if values.iter().any(|v| v.is_empty()) {
        return Err(format!("--vary '{text}' has an empty value. {fix}"));
    }
    Ok(values
        .into_iter()
        .map(|v| Member {
            key: key.to_string(),
            value: v.to_string(),
        })
        .collect())
}

/// The arguments after `--` as `coupler run` of member `scene` reads and checks them before it
/// starts anything (the flags, the scene with their overrides, the fluid node on its ranks): a
/// bad one failed every member in turn (`-- --end nan`, or `-- --fluid-ranks 2` on a node built
/// without MPI: a table of "no summary" rows, and exit code 0).
fn check_run_args(scene: &Path, run_args: &[String]) -> Result<(), String> {
    use crate::cli::{Cli, Cmd};
    use clap::Parser;
    let words = format!("-- {}", run_args.join(" "));
    let argv = ["coupler".as_ref(), "run".as_ref(), scene.as_os_str()]
        .into_iter()
        .chain(run_args.iter().map(|a| a.as_ref()))
        .chain(["--quiet".as_ref(), "--out".as_ref(), "run".as_ref()]);
    let cli = Cli::try_parse_from(argv).map_err(|e| {
        let text = e.to_string();
        let first = text.lines().next().unwrap_or_default();
        format!(
            "{words}: {}. Fix: give flags of `coupler run` (see `coupler run --help`), without a scene, --out or --quiet: the spread gives those",
            first.trim_start_matches("error: ")
        )
    })?;
    let Cmd::Run(run) = cli.command else {
        unreachable!("parsed as `coupler run`")
    };
    let named = |e: String| format!("{words}: {e}");
    let (scene, _) = crate::run::settings::scene(&run, None).map_err(named)?;
    crate::run::settings::check_values(&run, &scene, None).map_err(named)?;
    let ranks = crate::run::per_rank::ranks(run.fluid_ranks, &scene).map_err(named)?;
    let launcher = crate::run::launcher::Launcher::parse(run.mpirun.as_deref()).map_err(named)?;
    crate::run::command::fluid_node(&run, &scene, ranks, &launcher).map_err(named)?;
    Ok(())
}

/// A gauge's window `GAUGE=T0:T1`.
fn parse_window(text: &str) -> Result<(String, f64, f64), String> {
    let fix = "Fix: write --window GAUGE=T0:T1, e.g. --window G1=0.7:1.3";
    let (gauge, range) = text
        .split_once('=')
        .ok_or_else(|| format!("--window '{text}' has no '='. {fix}"))?;
    let (a, b) = range
        .split_once(':')
        .ok_or_else(|| format!("--window '{text}' has no ':' between its times. {fix}"))?;
    let num = |s: &str| -> Result<f64, String> {
        s.trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite() && *v >= 0.0)
            .ok_or_else(|| format!("--window '{text}': '{s}' is not a time ≥ 0 [s]. {fix}"))
    };
    let (t0, t1) = (num(a)?, num(b)?);
    if t1 <= t0 {
        return Err(format!("--window '{text}' ends before it starts. {fix}"));
    }
    Ok((gauge.trim().to_string(), t0, t1))
}

/// The value of `--vary` as TOML: a number, a boolean, an array or a quoted string as written;
/// a bare word as a string (`solid.solver=implicit`).
fn toml_value(text: &str) -> toml::Value {
    toml::from_str::<toml::Table>(&format!("v = {text}"))
        .ok()
        .and_then(|mut t| t.remove("v"))
        .unwrap_or_else(|| toml::Value::String(text.to_string()))
}

/// Makes every relative `[[terrain]] file` of a scene's TOML an absolute path from `dir` (the
/// scene file's directory), as `Scene::load` reads it; true if any was relative.
fn anchor_files(scene: &mut toml::Table, dir: &Path) -> bool {
    let mut changed = false;
    let Some(toml::Value::Array(terrains)) = scene.get_mut("terrain") else {
        return false;
    };
    let dir = std::path::absolute(dir).unwrap_or_else(|_| dir.to_path_buf());
    for t in terrains.iter_mut().filter_map(toml::Value::as_table_mut) {
        if let Some(toml::Value::String(file)) = t.get_mut("file")
            && Path::new(file.as_str()).is_relative()
        {
            *file = dir.join(&*file).display().to_string();
            changed = true;
        }
    }
    changed
}

/// Sets the dotted `key` of a scene's TOML to `value`, making the tables on the way
/// (`fluid.dfsph` need not be in the scene).
fn set_key(scene: &mut toml::Table, key: &str, value: toml::Value) -> Result<(), String> {
    let parts: Vec<&str> = key.split('.').collect();
    let (last, path) = parts.split_last().expect("a key has a part");
    let mut table = scene;
    for (i, part) in path.iter().enumerate() {
        let entry = table
            .entry(part.to_string())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        table = entry.as_table_mut().ok_or_else(|| {
            format!(
                "--vary {key}: '{}' is not a table in the scene (an array such as [[block]] or a value), so it has no key '{}'. Fix: name a value in a table, e.g. fluid.wcsph.alpha or time.dt_max",
                parts[..=i].join("."),
                parts[i + 1]
            )
        })?;
    }
    table.insert(last.to_string(), value);
    Ok(())
}

/// The crest of each gauge in a run directory: the highest surface above the first reading,
/// within the gauge's window; None where the run ended before the window did.
fn crests(
    dir: &Path,
    windows: &[(String, f64, f64)],
    run_end: f64,
) -> Result<Vec<(String, Option<f64>)>, String> {
    let table = Table::read(&dir.join("gauges.csv"))?;
    let mut out = Vec::new();
    for (c, name) in table.header.iter().enumerate().skip(1) {
        if name.ends_with("_spray") {
            continue;
        }
        let window = windows.iter().find(|w| &w.0 == name);
        let (t0, t1) = window.map_or((0.0, f64::INFINITY), |w| (w.1, w.2));
        let still = (!table.rows.is_empty()).then(|| table.num(0, c));
        let reached = window.is_none_or(|w| run_end >= w.2 - 1e-9);
        let top = (0..table.rows.len())
            .filter(|&r| (t0..=t1).contains(&table.num(r, 0)))
            .map(|r| table.num(r, c))
            .filter(|v| v.is_finite())
            .fold(None, |m: Option<f64>, v| Some(m.map_or(v, |m| m.max(v))));
        let crest = match (still, top, reached) {
            (Some(s), Some(t), true) => Some((t - s).max(0.0)),
            _ => None,
        };
        out.push((name.clone(), crest));
    }
    Ok(out)
}

/// Where `x` falls among `values`: "lowest of 11", "3rd of 11 from the top", "highest of 11".
fn place(x: f64, values: &[f64]) -> String {
    let n = values.len();
    let above = values.iter().filter(|&&v| v > x).count();
    let below = values.iter().filter(|&&v| v < x).count();
    if below == 0 {
        format!("lowest of {n}")
    } else if above == 0 {
        format!("highest of {n}")
    } else {
        format!("{} of {n} from the top", above + 1)
    }
}

/// One row of `spread.csv` read back: the member's label, status and crests by gauge.
struct Row {
    member: String,
    status: String,
    crests: Vec<(String, Option<f64>)>,
}

const FIXED_COLUMNS: [&str; 6] = ["member", "key", "value", "status", "steps", "wall_s"];

fn csv_header(gauges: &[String]) -> String {
    let mut h = FIXED_COLUMNS.join(",");
    for g in gauges {
        write!(h, ",{g}").unwrap();
    }
    h
}

fn csv_row(i: usize, m: &Member, o: &RunOutcome, crests: &[(String, Option<f64>)]) -> String {
    // Commas cannot stand in a cell: an array value is written with ';'.
    let mut line = format!(
        "{i},{},{},{},{},{:.1}",
        m.key,
        m.value.replace(',', ";"),
        o.status.replace(',', ";"),
        o.steps,
        o.wall_seconds
    );
    for (_, c) in crests {
        match c {
            Some(v) => write!(line, ",{v:.5}").unwrap(),
            None => line.push(','),
        }
    }
    line
}

fn read_rows(path: &Path) -> Result<Vec<Row>, String> {
    let t = Table::read(path)?;
    if t.header.len() < FIXED_COLUMNS.len() || t.header[..FIXED_COLUMNS.len()] != FIXED_COLUMNS {
        return Err(format!(
            "{} is not a spread.csv written by `coupler spread` (its header is {:?})",
            path.display(),
            t.header
        ));
    }
    Ok((0..t.rows.len())
        .map(|r| Row {
            member: match t.rows[r][1].as_str() {
                "" => "base".to_string(),
                key => format!("{key} = {}", t.rows[r][2]),
            },
            status: t.rows[r][3].clone(),
            crests: (FIXED_COLUMNS.len()..t.header.len())
                .map(|c| {
                    (
                        t.header[c].clone(),
                        Some(t.num(r, c)).filter(|v| v.is_finite()),
                    )
                })
                .collect(),
        })
        .collect())
}

/// The completed members' crests at `gauge`.
fn crests_at(rows: &[Row], gauge: &str) -> Vec<f64> {
    rows.iter()
        .filter(|r| r.status == "completed")
        .filter_map(|r| r.crests.iter().find(|c| c.0 == gauge).and_then(|c| c.1))
        .collect()
}

/// The table `coupler spread` prints (and writes as `spread.md`).
fn table(rows: &[Row], windows: &[(String, f64, f64)], against: Option<&[Row]>) -> String {
    let mut s = String::new();
    let gauges: Vec<&String> = rows
        .first()
        .map(|r| r.crests.iter().map(|c| &c.0).collect())
        .unwrap_or_default();
    let mut head =
        "| gauge | window [s] | base crest [m] | median [m] | lowest – highest [m] | highest − lowest over median | the base run |".to_string();
    let mut rule = "|---|---|---:|---:|---|---:|---|".to_string();
    if against.is_some() {
        head.push_str(" median against the other spread's | within its range |");
        rule.push_str("---:|---|");
    }
    writeln!(s, "{head}\n{rule}").unwrap();
    for g in gauges {
        let window = windows
            .iter()
            .find(|w| &w.0 == g)
            .map_or("whole run".to_string(), |w| format!("{}–{}", w.1, w.2));
        let values = crests_at(rows, g);
        let base = rows
            .first()
            .filter(|r| r.status == "completed")
            .and_then(|r| r.crests.iter().find(|c| &c.0 == g).and_then(|c| c.1));
        if values.is_empty() {
            writeln!(
                s,
                "| {g} | {window} | – | – | – | – | no completed member read it |"
            )
            .unwrap();
            continue;
        }
        let (median, lo, hi) = median_range(&values);
        let spread = if median > 0.0 {
            format!("{:.1} %", 100.0 * (hi - lo) / median)
        } else {
            "–".into()
        };
        let (base_text, base_place) = match base {
            Some(b) => (format!("{b:.4}"), place(b, &values)),
            None => ("–".into(), "did not read it".into()),
        };
        write!(
            s,
            "| {g} | {window} | {base_text} | {median:.4} | {lo:.4} – {hi:.4} | {spread} | {base_place} |"
        )
        .unwrap();
        if let Some(other) = against {
            let theirs = crests_at(other, g);
            if theirs.is_empty() {
                write!(s, " – | – |").unwrap();
            } else {
                let (m, l, h) = median_range(&theirs);
                let rel = if m > 0.0 {
                    format!("{:+.1} %", 100.0 * (median - m) / m)
                } else {
                    "–".into()
                };
                let inside = if (l..=h).contains(&median) {
                    "yes"
                } else {
                    "no"
                };
                write!(s, " {rel} | {inside} |").unwrap();
            }
        }
        s.push('\n');
    }
    let stopped: Vec<String> = rows
        .iter()
        .filter(|r| r.status != "completed")
        .map(|r| format!("{} ({})", r.member, r.status))
        .collect();
    if !stopped.is_empty() {
        writeln!(s, "\nLeft out (did not complete): {}", stopped.join("; ")).unwrap();
    }
    s
}

/// The member scenes a spread writes into --out (empty or absent when it began) before its first
/// run: removed when dropped unless `kept`, so a spread refused before any run leaves nothing
/// and the same command can be given again once fixed ("--out is not empty" otherwise).
struct Written<'a> {
    out: &'a Path,
    /// Whether the spread made --out.
    made: bool,
    kept: bool,
}

impl Drop for Written<'_> {
    fn drop(&mut self) {
        if self.kept {
            return;
        }
        if self.made {
            let _ = std::fs::remove_dir_all(self.out);
            return;
        }
        for entry in std::fs::read_dir(self.out).into_iter().flatten().flatten() {
            let path = entry.path();
            let _ = if path.is_dir() {
                std::fs::remove_dir_all(&path)
            } else {
                std::fs::remove_file(&path)
            };
        }
    }
}

fn run_inner(args: &SpreadArgs) -> Result<(), String> {
    let windows = args
        .windows
        .iter()
        .map(|w| parse_window(w))
        .collect::<Result<Vec<_>, _>>()?;
    let mut members = vec![Member {
        key: String::new(),
        value: String::new(),
    }];
    for v in &args.vary {
        members.extend(parse_vary(v)?);
    }
    let against = match &args.against {
        Some(dir) => Some(read_rows(&dir.join("spread.csv"))?),
        None => None,
    };
    if args.out.exists()
        && std::fs::read_dir(&args.out)
            .map_err(|e| format!("cannot read --out {}: {e}", args.out.display()))?
            .next()
            .is_some()
    {
        return Err(format!(
            "--out {} is not empty; a spread never writes over runs. Fix: name a new directory",
            args.out.display()
        ));
    }
    let text = match &args.scene {
        Some(p) => std::fs::read_to_string(p)
            .map_err(|e| format!("cannot read the scene {}: {e}", p.display()))?,
        None => shared::scene::DEFAULT_SCENE.to_string(),
    };
    let mut origin = args
        .scene
        .as_ref()
        .map_or(shared::scene::DEFAULT_SCENE_ORIGIN.to_string(), |p| {
            p.display().to_string()
        });
    let mut base: toml::Table = toml::from_str(&text).map_err(|e| format!("{origin}: {e}"))?;
    // The member scenes live in --out: a terrain file named relative to the scene file is
    // named from the scene file's directory instead.
    let anchored = match &args.scene {
        Some(p) => anchor_files(&mut base, p.parent().unwrap_or(Path::new("."))),
        None => false,
    };
    for s in &args.set {
        let fixed = parse_vary(s).map_err(|e| e.replace("--vary", "--set"))?;
        let [m] = fixed.as_slice() else {
            return Err(format!(
                "--set '{s}' gives {} values; every run takes one. Fix: --set KEY=VALUE, and --vary for several",
                fixed.len()
            ));
        };
        set_key(&mut base, &m.key, toml_value(&m.value))
            .map_err(|e| e.replace("--vary", "--set"))?;
        write!(origin, ", {}", m.label()).unwrap();
    }

    // Every member's scene, written and checked before the first run starts; a refusal takes
    // them back.
    let mut written = Written {
        out: &args.out,
        made: !args.out.exists(),
        kept: false,
    };
    std::fs::create_dir_all(args.out.join("runs"))
        .map_err(|e| format!("cannot create {}: {e}", args.out.display()))?;
    let mut scenes = Vec::new();
    // The base scene's gauges: the spread's columns, in the scene's (and gauges.csv's) order.
    let mut gauges: Vec<String> = Vec::new();
    for (i, m) in members.iter().enumerate() {
        let path = args.out.join(format!("member_{i:02}.toml"));
        let body = if m.key.is_empty() && args.set.is_empty() && !anchored {
            text.clone()
        } else {
            let mut t = base.clone();
            if !m.key.is_empty() {
                set_key(&mut t, &m.key, toml_value(&m.value))?;
            }
            let mut body = format!("# {origin}; this run: {}\n", m.label());
            body.push_str(
                &toml::to_string(&t).map_err(|e| format!("cannot write {}: {e}", m.label()))?,
            );
            body
        };
        std::fs::write(&path, &body)
            .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        let scene = crate::run::scenes::load(Some(&path))
            .map_err(|e| format!("member {i} ({}): {e}", m.label()))?;
        check_run_args(&path, &args.run_args)
            .map_err(|e| format!("member {i} ({}): {e}", m.label()))?;
        if i == 0 {
            gauges = scene.gauges.iter().map(|g| g.name.clone()).collect();
            if gauges.is_empty() {
                return Err(format!(
                    "{origin} has no [[gauge]]: a spread tables gauge crests. Fix: add a [[gauge]] with name, x and y"
                ));
            }
            if let Some(w) = windows.iter().find(|w| !gauges.contains(&w.0)) {
                return Err(format!(
                    "--window {}: the scene has no gauge '{}' (its gauges: {}). Fix: name one of them",
                    w.0,
                    w.0,
                    gauges.join(", ")
                ));
            }
        }
        scenes.push(path);
    }
    written.kept = true;

    let mut csv = csv_header(&gauges) + "\n";
    let csv_path = args.out.join("spread.csv");
    for (i, (m, scene)) in members.iter().zip(&scenes).enumerate() {
        let dir = args.out.join("runs").join(format!("{i:02}"));
        println!("run {}/{}: {} …", i + 1, members.len(), m.label());
        let outcome = runner::coupler_run(scene, &args.run_args, &dir)?;
        let read = if dir.join("gauges.csv").is_file() {
            crests(&dir, &windows, outcome.time)?
        } else {
            Vec::new()
        };
        // A member without gauges.csv (it stopped before its first sample) gets empty cells.
        let row: Vec<(String, Option<f64>)> = gauges
            .iter()
            .map(|g| {
                let c = read.iter().find(|c| &c.0 == g).and_then(|c| c.1);
                (g.clone(), c)
            })
            .collect();
        csv.push_str(&csv_row(i, m, &outcome, &row));
        csv.push('\n');
        // Written after every member, so an interrupted spread keeps what it measured.
        std::fs::write(&csv_path, &csv)
            .map_err(|e| format!("cannot write {}: {e}", csv_path.display()))?;
        println!(
            "  {} in {:.1} s: {}",
            outcome.status,
            outcome.wall_seconds,
            row.iter()
                .map(|(g, c)| match c {
                    Some(v) => format!("{g} {v:.4}"),
                    None => format!("{g} –"),
                })
                .collect::<Vec<_>>()
                .join(", ")
        );
        if !outcome.completed() {
            println!("  {}", outcome.detail());
        }
    }
    let rows = read_rows(&csv_path)?;
    let out = table(&rows, &windows, against.as_deref());
    let md = args.out.join("spread.md");
    std::fs::write(&md, &out).map_err(|e| format!("cannot write {}: {e}", md.display()))?;
    println!("\n{out}\n  table: {}", md.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_key_is_set_in_tables_made_on_the_way() {
        let mut t: toml::Table = toml::from_str("[fluid]\nsolver = \"wcsph\"\n").unwrap();
        set_key(&mut t, "fluid.dfsph.viscosity", toml_value("0.05")).unwrap();
        set_key(&mut t, "fluid.solver", toml_value("dfsph")).unwrap();
        set_key(&mut t, "time.end", toml_value("3")).unwrap();
        assert_eq!(t["fluid"]["dfsph"]["viscosity"].as_float(), Some(0.05));
        assert_eq!(t["fluid"]["solver"].as_str(), Some("dfsph"));
        assert_eq!(t["time"]["end"].as_integer(), Some(3));
        assert_eq!(toml_value("true").as_bool(), Some(true));
        assert_eq!(toml_value("\"mirrored\"").as_str(), Some("mirrored"));
    }

    #[test]
    fn a_terrain_file_is_named_from_the_scene_files_directory() {
        let mut t: toml::Table = toml::from_str(
            "[[terrain]]\nfile = \"fjord/fjord.asc\"\n[[terrain]]\nfile = \"/abs/a.stl\"\n",
        )
        .unwrap();
        assert!(anchor_files(&mut t, Path::new("/data/scenes")));
        let files: Vec<&str> = t["terrain"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x["file"].as_str().unwrap())
            .collect();
        assert_eq!(files, ["/data/scenes/fjord/fjord.asc", "/abs/a.stl"]);
        let mut none: toml::Table = toml::from_str("[fluid]\ndx = 0.04\n").unwrap();
        assert!(!anchor_files(&mut none, Path::new("scenes")));
    }

    #[test]
    fn a_key_through_a_value_or_an_array_is_refused_by_name() {
        let mut t: toml::Table =
            toml::from_str("[fluid]\ndx = 0.04\n[[block]]\nname = \"a\"\n").unwrap();
        let e = set_key(&mut t, "fluid.dx.x", toml_value("1")).unwrap_err();
        assert!(e.contains("'fluid.dx' is not a table"), "{e}");
        let e = set_key(&mut t, "block.density", toml_value("1")).unwrap_err();
        assert!(
            e.contains("'block' is not a table") && e.contains("Fix:"),
            "{e}"
        );
    }

    #[test]
    fn bad_vary_and_window_arguments_are_named_with_the_fix() {
        assert_eq!(parse_vary("a.b=1, 2").unwrap().len(), 2);
        for bad in ["a.b", "=1", "a..b=1", "a.b=1,,2"] {
            let e = parse_vary(bad).unwrap_err();
            assert!(e.contains(bad) && e.contains("Fix:"), "{e}");
        }
        assert_eq!(
            parse_window("G1=0.7:1.3").unwrap(),
            ("G1".to_string(), 0.7, 1.3)
        );
        for bad in ["G1", "G1=0.7", "G1=1.3:0.7", "G1=a:1", "G1=-1:1"] {
            let e = parse_window(bad).unwrap_err();
            assert!(e.contains("Fix:"), "{e}");
        }
    }

    #[test]
    fn crests_are_read_above_the_first_reading_within_the_window() {
        let dir = std::env::temp_dir().join(format!(
            "rockwave-spread-{}-{}",
            std::process::id(),
            shared::transport::RunId::fresh()
        ));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(
            dir.join("gauges.csv"),
            "time,A,B,A_spray,B_spray\n0.0,0.5,0.5,0.5,0.5\n0.5,0.9,0.6,2.0,0.6\n1.0,0.7,0.8,0.7,0.8\n1.5,0.6,0.55,0.6,0.55\n",
        )
        .unwrap();
        // A's window excludes its 0.9 at t = 0.5; B has none; C's window the run never reached.
        let windows = vec![("A".to_string(), 0.8, 1.6), ("B2".to_string(), 0.0, 9.0)];
        let c = crests(&dir, &windows, 1.6).unwrap();
        assert_eq!(c.len(), 2, "the spray columns are not gauges: {c:?}");
        assert!((c[0].1.unwrap() - 0.2).abs() < 1e-12, "{c:?}");
        assert!((c[1].1.unwrap() - 0.3).abs() < 1e-12, "{c:?}");
        let short = crests(&dir, &windows, 1.0).unwrap();
        assert_eq!(
            short[0].1, None,
            "a window the run did not reach has no crest"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn the_table_gives_median_range_and_the_base_runs_place() {
        assert_eq!(place(1.0, &[1.0, 2.0, 3.0]), "lowest of 3");
        assert_eq!(place(2.0, &[1.0, 2.0, 3.0]), "2 of 3 from the top");
        assert_eq!(place(3.0, &[1.0, 2.0, 3.0]), "highest of 3");
        let row = |status: &str, g: Option<f64>| Row {
            member: "k = v".into(),
            status: status.into(),
            crests: vec![("G1".into(), g)],
        };
        let ours = [
            row("completed", Some(0.10)),
            row("completed", Some(0.12)),
            row("completed", Some(0.11)),
            row("unstable", Some(0.5)),
        ];
        let theirs = [row("completed", Some(0.10)), row("completed", Some(0.12))];
        let t = table(&ours, &[("G1".into(), 0.7, 1.3)], Some(&theirs));
        assert!(
            t.contains("| G1 | 0.7–1.3 | 0.1000 | 0.1100 | 0.1000 – 0.1200 | 18.2 % | lowest of 3 | +0.0 % | yes |"),
            "{t}"
        );
        assert!(
            t.contains("Left out (did not complete): k = v (unstable)"),
            "{t}"
        );
    }
}
