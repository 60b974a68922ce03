//! The impact-pressure study of docs/VALIDATION.md ("Impact pressure"): one Lobovský et al.
//! (2014) dam-break run, its sensors' pulses read three ways (the water's pressure over the
//! face, the wall's load behind it, the wall's load along the middle half of the width), and
//! optionally the probe series as CSV.
//!
//! `cargo run --release -p fluid-node --example impact_study -- H PER_H [--window W]
//! [--solver NAME] [--param 'key = value']... [--end-star T] [--dt-max S] [--layers N] [--grid-shift M] [--row-shift A] [--row-draw D] [--draws K] [--profile] [--csv FILE]`; with H = 0.6 also
//! sensor 1's impulse against the paper's median (the impulse row of `fluid-validate`), with
//! H = 0.3 each sensor's impulse and highest 5–20 ms means against one run of the experiment
//! (`LOBOVSKY_H300_EVENT5`). `--draws K` (with `--row-shift`) runs draws D … D+K−1 of the
//! shifted rows instead (D from `--row-draw`, 0 by default) and prints sensor 1's peak and
//! impulse per draw and their median and range: an ensemble of starts, against the
//! experiment's repeated runs. `--profile` also
//! reads the wall at every cell's height up to H, in both readings, and prints where along
//! the height the impulse falls and its sum (the wall's load per metre of its width), and at
//! H = 0.6 the mean over its lowest 1, 2, 4 and 8 cells (what a coarser run's lowest cell
//! could read at best).
//! Several resolutions, `PER_H` = `15,30,60` (one ratio apart), make a resolution study: the
//! runs (or `--draws K` of each) at every one, then where each reading's medians converge,
//! Richardson's extrapolate to zero spacing and its grid convergence index.

use fluid_node::validation::{
    Impact, ImpactCase, LOAD_BOXES, LOBOVSKY_H300, LOBOVSKY_H300_EVENT5,
    LOBOVSKY_H600_S1_IMPACT_TIME, LOBOVSKY_H600_S1_IMPULSE, Profile, RINGING_SPAN, ROW_INTERVAL,
    STRIP, WALL, dry_as_zero, impact, integral, observed_order, richardson,
};
use shared::report::median_range;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("--experiment") {
        return experiment(&args[1..]);
    }
    let height: f64 = args.first().and_then(|a| a.parse().ok()).expect("H PER_H");
    // PER_H, or several (coarse to fine, one ratio apart) for a resolution study.
    let resolutions: Vec<usize> = args
        .get(1)
        .map(|a| a.split(',').map(|n| n.parse().expect("PER_H")).collect())
        .expect("H PER_H");
    let (mut solver, mut csv, mut draws) = ("wcsph".to_string(), None, None);
    let (mut options, mut params, mut cells) = (Vec::new(), Vec::new(), false);
    let mut i = 2;
    while i < args.len() {
        if args[i] == "--profile" {
            cells = true;
            i += 1;
            continue;
        }
        let v = args.get(i + 1).cloned().expect("a value after the option");
        match args[i].as_str() {
            "--solver" => solver = v,
            "--param" => params.push(v),
            "--csv" => csv = Some(v),
            "--draws" => draws = Some(v.parse::<u32>().expect("number of draws")),
            o => options.push((o.to_string(), v)),
        }
        i += 2;
    }
    // The case at one resolution, with the options.
    let case_at = |per_h: usize| {
        let mut case = ImpactCase::new(height, per_h, None);
        for (o, v) in &options {
            match o.as_str() {
                "--window" => case.window = Some(v.parse().expect("window [s]")),
                "--end-star" => case.end_star = v.parse().expect("t·sqrt(g/H)"),
                "--dt-max" => case.dt_max = v.parse().expect("largest step [s]"),
                "--layers" => case.layers = v.parse().expect("particle layers across the slab"),
                "--grid-shift" => case.grid_shift = v.parse().expect("grid shift [m]"),
                "--row-shift" => case.row_shift = v.parse().expect("row shift [dx]"),
                "--row-draw" => case.row_draw = v.parse().expect("draw of the shifted rows"),
                o => panic!("unknown option {o}"),
            }
        }
        case.params = params.join("\n");
        case.profile = cells;
        case
    };
    if resolutions.len() > 1 {
        return study(&solver, &resolutions, draws.unwrap_or(1), case_at);
    }
    let mut case = case_at(resolutions[0]);
    if let Some(k) = draws {
        assert!(case.row_shift > 0.0, "--draws needs --row-shift");
        ensemble(&solver, &mut case, k);
        return;
    }
    let r = impact(&solver, &case).expect("run");
    println!(
        "H = {} m, H/dx = {}, window {:?}, {solver} {:?}: {} particles, {} steps, {:.1} s (tank {:.4} m)",
        case.height,
        case.per_h,
        case.window,
        case.params,
        r.particles,
        r.steps,
        r.seconds,
        case.length
    );
    // Each sensor read twice: the water's pressure over its face, and the wall's load behind
    // it (docs/VALIDATION.md, "What a sensor reads").
    for (at, reading) in [
        (0, "the water's pressure over the face"),
        (WALL, "the wall's load"),
        (STRIP, "the wall's load along the middle half of the width"),
    ] {
        println!(" {reading}:");
        report(&r, &case, at);
    }
    if let Some(p) = r.profile(LOBOVSKY_H600_S1_IMPACT_TIME) {
        profile(&p, &case);
    }
    if let Some(path) = csv {
        let mut out = String::from(
            "time,s1,s2,s3,s4,s1_wall,s2_wall,s3_wall,s4_wall,s1_strip,s2_strip,s3_strip,s4_strip",
        );
        if case.profile {
            for suffix in ["", "_wall"] {
                for k in 0..case.per_h {
                    out.push_str(&format!(",z{k}{suffix}"));
                }
            }
        }
        out.push('\n');
        for (k, t) in r.times.iter().enumerate() {
            out.push_str(&format!("{t}"));
            for s in &r.series {
                out.push_str(&format!(",{}", s[k]));
            }
            out.push('\n');
        }
        std::fs::write(path, out).expect("write csv");
    }
}

