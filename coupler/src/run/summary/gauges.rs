//! What one gauge saw: its still-water level, crest, trough and spray, from its series in
//! `gauges.csv` (docs/ARCHITECTURE.md "Run directory").

/// The still-water level of a gauge: an elevation [m], or `"dry"` when the gauge was dry at
/// t = 0.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[serde(untagged)]
pub enum Level {
    Wet(f64),
    Dry(&'static str),
}

/// The highest (crest) or lowest (trough) water at a gauge.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Extreme {
    /// Surface elevation there [m].
    pub elevation: f64,
    /// Height above (crest) or depth below (trough) the still-water level [m], both ≥ 0; for a
    /// gauge dry at t = 0, the crest's height above the bed (the deepest the water got).
    pub amount: f64,
    pub time: f64,
}

/// Per-gauge wave statistics from `gauges.csv` (docs/ARCHITECTURE.md "Run directory").
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct GaugeSummary {
    /// Bed elevation under the gauge: what the gauge reads while dry [m].
    pub bed: f64,
    /// Surface elevation at the first sample (after the first step, t ≈ 0), or "dry".
    pub still_water_level: Level,
    /// First time the gauge was wet [s] (0 when wet at the first sample); null if it never got
    /// wet.
    pub wet_from: Option<f64>,
    /// Highest surface; null if the gauge stayed dry.
    pub crest: Option<Extreme>,
    /// Lowest surface below the still-water level; null for a gauge dry at t = 0.
    pub trough: Option<Extreme>,
    /// Highest water including spray (`<name>_spray`) [m]; null if none reached the gauge.
    pub spray_max: Option<f64>,
}

/// A gauge is dry when it reads its bed elevation (the fluid node writes exactly that, to the
/// CSV's 6 decimals).
const DRY_TOLERANCE: f64 = 2e-6;

/// The summary of one gauge's series (time, surface) over a bed at `bed`.
pub fn summarise_gauge(series: &[(f64, f64)], spray: &[(f64, f64)], bed: f64) -> GaugeSummary {
    let wet = |v: f64| v > bed + DRY_TOLERANCE;
    let spray_max = spray
        .iter()
        .map(|s| s.1)
        .filter(|&v| wet(v))
        .fold(None, |m: Option<f64>, v| Some(m.map_or(v, |m| m.max(v))));
    let level = match series.first() {
        Some(&(_, v)) if wet(v) => Level::Wet(v),
        _ => Level::Dry("dry"),
    };
    // The first sample is taken after the first step: a gauge wet then was wet from t = 0.
    let wet_from = match level {
        Level::Wet(_) => Some(0.0),
        Level::Dry(_) => series.iter().find(|s| wet(s.1)).map(|s| s.0),
    };
    let Some(_) = wet_from else {
        return GaugeSummary {
            bed,
            still_water_level: level,
            wet_from,
            crest: None,
            trough: None,
            spray_max,
        };
    };
    let base = match level {
        Level::Wet(v) => v,
        Level::Dry(_) => bed,
    };
    let (crest_time, crest) =
        series.iter().fold(
            (0.0, f64::NEG_INFINITY),
            |a, &(t, v)| if v > a.1 { (t, v) } else { a },
        );
    let trough = match level {
        Level::Wet(_) => series
            .iter()
            .fold(None, |a: Option<(f64, f64)>, &(t, v)| match a {
                Some((_, m)) if m <= v => a,
                _ => Some((t, v)),
            })
            .map(|(time, v)| Extreme {
                elevation: v,
                amount: (base - v).max(0.0),
                time,
            }),
        Level::Dry(_) => None,
    };
    GaugeSummary {
        bed,
        still_water_level: level,
        wet_from,
        crest: Some(Extreme {
            elevation: crest,
            amount: (crest - base).max(0.0),
            time: crest_time,
        }),
        trough,
        spray_max,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series(v: &[f64]) -> Vec<(f64, f64)> {
        v.iter()
            .enumerate()
            .map(|(i, &v)| (0.1 * i as f64, v))
            .collect()
    }

    #[test]
    fn a_wet_gauge_reports_crest_and_trough_from_its_still_water_level() {
        let s = summarise_gauge(
            &series(&[0.5, 0.52, 0.58, 0.47, 0.5]),
            &series(&[0.5, 0.9, 0.6, 0.5, 0.5]),
            0.0,
        );
        assert_eq!(s.still_water_level, Level::Wet(0.5));
        assert_eq!(s.wet_from, Some(0.0));
        let c = s.crest.unwrap();
        assert!((c.amount - 0.08).abs() < 1e-12 && (c.time - 0.2).abs() < 1e-12);
        let t = s.trough.unwrap();
        assert!((t.amount - 0.03).abs() < 1e-12 && (t.time - 0.3).abs() < 1e-12);
        assert_eq!(s.spray_max, Some(0.9));
    }

    #[test]
    fn a_gauge_that_stays_dry_reports_no_wave() {
        let s = summarise_gauge(&series(&[0.2, 0.2, 0.2]), &series(&[0.2, 0.2, 0.2]), 0.2);
        assert_eq!(s.still_water_level, Level::Dry("dry"));
        assert_eq!(
            (s.wet_from, &s.crest, &s.trough, s.spray_max),
            (None, &None, &None, None)
        );
        assert_eq!(
            serde_json::to_value(&s).unwrap()["still_water_level"],
            serde_json::json!("dry")
        );
    }

    #[test]
    fn a_gauge_that_gets_wet_reports_when_and_how_deep() {
        let s = summarise_gauge(&series(&[0.2, 0.2, 0.25, 0.2]), &[], 0.2);
        assert!(s.spray_max.is_none());
        assert_eq!(s.still_water_level, Level::Dry("dry"));
        assert!((s.wet_from.unwrap() - 0.2).abs() < 1e-12);
        assert!((s.crest.unwrap().amount - 0.05).abs() < 1e-12);
        assert!(s.trough.is_none());
    }
}
