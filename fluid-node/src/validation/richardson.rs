//! Where a quantity read at successive resolutions converges: Richardson extrapolation to zero
//! spacing, and Roache's grid convergence index as its uncertainty (Roache 1998, *Verification
//! and Validation in Computational Science and Engineering*; the procedure of Celik, Ghia,
//! Roache, Freitas, Coleman & Raad 2008, J. Fluids Eng. 130, 078001, Eqs. 1–7 for a constant
//! refinement ratio).
//!
//! A quantity φ with a discretisation error C hᵖ reads φ_m and φ_f at spacings r h and h; then
//! φ₀ ≈ φ_f + (φ_f − φ_m) / (rᵖ − 1). Three runs give the order the quantity itself shows,
//! p = ln(ε_cm / ε_mf) / ln r (ε the changes from coarse to medium and medium to fine), when both
//! changes have one sign (monotone convergence). Extrapolating with an observed order above
//! the scheme's formal one trusts a small change too far, so the order used is the lower of
//! the two, as Roache advises for the index; an order below half the formal one (or a
//! negative one: the changes grow) says the runs are not yet in the asymptotic range, and no
//! extrapolate is given. Where the changes alternate in sign, the formal order is used with
//! the wider safety factor.
//!
//! The changes must stand above the run-to-run scatter of the quantity: for an impact, whose
//! reading moves by several per cent between starts that differ only in where the particles
//! sit, extrapolate the medians of an ensemble, not single runs.

/// A resolution study's verdict on one quantity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Extrapolated {
    /// φ₀, the value at zero spacing, from the two finest runs with [`Self::order`].
    pub value: f64,
    /// The order used: the observed one when it is known and below the formal one, else the
    /// formal one.
    pub order: f64,
    /// The order the three finest runs show, when they converge monotonically.
    pub observed: Option<f64>,
    /// The finest run's grid convergence index, Fs |φ_f − φ_m| / |φ_f| / (rᵖ − 1): a relative
    /// band about the finest run that holds the converged value, with the safety factor
    /// Fs = 1.25 when three runs converge monotonically and 3 otherwise (Roache 1998).
    pub gci: f64,
}

/// The order of convergence three runs show (`values` coarse to fine, the last three used,
/// each finer spacing `ratio` times smaller): ln(ε_cm / ε_mf) / ln r when both changes have one
/// sign (negative when the changes grow: divergence); None when they change sign (oscillatory
/// convergence), for fewer than three runs, a change of zero, or a ratio that does not refine.
pub fn observed_order(values: &[f64], ratio: f64) -> Option<f64> {
    let n = values.len();
    if n < 3 || ratio.is_nan() || ratio <= 1.0 {
        return None;
    }
    let (e_coarse, e_fine) = (values[n - 2] - values[n - 3], values[n - 1] - values[n - 2]);
    (e_coarse * e_fine > 0.0).then(|| (e_coarse / e_fine).ln() / ratio.ln())
}

/// The Richardson extrapolate and grid convergence index of `values` (coarse to fine, at
/// least two, each finer run's spacing `ratio` (> 1) times smaller), for a scheme of
/// `formal` order. None with fewer than two finite values, and when three runs show an order
/// below half the formal one, diverging included: they are not in the asymptotic range,
/// where an extrapolate means something.
pub fn richardson(values: &[f64], ratio: f64, formal: f64) -> Option<Extrapolated> {
    let n = values.len();
    let refined = ratio.is_finite() && ratio > 1.0 && formal.is_finite() && formal > 0.0;
    if n < 2 || !refined || values.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let observed = observed_order(values, ratio);
    if observed.is_some_and(|p| p < 0.5 * formal) {
        return None;
    }
    let (fine, medium) = (values[n - 1], values[n - 2]);
    let e_fine = fine - medium;
    let order = observed.filter(|&p| p < formal).unwrap_or(formal);
    let grow = ratio.powf(order) - 1.0;
    let safety = if observed.is_some() { 1.25 } else { 3.0 };
    Some(Extrapolated {
        value: fine + e_fine / grow,
        order,
        observed,
        gci: safety * (e_fine / fine).abs() / grow,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// φ(h) = 12 − 3 hᵖ read at h = 4, 2, 1.
    fn series(p: f64) -> Vec<f64> {
        [4.0, 2.0, 1.0]
            .iter()
            .map(|h: &f64| 12.0 - 3.0 * h.powf(p))
            .collect()
    }

    #[test]
    fn an_exact_power_law_extrapolates_to_its_limit() {
        // First order, as the scheme: the limit exactly, and the order seen.
        let e = richardson(&series(1.0), 2.0, 1.0).unwrap();
        assert!((e.value - 12.0).abs() < 1e-12, "{e:?}");
        assert!((e.observed.unwrap() - 1.0).abs() < 1e-12);
        // The index: 1.25 × |9 − 6| / 9 / (2 − 1).
        assert!((e.gci - 1.25 * 3.0 / 9.0).abs() < 1e-12);
        // Order 0.7, below the formal first: the observed order is used, and the limit found.
        let e = richardson(&series(0.7), 2.0, 1.0).unwrap();
        assert!((e.order - 0.7).abs() < 1e-12 && (e.value - 12.0).abs() < 1e-12);
        // Second order, above the formal first: first order is used. The extrapolate goes
        // past the limit (one full change added, not a third of it), and the index is wide
        // enough to say so.
        let e = richardson(&series(2.0), 2.0, 1.0).unwrap();
        assert_eq!(e.order, 1.0);
        assert!((e.value - (9.0 + 9.0)).abs() < 1e-12, "{e:?}");
        assert!((e.gci - 1.25).abs() < 1e-12 && e.value - 12.0 < e.gci * 9.0);
    }

    #[test]
    fn oscillating_or_short_studies_use_the_formal_order_and_a_wider_band() {
        // Up, then down: no observed order, Fs = 3.
        let e = richardson(&[10.0, 12.0, 11.0], 2.0, 1.0).unwrap();
        assert_eq!(e.observed, None);
        assert!((e.value - 10.0).abs() < 1e-12);
        assert!((e.gci - 3.0 / 11.0).abs() < 1e-12);
        // Two runs: the same.
        let e = richardson(&[12.0, 11.0], 2.0, 1.0).unwrap();
        assert_eq!(e.observed, None);
        assert!((e.value - 10.0).abs() < 1e-12);
        // Nothing to say from one run, a failed run, or no refinement.
        assert_eq!(richardson(&[1.0], 2.0, 1.0), None);
        assert_eq!(richardson(&[1.0, f64::NAN], 2.0, 1.0), None);
        assert_eq!(richardson(&[1.0, 2.0], 1.0, 1.0), None);
    }

    #[test]
    fn diverging_or_barely_converging_runs_have_no_extrapolate() {
        // The changes grow (1, then 2): divergence, order −1.
        assert_eq!(observed_order(&[10.0, 11.0, 13.0], 2.0), Some(-1.0));
        assert_eq!(richardson(&[10.0, 11.0, 13.0], 2.0, 1.0), None);
        // Order 0.1 of a first-order scheme: far from the asymptotic range (the extrapolate
        // would add ten changes).
        assert_eq!(richardson(&series(0.1), 2.0, 1.0), None);
        // A change of zero says nothing of the order.
        assert_eq!(observed_order(&[10.0, 11.0, 11.0], 2.0), None);
        assert_eq!(observed_order(&[10.0, 11.0, 11.5], 1.0), None);
    }
}