/// Where along the wall's height the impulse falls in each reading, and its sum.
fn profile(p: &Profile, case: &ImpactCase) {
    println!(
        " the wall's height, impulse over the impact time ({:.0} ms) from the first onset at t* {:.3}, each cell's strip:",
        1e3 * LOBOVSKY_H600_S1_IMPACT_TIME,
        p.start * (9.81 / case.height).sqrt()
    );
    println!("  z [mm]  pressure  wall [mbar·s]  wall/pressure");
    for (z, ip, iw) in &p.cells {
        println!(
            "  {:6.1} {:9.3} {:9.3}  {:6.3}",
            1e3 * z,
            ip / 100.0,
            iw / 100.0,
            iw / ip
        );
    }
    println!(
        "  below H, per metre of the wall's width: pressure {:.2} N·s, wall {:.2} N·s ({:+.1} %)",
        p.pressure,
        p.wall,
        100.0 * (p.wall / p.pressure - 1.0)
    );
    // What a reading averaged over a coarser run's lowest cell could take at best, from this
    // run's profile (docs/VALIDATION.md, "What a cell can read"); the median is H = 600 mm's.
    if (case.height - 0.6).abs() > 1e-9 {
        return;
    }
    let median = LOBOVSKY_H600_S1_IMPULSE / 100.0;
    for cells in [1, 2, 4, 8] {
        if let Some((ip, iw)) = p.lowest(cells) {
            println!(
                "  mean over the lowest {:.0} mm: pressure {:.3} ({:+.1} % of the median), wall {:.3} mbar·s ({:+.1} %)",
                1e3 * cells as f64 * case.dx(),
                ip / 100.0,
                100.0 * (ip / 100.0 / median - 1.0),
                iw / 100.0,
                100.0 * (iw / 100.0 / median - 1.0)
            );
        }
    }
}

