//! Charts of speed against accuracy and stability maps (plotters), each written as CSV, SVG and
//! PNG side by side.

use plotters::prelude::*;
use std::io::Write;
use std::path::Path;

/// One measured configuration: how long it took and how far from the reference it landed.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Sample {
    /// Series the point belongs to (e.g. "wcsph" or "explicit/parallel").
    pub series: String,
    /// The knobs that produced it (e.g. "dx=0.02 dt×1").
    pub params: String,
    pub wall_seconds: f64,
    /// Error against the reference (relative, unless the chart says otherwise).
    pub error: f64,
}

/// Indices of the samples no other sample beats in both time and error (the Pareto front),
/// sorted by time.
pub fn pareto_front(samples: &[Sample]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..samples.len())
        .filter(|&i| samples[i].error.is_finite())
        .collect();
    idx.sort_by(|&a, &b| {
        samples[a]
            .wall_seconds
            .total_cmp(&samples[b].wall_seconds)
            .then(samples[a].error.total_cmp(&samples[b].error))
    });
    let mut front = Vec::new();
    let mut best = f64::INFINITY;
    for i in idx {
        if samples[i].error < best {
            best = samples[i].error;
            front.push(i);
        }
    }
    front
}

/// Writes `<stem>.csv`: series, params, wall time, error, on the Pareto front.
pub fn write_csv(stem: &Path, samples: &[Sample]) -> std::io::Result<()> {
    let front = pareto_front(samples);
    let mut f = std::fs::File::create(stem.with_extension("csv"))?;
    writeln!(f, "series,params,wall_seconds,error,pareto")?;
    for (i, s) in samples.iter().enumerate() {
        writeln!(
            f,
            "{},{},{},{},{}",
            s.series,
            s.params,
            s.wall_seconds,
            s.error,
            front.contains(&i)
        )?;
    }
    Ok(())
}

/// The font plotters measures and draws text with. DejaVu Sans, from Debian's
/// fonts-dejavu-core, which `.ci/run` installs when missing.
const FONT_PATHS: &[&str] = &[
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
];

fn ensure_font() -> Result<(), String> {
    static DONE: std::sync::OnceLock<Result<(), String>> = std::sync::OnceLock::new();
    DONE.get_or_init(|| {
        let bytes = FONT_PATHS
            .iter()
            .find_map(|p| std::fs::read(p).ok())
            .ok_or_else(|| {
                format!(
                    "no font for PNG charts (looked for {}): install fonts-dejavu-core",
                    FONT_PATHS.join(", ")
                )
            })?;
        let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
        plotters::style::register_font("sans-serif", FontStyle::Normal, bytes)
            .map_err(|_| "the font could not be loaded".to_string())
    })
    .clone()
}

/// One colour per series (the coupled chart has 12: three fluids × two solids × two schemes):
/// the ten of matplotlib's "tab10" and two darker ones.
const PALETTE: [RGBColor; 12] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(23, 190, 207),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(0, 0, 128),
    RGBColor(0, 102, 102),
];

fn draw_error_vs_time<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    title: &str,
    error_label: &str,
    samples: &[Sample],
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| format!("drawing failed: {e:?}");
    root.fill(&WHITE).map_err(e)?;
    let finite: Vec<&Sample> = samples
        .iter()
        .filter(|s| s.error.is_finite() && s.error > 0.0 && s.wall_seconds > 0.0)
        .collect();
    if finite.is_empty() {
        return Err("no finite samples to chart".into());
    }
    let (tmin, tmax) = finite.iter().fold((f64::INFINITY, 0.0f64), |a, s| {
        (a.0.min(s.wall_seconds), a.1.max(s.wall_seconds))
    });
    let (emin, emax) = finite.iter().fold((f64::INFINITY, 0.0f64), |a, s| {
        (a.0.min(s.error), a.1.max(s.error))
    });
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 22))
        .margin(16)
        .x_label_area_size(48)
        .y_label_area_size(70)
        .build_cartesian_2d(
            (tmin / 1.5..tmax * 1.5).log_scale(),
            (emin / 1.5..emax * 1.5).log_scale(),
        )
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc("wall time [s]")
        .y_desc(error_label)
        .x_labels(8)
        .y_labels(8)
        .x_label_formatter(&|v: &f64| short(*v))
        .y_label_formatter(&|v: &f64| short(*v))
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(e)?;
    let mut series: Vec<&str> = finite.iter().map(|s| s.series.as_str()).collect();
    series.dedup();
    series.sort();
    series.dedup();
    for (k, name) in series.iter().enumerate() {
        let color = PALETTE[k % PALETTE.len()];
        let pts: Vec<(f64, f64)> = finite
            .iter()
            .filter(|s| s.series == *name)
            .map(|s| (s.wall_seconds, s.error))
            .collect();
        chart
            .draw_series(pts.iter().map(|&p| Circle::new(p, 5, color.filled())))
            .map_err(e)?
            .label(*name)
            .legend(move |(x, y)| Circle::new((x + 8, y), 5, color.filled()));
    }
    let front: Vec<(f64, f64)> = pareto_front(samples)
        .iter()
        .map(|&i| (samples[i].wall_seconds, samples[i].error))
        .collect();
    chart
        .draw_series(LineSeries::new(front.clone(), BLACK.stroke_width(2)))
        .map_err(e)?
        .label("Pareto front")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], BLACK.stroke_width(2)));
    chart
        .draw_series(
            front
                .iter()
                .map(|&p| Circle::new(p, 8, BLACK.stroke_width(2))),
        )
        .map_err(e)?;
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .draw()
        .map_err(e)?;
    root.present().map_err(e)?;
    Ok(())
}

