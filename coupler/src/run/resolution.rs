//! Particle spacing from the accuracy a user asks for (`coupler run --target-error E`).
//!
//! `coupler chart` runs the dam break at several resolutions and fits the discretisation error
//! of the surge front to e(N) ≈ C·N^(−p), N = water depth / dx (particles across the depth).
//! The error of a resolution is estimated the Richardson way, from the change to the next finer
//! run: |Z_N − Z_2N| ≈ C N^−p (1 − 2^−p), so e(N) = |Z_N − Z_2N| / (1 − 2^−p). It is the error
//! against the converged solution of the same equations; what the method misses of the
//! experiment (gate, bed friction: WCSPH runs ahead of Martin & Moyce 1952, see
//! docs/REFERENCES.md §1.2) no resolution removes, and the chart reports it separately. The fit
//! goes into `docs/charts/fluid_convergence.csv` (committed, and compiled into the coupler), so
//! a run picks dx from a measured curve, not a guess.

use shared::math::readable;
use shared::scene::{Scene, ShapeSpec};

/// The fit compiled into the coupler (written by `coupler chart`).
pub const EMBEDDED_FIT: &str = include_str!("../../../docs/charts/fluid_convergence.csv");

/// e(N) ≈ C·N^(−p) for one fluid solver, N = depth/dx, measured over [n_min, n_max].
#[derive(Debug, Clone, PartialEq)]
pub struct ConvergenceFit {
    pub solver: String,
    pub c: f64,
    pub p: f64,
    pub n_min: f64,
    pub n_max: f64,
}

impl ConvergenceFit {
    /// Least-squares line through (ln N, ln Δ) of successive doublings, Δ = |Z_N − Z_2N|.
    /// Needs at least two doublings (three runs).
    pub fn from_doublings(solver: &str, deltas: &[(f64, f64)]) -> Result<ConvergenceFit, String> {
        let pts: Vec<(f64, f64)> = deltas
            .iter()
            .filter(|(n, d)| *n > 0.0 && *d > 0.0 && d.is_finite())
            .map(|&(n, d)| (n.ln(), d.ln()))
            .collect();
        if pts.len() < 2 {
            return Err(format!(
                "{solver}: need two resolution doublings with a nonzero change to fit a convergence curve, have {}",
                pts.len()
            ));
        }
        let m = pts.len() as f64;
        let (sx, sy) = pts.iter().fold((0.0, 0.0), |a, p| (a.0 + p.0, a.1 + p.1));
        let (mx, my) = (sx / m, sy / m);
        let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
        let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
        let slope = sxy / sxx;
        let p = -slope;
        if !(p.is_finite() && p > 0.05) {
            return Err(format!(
                "{solver}: the front does not converge over these resolutions (fitted order {p:.2})"
            ));
        }
        let c_delta = (my - slope * mx).exp();
        let ns: Vec<f64> = deltas.iter().map(|d| d.0).collect();
        Ok(ConvergenceFit {
            solver: solver.into(),
            c: c_delta / (1.0 - 2f64.powf(-p)),
            p,
            n_min: ns.iter().cloned().fold(f64::INFINITY, f64::min),
            // The finest run of the last doubling is measured too.
            n_max: 2.0 * ns.iter().cloned().fold(0.0, f64::max),
        })
    }

    /// Estimated error at N particles across the depth.
    pub fn error_at(&self, n: f64) -> f64 {
        self.c * n.powf(-self.p)
    }

    /// N that brings the estimated error down to `target`.
    pub fn particles_for(&self, target: f64) -> f64 {
        (self.c / target).powf(1.0 / self.p)
    }
}

/// Writes the fits as CSV.
pub fn to_csv(fits: &[ConvergenceFit]) -> String {
    let mut s = String::from(
        "# Surge-front error of the dam break against N = depth/dx, e = C*N^-p (coupler chart)\nsolver,C,p,n_min,n_max\n",
    );
    for f in fits {
        s += &format!(
            "{},{:.6e},{:.6},{},{}\n",
            f.solver, f.c, f.p, f.n_min, f.n_max
        );
    }
    s
}

/// Reads fits written by [`to_csv`].
pub fn parse_csv(text: &str) -> Result<Vec<ConvergenceFit>, String> {
    let mut out = Vec::new();
    for line in text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .skip(1)
    {
        let c: Vec<&str> = line.split(',').map(str::trim).collect();
        let num = |i: usize| -> Result<f64, String> {
            c.get(i)
                .and_then(|v| v.parse().ok())
                .ok_or_else(|| format!("bad convergence line '{line}'"))
        };
        out.push(ConvergenceFit {
            solver: c[0].to_string(),
            c: num(1)?,
            p: num(2)?,
            n_min: num(3)?,
            n_max: num(4)?,
        });
    }
    Ok(out)
}

/// Depth of the deepest water volume of the scene [m] (the length N is measured against).
pub fn water_depth(scene: &Scene) -> Option<f64> {
    let fluid = scene.fluid.as_ref()?;
    fluid
        .water
        .iter()
        .map(|w| match &w.shape {
            ShapeSpec::Box { min, max } => max[2] - min[2],
            ShapeSpec::Prism {
                axis,
                profile,
                extent,
            } => match axis {
                shared::scene::Axis::Z => extent[1] - extent[0],
                _ => {
                    let zs = profile.iter().map(|p| p[1]);
                    zs.clone().fold(f64::NEG_INFINITY, f64::max) - zs.fold(f64::INFINITY, f64::min)
                }
            },
            ShapeSpec::Convex { vertices } => {
                let zs = vertices.iter().map(|v| v[2]);
                zs.clone().fold(f64::NEG_INFINITY, f64::max) - zs.fold(f64::INFINITY, f64::min)
            }
        })
        .reduce(f64::max)
}