/// The pulses, the spread and ringing of sensor 1, and the comparison with the experiment, of
/// the series from `at` on (0: the water's pressure, `WALL`: the wall's load).
fn report(r: &Impact, case: &ImpactCase, at: usize) {
    let star = (9.81 / case.height).sqrt();
    for (s, p) in LOBOVSKY_H300.iter().zip(&r.pulses[at..]) {
        match p {
            Some(p) => println!(
                "  {} z = {:.3}: peak {:7.0} Pa at t* {:.3}, rise {:5.1} ms, decay {:6.1} ms, impulse {:7.1} Pa·s",
                s.name,
                s.z,
                p.peak,
                p.t_peak * star,
                1e3 * p.rise,
                1e3 * p.decay,
                p.impulse
            ),
            None => println!("  {}: no pulse", s.name),
        }
    }
    // How far sensor 1 swings about its level through the impact (docs/VALIDATION.md, "What
    // the DFSPH peak is").
    if let (Some((mean, sd)), Some((_, onset))) = (
        r.spread(at, LOBOVSKY_H600_S1_IMPACT_TIME),
        r.impulse(at, LOBOVSKY_H600_S1_IMPACT_TIME),
    ) {
        println!(
            "  s1 over the impact time ({:.0} ms) from the onset at t* {:.3}: mean {mean:.0} Pa, standard deviation {sd:.0} Pa",
            1e3 * LOBOVSKY_H600_S1_IMPACT_TIME,
            onset * star
        );
    }
    // The period the wall rings at after the peak, and the highest mean over one such period
    // (a box that removes the ringing and its harmonics) within the impact time from the
    // onset: a diagnosis, not a reading (docs/VALIDATION.md, "What the Riemann crest is").
    if let (Some(period), Some((_, onset))) = (
        r.ringing_period(at),
        r.impulse(at, LOBOVSKY_H600_S1_IMPACT_TIME),
    ) {
        let p = dry_as_zero(&r.series[at]);
        let boxed = r
            .times
            .iter()
            .filter(|&&t| t >= onset + period && t <= onset + LOBOVSKY_H600_S1_IMPACT_TIME)
            .map(|&t| integral(&r.times, &p, t - period, t) / period)
            .fold(f64::NEG_INFINITY, f64::max);
        println!(
            "  s1 rings every {:.1} ms after its peak (the autocorrelation over {:.0} ms); its highest mean over one period: {boxed:.0} Pa",
            1e3 * period,
            1e3 * (RINGING_SPAN.0 + RINGING_SPAN.1)
        );
    }
    // One run of the experiment at H = 300 mm, reduced as ours (docs/VALIDATION.md, "One run
    // of the experiment"): the load over the impact time and over boxes of 5–20 ms.
    if (case.height - 0.3).abs() < 1e-9 {
        let span = LOBOVSKY_H600_S1_IMPACT_TIME;
        let pct = |ours: f64, theirs: f64| 100.0 * (ours / theirs - 1.0);
        for (k, (s, e)) in LOBOVSKY_H300.iter().zip(&LOBOVSKY_H300_EVENT5).enumerate() {
            let Some((impulse, onset)) = r.impulse(at + k, span) else {
                println!("  {} against the experiment's event 5: no onset", s.name);
                continue;
            };
            let boxes: Vec<String> = LOAD_BOXES
                .iter()
                .zip(e.boxed)
                .map(|(&w, theirs)| {
                    let ours = r.box_peak(at + k, w, span).unwrap_or(f64::NAN);
                    format!("{:.0} ms {ours:.0} ({:+.0} %)", 1e3 * w, pct(ours, theirs))
                })
                .collect();
            let peak = r.first_pulse(at + k).map_or(f64::NAN, |p| p.peak);
            println!(
                "  {} against the experiment's event 5: onset t* {:.3} ({:.3}), impulse {impulse:.1} Pa·s ({:+.1} %), highest means 1 ms {peak:.0} ({:+.0} %), {}",
                s.name,
                onset * star,
                e.onset_star,
                pct(impulse, e.impulse),
                pct(peak, e.peak),
                boxes.join(", ")
            );
        }
    }
    // The paper's impulse is for H = 600 mm (`fluid-validate`'s impulse row).
    if (case.height - 0.6).abs() < 1e-9
        && let Some((impulse, onset)) = r.impulse(at, LOBOVSKY_H600_S1_IMPACT_TIME)
    {
        println!(
            "  s1 impulse over the impact time ({:.0} ms) from the onset at t* {:.3}: {impulse:.1} Pa·s ({:+.1} % of the median)",
            1e3 * LOBOVSKY_H600_S1_IMPACT_TIME,
            onset * star,
            100.0 * (impulse / LOBOVSKY_H600_S1_IMPULSE - 1.0)
        );
    }
}

/// The three readings of sensor 1: the water's pressure, the wall's load behind the disk, and
/// along the strip.
const READINGS: [(usize, &str); 3] = [(0, "pressure"), (WALL, "wall"), (STRIP, "strip")];