/// A tick label with three significant digits and no float noise (0.30000000000000004 → 0.3).
fn short(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let digits = (2 - v.abs().log10().floor() as i32).max(0) as usize;
    let s = format!("{v:.digits$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// Writes `<stem>.csv`, `<stem>.svg` and `<stem>.png`: error against wall time on log–log axes,
/// one colour per series, the Pareto front drawn through the undominated points.
pub fn error_vs_time(
    stem: &Path,
    title: &str,
    error_label: &str,
    samples: &[Sample],
) -> Result<(), String> {
    write_csv(stem, samples)
        .map_err(|e| format!("cannot write {}: {e}", stem.with_extension("csv").display()))?;
    // Both backends measure text with the font, so it is needed for the SVG too.
    ensure_font()?;
    let svg = stem.with_extension("svg");
    draw_error_vs_time(
        SVGBackend::new(&svg, (900, 600)).into_drawing_area(),
        title,
        error_label,
        samples,
    )?;
    let png = stem.with_extension("png");
    draw_error_vs_time(
        BitMapBackend::new(&png, (900, 600)).into_drawing_area(),
        title,
        error_label,
        samples,
    )
}

/// One cell of a stability map.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Trial {
    /// The method (row), e.g. "explicit DDA" or "wcsph, parallel".
    pub method: String,
    /// The pushed parameter (column), e.g. the dt factor.
    pub value: f64,
    pub stable: bool,
    /// How instability was detected (the run's message), or what was measured when stable.
    pub detail: String,
}

fn draw_stability<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    title: &str,
    x_label: &str,
    trials: &[Trial],
    label_width: u32,
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| format!("drawing failed: {e:?}");
    root.fill(&WHITE).map_err(e)?;
    let mut methods: Vec<&str> = Vec::new();
    for t in trials {
        if !methods.contains(&t.method.as_str()) {
            methods.push(&t.method);
        }
    }
    let (vmin, vmax) = trials.iter().fold((f64::INFINITY, 0.0f64), |a, t| {
        (a.0.min(t.value), a.1.max(t.value))
    });
    let n = methods.len() as f64;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 22))
        .margin(16)
        .x_label_area_size(48)
        .y_label_area_size(label_width)
        // One empty row below the methods holds the legend.
        .build_cartesian_2d((vmin / 1.6..vmax * 1.6).log_scale(), -1.5..n - 0.5)
        .map_err(e)?;
    let labels = methods.clone();
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_labels(2 * (methods.len() + 2))
        .y_label_formatter(&move |y: &f64| {
            let i = y.round();
            if (y - i).abs() < 1e-6 && i >= 0.0 {
                labels
                    .get(i as usize)
                    .map(|s| s.to_string())
                    .unwrap_or_default()
            } else {
                String::new()
            }
        })
        .disable_y_mesh()
        .label_style(("sans-serif", 13))
        .draw()
        .map_err(e)?;
    let green = RGBColor(44, 160, 44);
    let red = RGBColor(214, 39, 40);
    for t in trials {
        let row = methods.iter().position(|m| *m == t.method).unwrap_or(0) as f64;
        let style = if t.stable {
            green.filled()
        } else {
            red.filled()
        };
        chart
            .draw_series(std::iter::once(Circle::new((t.value, row), 9, style)))
            .map_err(e)?;
    }
    // Legend entries only: no points (a point outside the range would still be drawn).
    chart
        .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())
        .map_err(e)?
        .label("stable")
        .legend(move |(x, y)| Circle::new((x + 8, y), 6, green.filled()));
    chart
        .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())
        .map_err(e)?
        .label("unstable (detected, named)")
        .legend(move |(x, y)| Circle::new((x + 8, y), 6, red.filled()));
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 13))
        .draw()
        .map_err(e)?;
    root.present().map_err(e)?;
    Ok(())
}

