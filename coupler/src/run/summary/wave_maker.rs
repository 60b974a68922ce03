//! A piston wave maker's waves against linear theory, for `summary.json`.
//!
//! A scene whose one kinematic block moves sinusoidally along a horizontal axis and spans the
//! water's depth is a piston wave maker (paper Example 1). At each gauge in front of it over the piston's depth, the
//! summary gives the height of the first harmonic of the record at the piston's period, 2·|a₁|
//! with a₁ = (2/τ) ∫ η(t) e^{−iωt} dt over a window τ of whole periods, and its ratio to
//! Biesel's linear wave ([`crate::run::summary::linear_waves`]). The first harmonic, not crest minus trough:
//! a wave of H/h ≈ 0.3 carries a bound second harmonic that raises crests and flattens troughs
//! without changing it (second-order wave-maker theory keeps the first order's amplitude).
//!
//! The window starts once the fully ramped wave has reached the gauge plus one period for the
//! front to pass (ramp + distance/c_g + T) and ends at the record's last whole period, or
//! before a reflection from the far end of the water could return (2·L − x)/c_g. A gauge whose
//! window holds no whole period, or whose bed is not the piston's (a beach), is left out.

use crate::run::summary::gauges::{GaugeSummary, Level};
use crate::run::summary::linear_waves::PistonWave;
use shared::scene::{BlockKind, MotionSpec, Scene};
use std::collections::BTreeMap;
use std::f64::consts::TAU;

/// The wave maker's linear wave and what the gauges recorded of it.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct WaveMakerSummary {
    /// The kinematic block that makes the waves.
    pub piston: String,
    /// Its amplitude [m] (the stroke is twice it).
    pub amplitude: f64,
    /// Linear theory's wave for that stroke, period and the still-water depth at the gauges.
    pub linear: PistonWave,
    pub gauges: BTreeMap<String, GaugeWave>,
}

/// One gauge's first harmonic.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct GaugeWave {
    /// Distance from the piston's face along its stroke [m].
    pub distance: f64,
    /// Window of whole periods the harmonic was taken over [s].
    pub window: [f64; 2],
    /// 2·|a₁| [m].
    pub first_harmonic_height: f64,
    /// first_harmonic_height / linear.height.
    pub ratio_to_linear: f64,
}

/// The summary of a wave-maker scene, or `None` if `scene` is not one (or no gauge qualifies).
/// `series` holds each gauge's record (time, surface) by name, `gauges` their summaries.
pub fn summarise(
    scene: &Scene,
    series: &BTreeMap<String, Vec<(f64, f64)>>,
    gauges: &BTreeMap<String, GaugeSummary>,
) -> Option<WaveMakerSummary> {
    let mut kinematic = scene
        .blocks
        .iter()
        .filter(|b| b.kind == BlockKind::Kinematic);
    let piston = kinematic.next()?;
    if kinematic.next().is_some() {
        return None;
    }
    let Some(MotionSpec::Sine {
        amplitude,
        period,
        ramp,
        ..
    }) = piston.motion
    else {
        return None;
    };
    // A horizontal stroke: the unit direction d and the amplitude along it.
    let a = (amplitude[0].powi(2) + amplitude[1].powi(2)).sqrt();
    if a <= 0.0 || amplitude[2].abs() > 1e-9 * a {
        return None;
    }
    let d = [amplitude[0] / a, amplitude[1] / a];
    let along = |x: f64, y: f64| x * d[0] + y * d[1];
    let corners = shared::geometry::shape_points(&piston.shape).ok()?;
    let face = corners
        .iter()
        .map(|p| along(p.x, p.y))
        .fold(f64::NEG_INFINITY, f64::max);
    // The far end of the water along the stroke, for the reflection's return.
    let far = scene
        .fluid
        .as_ref()?
        .water
        .iter()
        .filter_map(|w| shared::geometry::shape_points(&w.shape).ok())
        .flatten()
        .map(|p| along(p.x, p.y))
        .fold(f64::NEG_INFINITY, f64::max);
    let g = (scene.gravity[0].powi(2) + scene.gravity[1].powi(2) + scene.gravity[2].powi(2)).sqrt();
    // The piston's depth: that of the nearest gauge in front of it.
    let depth_at = |s: &GaugeSummary| match s.still_water_level {
        Level::Wet(level) => Some(level - s.bed),
        Level::Dry(_) => None,
    };
    let ahead: Vec<_> = scene
        .gauges
        .iter()
        .filter_map(|gauge| {
            let distance = along(gauge.x, gauge.y) - face;
            let depth = depth_at(gauges.get(&gauge.name)?)?;
            (distance > 0.0).then_some((gauge.name.clone(), distance, depth))
        })
        .collect();
    let (nearest, _, depth) = ahead.iter().min_by(|a, b| a.1.total_cmp(&b.1))?;
    let depth = *depth;
    // Biesel's piston spans the depth: from the bed (within 5 % of the depth) to above the
    // still water. A kinematic block that does not (a flap, a plunger) is another wave maker.
    let bed = gauges.get(nearest)?.bed;
    let (low, high) = corners
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| {
            (l.min(p.z), h.max(p.z))
        });
    if low > bed + 0.05 * depth || high < bed + depth {
        return None;
    }
    let linear = PistonWave::new(a, period, depth, g);
    let mut out = BTreeMap::new();
    for (name, distance, h) in ahead {
        // Only over the piston's depth (within 2 %): on a beach the wave shoals.
        if (h / depth - 1.0).abs() > 0.02 {
            continue;
        }
        let Some(record) = series.get(&name) else {
            continue;
        };
        let Some(&(t_last, _)) = record.last() else {
            continue;
        };
        let c = linear.group_velocity;
        let start = ramp + distance / c + period;
        let reflection = (2.0 * (far - face) - distance) / c;
        let whole = ((t_last.min(reflection) - start) / period).floor();
        if whole < 1.0 {
            continue;
        }
        let window = [start, start + whole * period];
        let a1 = first_harmonic(record, TAU / period, window);
        out.insert(
            name,
            GaugeWave {
                distance,
                window,
                first_harmonic_height: 2.0 * a1,
                ratio_to_linear: 2.0 * a1 / linear.height,
            },
        );
    }
    (!out.is_empty()).then(|| WaveMakerSummary {
        piston: piston.name.clone(),
        amplitude: a,
        linear,
        gauges: out,
    })
}

