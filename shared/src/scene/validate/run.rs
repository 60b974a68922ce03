//! The run's frame: the scene's name and gravity, `[time]`, `[domain]` and `[output]`.

use super::checker::Checker;
use crate::math::readable;
use crate::scene::schema::Scene;

/// Largest domain coordinate [m]: a 10 000 km box holds any landslide tsunami.
const MAX_DOMAIN: f64 = 1e7;
/// Most output frames a run may ask for (time.end / output.interval), unless the scene raises
/// it with `output.max_frames`.
const MAX_FRAMES: f64 = 1e4;

/// `name` (it names the run directory) and `gravity`.
pub(super) fn name_and_gravity(c: &mut Checker, s: &Scene) {
    if s.name.trim().is_empty() {
        c.fail(
            "name",
            &s.name,
            "is empty",
            "give the scene a short name, e.g. name = \"wedge\"",
        );
    } else if s.name.starts_with('.')
        || s.name.len() > 100
        || !s
            .name
            .chars()
            .all(|ch| ch.is_ascii_alphanumeric() || matches!(ch, '_' | '-' | '.'))
    {
        c.fail(
            "name",
            &s.name,
            "names the run directory (runs/<name>-<run id>) and must be one plain file name: \
             no '/', '..', spaces or other characters, not starting with '.', at most 100 characters",
            "use letters, digits, '_', '-' and '.', e.g. name = \"sliding_wedge\"",
        );
    }
    c.finite3("gravity", s.gravity);
    if s.gravity.iter().any(|g| g.abs() > 1e3) {
        c.fail(
            "gravity",
            s.gravity,
            "is more than 100 g",
            "give gravity in m/s², e.g. gravity = [0, 0, -9.81]",
        );
    }
}

/// `[time]`: the end and the bounds of the step.
pub(super) fn time(c: &mut Checker, s: &Scene) {
    c.key("time", |c| {
        c.positive(
            "end",
            s.time.end,
            "give the simulated end time in seconds, e.g. end = 3.0",
        );
        c.positive(
            "dt_max",
            s.time.dt_max,
            "give the largest step in seconds, e.g. dt_max = 1e-3",
        );
        c.positive(
            "dt_min",
            s.time.dt_min,
            "give the smallest acceptable step, e.g. dt_min = 1e-9",
        );
        // An end before the smallest step the run may take: it would stop at once, with
        // exit 0 and nothing but the start written (`--end 1e-300` did).
        if s.time.end > 0.0 && s.time.end < s.time.dt_min {
            c.fail(
                "end",
                s.time.end,
                &format!(
                    "is shorter than time.dt_min = {:e} s, the smallest step the run may take: it would end before its first step",
                    s.time.dt_min
                ),
                "give the simulated end time in seconds, e.g. end = 3.0",
            );
        }
        if s.time.dt_min >= s.time.dt_max {
            c.fail(
                "dt_min",
                s.time.dt_min,
                "is not below dt_max",
                "make dt_min much smaller than dt_max",
            );
        }
    });
}

/// `[domain]`: a non-empty box of sane size.
pub(super) fn domain(c: &mut Checker, s: &Scene) {
    let d = &s.domain;
    c.key("domain", |c| {
        c.finite3("min", d.min);
        c.finite3("max", d.max);
        for (field, v) in [("min", d.min), ("max", d.max)] {
            if v.iter().any(|x| x.abs() > MAX_DOMAIN) {
                c.fail(
                    field,
                    v,
                    &format!("lies beyond ±{MAX_DOMAIN:e} m"),
                    "give the domain corners in metres",
                );
            }
        }
        if (0..3).any(|k| d.max[k] <= d.min[k]) {
            c.fail(
                "max",
                d.max,
                "is not above domain.min on every axis",
                "make max[k] > min[k] for x, y and z",
            );
        }
    });
}

/// `[output]`: the frame interval (and how many frames it asks for) and the checkpoints.
pub(super) fn output(c: &mut Checker, s: &Scene) {
    c.key("output", |c| {
        c.positive(
            "interval",
            s.output.interval,
            "give the time between frames, e.g. interval = 0.05",
        );
        if let Some(m) = s.output.max_frames {
            c.positive(
                "max_frames",
                m,
                "give the most frames the run may write, e.g. max_frames = 20000, or leave it out for 10000",
            );
        }
        let max_frames = s
            .output
            .max_frames
            .filter(|m| m.is_finite() && *m > 0.0)
            .unwrap_or(MAX_FRAMES);
        let frames = s.time.end / s.output.interval;
        if s.output.interval > 0.0 && frames > max_frames {
            c.fail(
                "interval",
                s.output.interval,
                &format!(
                    "asks for {frames:.3e} frames over time.end = {} s (at most {:.0}, \
                     output.max_frames); each frame is a step landed exactly and a VTK file per node",
                    readable(s.time.end),
                    readable(max_frames)
                ),
                &format!(
                    "use interval >= {:.3e}, or raise output.max_frames to {:.0} if you mean it",
                    s.time.end / max_frames,
                    readable(frames.ceil())
                ),
            );
        }
        if let Some(v) = s.output.checkpoint_interval {
            c.positive(
                "checkpoint_interval",
                v,
                "give the simulated seconds between checkpoints, e.g. checkpoint_interval = 1.0, or leave it out",
            );
        }
        if let Some(v) = s.output.checkpoint_wall_minutes {
            c.positive(
                "checkpoint_wall_minutes",
                v,
                "give the wall-clock minutes between checkpoints, e.g. checkpoint_wall_minutes = 30, or leave it out",
            );
        }
    });
}