/// Sensor 1's peak [Pa] (the first pulse's, over the impact time) and impulse over the impact
/// time from the onset [Pa·s], in each reading ([`READINGS`]), of draws D … D+k−1 (D the
/// case's `row_draw`, `--row-draw`, 0 by default); then each one's median and range over the
/// draws, which it returns: (peak, impulse) per reading.
fn ensemble(solver: &str, case: &mut ImpactCase, k: u32) -> Vec<(f64, f64)> {
    let mut peaks = vec![Vec::new(); READINGS.len()];
    let mut impulses = vec![Vec::new(); READINGS.len()];
    let mut medians = Vec::new();
    let first = case.row_draw;
    for draw in first..first + k {
        case.row_draw = draw;
        let r = impact(solver, case).expect("run");
        let mut line = format!("draw {draw} ({} steps, {:.0} s):", r.steps, r.seconds);
        for (n, &(at, name)) in READINGS.iter().enumerate() {
            let peak = r.first_pulse(at).map_or(f64::NAN, |p| p.peak);
            let impulse = r
                .impulse(at, LOBOVSKY_H600_S1_IMPACT_TIME)
                .map_or(f64::NAN, |(i, _)| i);
            line += &format!(" {name} {:.1} mbar, {impulse:.1} Pa·s;", peak / 100.0);
            peaks[n].push(peak);
            impulses[n].push(impulse);
        }
        println!("{line}");
    }
    let h300 = (case.height - 0.3).abs() < 1e-9;
    for (n, &(_, name)) in READINGS.iter().enumerate() {
        let (pm, plo, phi) = median_range(&peaks[n]);
        let (im, ilo, ihi) = median_range(&impulses[n]);
        let against = if h300 {
            format!(
                "peak band {:.1}–{:.1} mbar",
                LOBOVSKY_H300[0].p025 / 100.0,
                LOBOVSKY_H300[0].p975 / 100.0
            )
        } else {
            format!(
                "impulse {:+.1} % of the median ({:+.1} … {:+.1} %)",
                100.0 * (im / LOBOVSKY_H600_S1_IMPULSE - 1.0),
                100.0 * (ilo / LOBOVSKY_H600_S1_IMPULSE - 1.0),
                100.0 * (ihi / LOBOVSKY_H600_S1_IMPULSE - 1.0)
            )
        };
        println!(
            " s1 {name} over {k} draws: peak median {:.1} mbar ({:.1} … {:.1}), impulse median {im:.1} Pa·s ({ilo:.1} … {ihi:.1}); {against}",
            pm / 100.0,
            plo / 100.0,
            phi / 100.0
        );
        medians.push((pm, im));
    }
    medians
}