/// Writes `<stem>.csv`, `<stem>.svg` and `<stem>.png`: one row per method, one dot per pushed
/// value, green where the run stayed stable and red where it stopped with a named instability.
pub fn stability_map(
    stem: &Path,
    title: &str,
    x_label: &str,
    trials: &[Trial],
) -> Result<(), String> {
    let mut f = std::fs::File::create(stem.with_extension("csv")).map_err(|e| e.to_string())?;
    writeln!(f, "method,value,stable,detail").map_err(|e| e.to_string())?;
    for t in trials {
        writeln!(
            f,
            "\"{}\",{},{},\"{}\"",
            t.method.replace('"', "'"),
            t.value,
            t.stable,
            t.detail.replace('"', "'")
        )
        .map_err(|e| e.to_string())?;
    }
    let h = 200
        + 60 * trials
            .iter()
            .map(|t| &t.method)
            .collect::<std::collections::BTreeSet<_>>()
            .len() as u32;
    // Room for the longest row label (about 6 px a character at the labels' size), the plot
    // keeping its 700 px.
    let longest = trials
        .iter()
        .map(|t| t.method.chars().count())
        .max()
        .unwrap_or(0) as u32;
    let label_width = (6 * longest + 24).max(300);
    let w = 700 + label_width;
    ensure_font()?;
    let svg = stem.with_extension("svg");
    draw_stability(
        SVGBackend::new(&svg, (w, h)).into_drawing_area(),
        title,
        x_label,
        trials,
        label_width,
    )?;
    let png = stem.with_extension("png");
    draw_stability(
        BitMapBackend::new(&png, (w, h)).into_drawing_area(),
        title,
        x_label,
        trials,
        label_width,
    )
}

/// Splits one CSV line, honouring double quotes (no escaped quotes inside: the writers here
/// replace them).
fn split_csv(line: &str) -> Vec<String> {
    let mut out = vec![String::new()];
    let mut quoted = false;
    for c in line.chars() {
        match c {
            '"' => quoted = !quoted,
            ',' if !quoted => out.push(String::new()),
            c => out.last_mut().expect("one cell").push(c),
        }
    }
    out
}

/// Reads the samples back from a CSV written by [`error_vs_time`] (to redraw a chart).
pub fn read_samples(stem: &Path) -> Result<Vec<Sample>, String> {
    let path = stem.with_extension("csv");
    let text = std::fs::read_to_string(&path)
        .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    text.lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let c = split_csv(l);
            let num = |i: usize| c.get(i).and_then(|v| v.parse::<f64>().ok());
            match (num(2), num(3)) {
                (Some(wall_seconds), Some(error)) => Ok(Sample {
                    series: c[0].clone(),
                    params: c[1].clone(),
                    wall_seconds,
                    error,
                }),
                _ => Err(format!("bad line in {}: {l}", path.display())),
            }
        })
        .collect()
}

/// Reads the trials back from a CSV written by [`stability_map`].
pub fn read_trials(stem: &Path) -> Result<Vec<Trial>, String> {
    let path = stem.with_extension("csv");
    let text = std::fs::read_to_string(&path)
        .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    text.lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let c = split_csv(l);
            match (c.get(1).and_then(|v| v.parse().ok()), c.get(2)) {
                (Some(value), Some(stable)) => Ok(Trial {
                    method: c[0].clone(),
                    value,
                    stable: stable == "true",
                    detail: c.get(3).cloned().unwrap_or_default(),
                }),
                _ => Err(format!("bad line in {}: {l}", path.display())),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(series: &str, t: f64, e: f64) -> Sample {
        Sample {
            series: series.into(),
            params: String::new(),
            wall_seconds: t,
            error: e,
        }
    }

    #[test]
    fn tick_labels_are_short() {
        assert_eq!(short(0.30000000000000004), "0.3");
        assert_eq!(short(0.0227), "0.0227");
        assert_eq!(short(100.0), "100");
        assert_eq!(short(52.95), "53");
    }

    #[test]
    fn pareto_front_keeps_only_undominated_points() {
        let samples = vec![
            s("a", 1.0, 0.5),
            s("a", 2.0, 0.6),
            s("b", 3.0, 0.1),
            s("b", 0.5, 0.9),
            s("b", 4.0, f64::NAN),
        ];
        assert_eq!(pareto_front(&samples), vec![3, 0, 2]);
    }

    #[test]
    fn charts_are_written() {
        let dir = std::env::temp_dir().join(format!("rockwave-chart-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let samples = vec![s("a", 1.0, 0.5), s("a", 2.0, 0.2), s("b", 3.0, 0.1)];
        error_vs_time(&dir.join("c"), "test", "error", &samples).unwrap();
        let svg = std::fs::read_to_string(dir.join("c.svg")).unwrap();
        assert!(svg.contains("<svg") && svg.contains("Pareto"));
        assert!(std::fs::metadata(dir.join("c.png")).unwrap().len() > 1000);
        let trials = vec![
            Trial {
                method: "explicit".into(),
                value: 0.5,
                stable: true,
                detail: String::new(),
            },
            Trial {
                method: "explicit".into(),
                value: 4.0,
                stable: false,
                detail: "energy grew".into(),
            },
        ];
        stability_map(&dir.join("m"), "map", "dt factor", &trials).unwrap();
        let back = read_trials(&dir.join("m")).unwrap();
        assert_eq!(back.len(), 2);
        assert!(!back[0].stable || back[0].value == 0.5);
        assert_eq!(back[1].detail, "energy grew");
        let samples_back = read_samples(&dir.join("c")).unwrap();
        assert_eq!(samples_back.len(), 3);
        assert_eq!(samples_back[1].error, 0.2);
        assert!(
            std::fs::read_to_string(dir.join("m.csv"))
                .unwrap()
                .contains("energy grew")
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