/// What `--target-error` chose, and why (printed by `coupler run`).
#[derive(Debug, Clone)]
pub struct Choice {
    pub dx: f64,
    pub particles_per_depth: f64,
    pub explanation: String,
}

/// Picks dx for `solver` so that the fitted error is at most `target`.
pub fn choose_dx(
    fits: &[ConvergenceFit],
    solver: &str,
    scene: &Scene,
    target: f64,
) -> Result<Choice, String> {
    if !(target.is_finite() && target > 0.0) {
        return Err(format!(
            "--target-error {}: must be a positive relative error, e.g. 0.02",
            readable(target)
        ));
    }
    // A relative error of 100 % or more is no target (the coarsest column meets it): most
    // likely a percentage, which fell back to 4 particles across the depth without a word.
    if target >= 1.0 {
        return Err(format!(
            "--target-error {}: is a relative error of {:.0} % or more, met by any column; \
             fix: give a fraction, e.g. --target-error 0.02 for 2 %",
            readable(target),
            readable(100.0 * target)
        ));
    }
    let fit = fits
        .iter()
        .find(|f| f.solver == solver)
        .ok_or_else(|| format!("no measured convergence curve for fluid solver '{solver}' (run `coupler chart` to measure one)"))?;
    let depth = water_depth(scene).ok_or("--target-error: the scene has no water")?;
    // Whole particles across the depth, never fewer than 4 (below that there is no column).
    let n = fit.particles_for(target).ceil().max(4.0);
    let dx = depth / n;
    let range = if n > fit.n_max {
        format!(
            "; N is beyond the finest measured resolution ({}), so the curve is extrapolated",
            fit.n_max
        )
    } else if n < fit.n_min {
        format!(
            "; N is below the coarsest measured resolution ({}), so the curve is extrapolated",
            fit.n_min
        )
    } else {
        String::new()
    };
    Ok(Choice {
        dx,
        particles_per_depth: n,
        explanation: format!(
            "--target-error {target}: {solver} dam-break front error e ≈ {:.3}·N^-{:.2} (N = depth/dx, measured for N = {}..{}); \
             e ≤ {target} needs N ≥ {:.1}; water depth {depth} m → dx = {dx:.5} m ({n} particles across the depth, estimated error {:.4}){range}",
            fit.c,
            fit.p,
            fit.n_min,
            fit.n_max,
            fit.particles_for(target),
            fit.error_at(n),
        ),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fit_recovers_a_power_law() {
        // Δ(N) for e = 2 N^-1.5.
        let (c, p) = (2.0, 1.5);
        let deltas: Vec<(f64, f64)> = [8.0, 16.0, 32.0]
            .iter()
            .map(|&n: &f64| (n, c * n.powf(-p) * (1.0 - 2f64.powf(-p))))
            .collect();
        let fit = ConvergenceFit::from_doublings("x", &deltas).unwrap();
        assert!((fit.p - p).abs() < 1e-9 && (fit.c - c).abs() < 1e-9);
        let n = fit.particles_for(0.01);
        assert!((fit.error_at(n) - 0.01).abs() < 1e-12);
        let back = parse_csv(&to_csv(std::slice::from_ref(&fit))).unwrap();
        assert!((back[0].p - fit.p).abs() < 1e-5 && (back[0].c / fit.c - 1.0).abs() < 1e-5);
    }

    #[test]
    fn a_diverging_series_is_refused() {
        let deltas = [(8.0, 0.01), (16.0, 0.02)];
        assert!(ConvergenceFit::from_doublings("x", &deltas).is_err());
    }

    #[test]
    fn the_embedded_fit_covers_every_fluid_solver() {
        // `--target-error` works with whichever solver a scene names: `coupler chart` fits
        // every registered one.
        let fits = parse_csv(EMBEDDED_FIT).unwrap();
        for s in fluid_node::REGISTRY.names() {
            let f = fits.iter().find(|f| f.solver == s).expect("solver fitted");
            assert!(f.p > 0.0 && f.c > 0.0);
        }
    }

    #[test]
    fn a_tighter_target_gives_a_finer_spacing() {
        let fits = parse_csv(EMBEDDED_FIT).unwrap();
        let scene = Scene::default_scene();
        let coarse = choose_dx(&fits, "wcsph", &scene, 0.05).unwrap();
        let fine = choose_dx(&fits, "wcsph", &scene, 0.01).unwrap();
        assert!(fine.dx < coarse.dx, "{} vs {}", fine.dx, coarse.dx);
        assert!(coarse.explanation.contains("dx ="));
    }

    /// A percentage given for a fraction is refused with the fraction to give, not met by the
    /// coarsest column.
    #[test]
    fn a_target_of_a_hundred_percent_or_more_is_refused() {
        let fits = parse_csv(EMBEDDED_FIT).unwrap();
        let scene = Scene::default_scene();
        for target in [1.0, 2.0, 5.0] {
            let e = choose_dx(&fits, "wcsph", &scene, target).unwrap_err();
            assert!(
                e.contains("give a fraction, e.g. --target-error 0.02"),
                "{e}"
            );
        }
        assert!(choose_dx(&fits, "wcsph", &scene, 0.5).is_ok());
    }
}