/// |a₁| of `record` at angular frequency `omega` over `window` (whole periods): the
/// trapezoidal rule on the samples, which need not be evenly spaced (a run records every
/// step). The mean drops out over whole periods.
pub fn first_harmonic(record: &[(f64, f64)], omega: f64, window: [f64; 2]) -> f64 {
    let (mut re, mut im) = (0.0, 0.0);
    for pair in record.windows(2) {
        let ((t0, y0), (t1, y1)) = (pair[0], pair[1]);
        // The part of the interval inside the window, with the record interpolated linearly.
        let (a, b) = (t0.max(window[0]), t1.min(window[1]));
        if b <= a || t1 <= t0 {
            continue;
        }
        let at = |t: f64| y0 + (y1 - y0) * (t - t0) / (t1 - t0);
        let (ya, yb) = (at(a), at(b));
        re += 0.5 * (b - a) * (ya * (omega * a).cos() + yb * (omega * b).cos());
        im += 0.5 * (b - a) * (ya * (omega * a).sin() + yb * (omega * b).sin());
    }
    2.0 / (window[1] - window[0]) * re.hypot(im)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A record of η = mean + a₁ sin(ωt + φ) + a₂ cos(2ωt), sampled unevenly.
    fn record(a1: f64, a2: f64, omega: f64, t_end: f64) -> Vec<(f64, f64)> {
        let mut out = Vec::new();
        let mut t = 0.0;
        let mut k = 0u32;
        while t <= t_end {
            out.push((
                t,
                1.0 + a1 * (omega * t + 0.3).sin() + a2 * (2.0 * omega * t).cos(),
            ));
            // Steps of 2–8 ms, as a run's.
            t += 0.002 + 0.006 * ((k * 7919) % 13) as f64 / 12.0;
            k += 1;
        }
        out
    }

    #[test]
    fn the_first_harmonic_ignores_the_mean_and_the_second() {
        let omega = TAU / 3.0;
        let r = record(0.12, 0.03, omega, 20.0);
        let a1 = first_harmonic(&r, omega, [5.0, 17.0]);
        assert!((a1 / 0.12 - 1.0).abs() < 1e-4, "{a1}");
        // At the second harmonic's frequency it reads that one.
        let a2 = first_harmonic(&r, 2.0 * omega, [5.0, 17.0]);
        assert!((a2 / 0.03 - 1.0).abs() < 1e-3, "{a2}");
    }

    #[test]
    fn the_wave_maker_scene_is_summarised_at_its_flat_gauges_only() {
        let text = include_str!("../../../../scenes/wave_maker.toml");
        let scene = shared::scene::Scene::parse(text, "wave_maker").unwrap();
        let wave = PistonWave::new(0.2, 3.0, 1.0, 9.81);
        // Every gauge records linear theory's wave arriving at c_g; a beach gauge too.
        let mut series = BTreeMap::new();
        let mut gauges = BTreeMap::new();
        for g in &scene.gauges {
            let x = g.x - 0.3;
            let omega = TAU / 3.0;
            let k = TAU / wave.wavelength;
            let rec: Vec<(f64, f64)> = (0..=5000)
                .map(|i| {
                    let t = i as f64 * 0.005;
                    let arrived = t > 3.0 + x / wave.group_velocity;
                    let eta = if arrived {
                        0.5 * wave.height * 0.8 * (k * x - omega * t).cos()
                    } else {
                        0.0
                    };
                    (t, 1.0 + eta)
                })
                .collect();
            series.insert(g.name.clone(), rec);
            let bed = if g.x > 70.0 { 0.04 * (g.x - 70.0) } else { 0.0 };
            gauges.insert(
                g.name.clone(),
                GaugeSummary {
                    bed,
                    still_water_level: Level::Wet(1.0),
                    wet_from: Some(0.0),
                    crest: None,
                    trough: None,
                    spray_max: None,
                },
            );
        }
        let s = summarise(&scene, &series, &gauges).expect("a wave maker");
        // The same block lifted off the bed is not Biesel's piston.
        let mut lifted = scene.clone();
        let piston = lifted
            .blocks
            .iter_mut()
            .find(|b| b.name == "piston")
            .unwrap();
        piston.shape = shared::scene::ShapeSpec::Box {
            min: [0.0, 0.0, 0.3],
            max: [0.3, 0.8, 2.0],
        };
        assert!(summarise(&lifted, &series, &gauges).is_none());
        assert_eq!(s.piston, "piston");
        assert!((s.linear.height - wave.height).abs() < 1e-9);
        // x10 and x30 have whole periods within the 25 s record; x50 not yet; the toe (its
        // bed still flat) has none; the beach gauge is over another depth.
        let names: Vec<_> = s.gauges.keys().cloned().collect();
        assert_eq!(names, ["x10", "x30"], "{s:?}");
        for g in s.gauges.values() {
            assert!((g.ratio_to_linear - 0.8).abs() < 2e-3, "{g:?}");
            assert!(g.window[0] >= 3.0 + g.distance / wave.group_velocity + 3.0 - 1e-9);
        }
    }
}