/// A resolution study: [`ensemble`] of `k` draws (one without `--draws`) at each
/// of `resolutions` (coarse to fine, one ratio apart), then where each reading's medians of
/// sensor 1's peak and impulse converge: Richardson's extrapolate to zero spacing and the
/// finest run's grid convergence index (`fluid_node::validation::richardson`), for a
/// first-order error (the wall's load at the bed is the water's stress averaged over the
/// kernel's reach, its impulse short in proportion to h: docs/VALIDATION.md, "Where the wall's
/// impulse goes").
fn study(solver: &str, resolutions: &[usize], k: u32, case_at: impl Fn(usize) -> ImpactCase) {
    let ratio = resolutions[1] as f64 / resolutions[0] as f64;
    assert!(
        resolutions
            .windows(2)
            .all(|w| (w[1] as f64 / w[0] as f64 - ratio).abs() < 1e-9 && ratio > 1.0),
        "the resolutions of a study grow by one ratio: {resolutions:?}"
    );
    let (mut medians, mut height) = (Vec::new(), 0.0);
    for &per_h in resolutions {
        let mut case = case_at(per_h);
        height = case.height;
        println!(
            "H = {height} m, H/dx = {per_h}, {solver} {:?}:",
            case.params
        );
        medians.push(ensemble(solver, &mut case, k));
    }
    let h300 = (height - 0.3).abs() < 1e-9;
    println!("where the medians converge, H/dx {resolutions:?} (first-order error):");
    for (n, &(_, name)) in READINGS.iter().enumerate() {
        for (quantity, unit, of) in [("peak", "mbar", 0), ("impulse", "mbar·s", 1)] {
            // [Pa] and [Pa·s] to mbar and mbar·s.
            let values: Vec<f64> = medians
                .iter()
                .map(|m| if of == 0 { m[n].0 } else { m[n].1 } / 100.0)
                .collect();
            let shown: Vec<String> = values.iter().map(|v| format!("{v:.2}")).collect();
            let observed = match observed_order(&values, ratio) {
                Some(p) => format!("{p:.2}"),
                None if values.len() < 3 => "none (two runs)".into(),
                None => "none (not monotone)".into(),
            };
            let Some(e) = richardson(&values, ratio, 1.0) else {
                println!(
                    " s1 {name} {quantity}: {} {unit}; observed order {observed}: no extrapolate (not in the asymptotic range, or a run without a pulse)",
                    shown.join(" → ")
                );
                continue;
            };
            let against = match (of, h300) {
                (0, true) => format!(
                    " (band {:.1}–{:.1})",
                    LOBOVSKY_H300[0].p025 / 100.0,
                    LOBOVSKY_H300[0].p975 / 100.0
                ),
                (1, false) => format!(
                    " ({:+.1} % of the median)",
                    100.0 * (100.0 * e.value / LOBOVSKY_H600_S1_IMPULSE - 1.0)
                ),
                _ => String::new(),
            };
            println!(
                " s1 {name} {quantity}: {} {unit}; observed order {observed}; at dx → 0 (order {:.2}) {:.2} {unit}{against}, GCI {:.1} %",
                shown.join(" → "),
                e.order,
                e.value,
                100.0 * e.gci
            );
        }
    }
}

/// `--experiment FILE [H]`: a raw sensor series of the experiment, rows of (t·sqrt(g/H),
/// p/(ρ0 g H)), reduced as ours (1 ms means every `ROW_INTERVAL`, then `Impact`'s onset,
/// peak, impulse and box means): how `LOBOVSKY_H300_EVENT5` was made (docs/REFERENCES.md §1.3).
fn experiment(args: &[String]) {
    let file = args.first().expect("--experiment FILE [H]");
    let height: f64 = args.get(1).map_or(0.3, |h| h.parse().expect("H [m]"));
    let (star, rgh) = ((9.81 / height).sqrt(), 1000.0 * 9.81 * height);
    let text = std::fs::read_to_string(file).expect("read the series");
    let (ts, ps): (Vec<f64>, Vec<f64>) = text
        .lines()
        .filter(|l| !l.trim().is_empty() && !l.starts_with('#'))
        .map(|l| {
            let v: Vec<f64> = l
                .split_whitespace()
                .map(|x| x.parse().expect("a number"))
                .collect();
            (v[0] / star, v[1] * rgh)
        })
        .unzip();
    let dt = ts[1] - ts[0];
    let (n, every) = (
        (1e-3 / dt).round() as usize,
        (ROW_INTERVAL / dt).round() as usize,
    );
    let rows: Vec<usize> = (n - 1..ps.len()).step_by(every).collect();
    let run = Impact {
        case: ImpactCase::new(height, 15, Some(1e-3)),
        times: rows.iter().map(|&i| ts[i]).collect(),
        series: vec![
            rows.iter()
                .map(|&i| ps[i + 1 - n..=i].iter().sum::<f64>() / n as f64)
                .collect(),
        ],
        pulses: vec![None],
        particles: 0,
        steps: 0,
        seconds: 0.0,
    };
    let span = LOBOVSKY_H600_S1_IMPACT_TIME;
    let (impulse, onset) = run.impulse(0, span).expect("an onset");
    let peak = run.first_pulse(0).map_or(f64::NAN, |p| p.peak);
    let boxes: Vec<String> = LOAD_BOXES
        .iter()
        .map(|&w| {
            format!(
                "{:.0} ms {:.0}",
                1e3 * w,
                run.box_peak(0, w, span).unwrap_or(f64::NAN)
            )
        })
        .collect();
    println!(
        "{file}: {:.0} Hz, onset t* {:.3}, highest 1 ms mean {peak:.0} Pa, impulse {impulse:.1} Pa·s, highest means {}",
        1.0 / dt,
        onset * star,
        boxes.join(", ")
    );
}
