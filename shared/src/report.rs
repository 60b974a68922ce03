//! Validation tables: one row per checked quantity, rendered as markdown. Shared by the fluid
//! validation (`fluid-validate`), the solid verification (`solid-validate`) and the docs.

use crate::math::Real;
use crate::solver::SolverError;

/// One line of a validation table.
#[derive(Debug, Clone)]
pub struct Row {
    pub case: String,
    pub solver: String,
    pub quantity: String,
    pub reference: String,
    pub measured: String,
    pub error: String,
    pub tolerance: String,
    pub pass: bool,
}

/// How a measured number is compared with its reference.
#[derive(Debug, Clone, Copy)]
pub enum Tolerance {
    /// |measured − reference| / |reference| ≤ x.
    Relative(Real),
    /// |measured − reference| ≤ x.
    Absolute(Real),
    /// measured ≤ x (the reference is a bound).
    AtMost(Real),
}

impl Row {
    pub fn numeric(
        case: &str,
        solver: &str,
        quantity: &str,
        reference: Real,
        measured: Real,
        tol: Tolerance,
    ) -> Row {
        let diff = (measured - reference).abs();
        let (error, tolerance, pass) = match tol {
            Tolerance::Relative(x) => {
                let e = diff / reference.abs();
                let pct = |v: Real| {
                    if v < 1e-4 {
                        format!("{:.1e} %", 100.0 * v)
                    } else {
                        format!("{:.3} %", 100.0 * v)
                    }
                };
                (pct(e), pct(x), e <= x)
            }
            Tolerance::Absolute(x) => (format!("{diff:.3e}"), format!("{x:.1e}"), diff <= x),
            Tolerance::AtMost(x) => ("–".to_string(), format!("≤ {x}"), measured <= x),
        };
        Row {
            case: case.into(),
            solver: solver.into(),
            quantity: quantity.into(),
            reference: format!("{reference:.6}"),
            measured: format!("{measured:.6}"),
            error,
            tolerance,
            pass: pass && measured.is_finite(),
        }
    }

    pub fn categorical(
        case: &str,
        solver: &str,
        quantity: &str,
        reference: &str,
        measured: &str,
    ) -> Row {
        Row {
            case: case.into(),
            solver: solver.into(),
            quantity: quantity.into(),
            reference: reference.into(),
            measured: measured.into(),
            error: "–".into(),
            tolerance: "exact".into(),
            pass: reference == measured,
        }
    }

    /// A case whose run did not complete.
    pub fn failed(case: &str, solver: &str, quantity: &str, e: &SolverError) -> Row {
        Row::categorical(case, solver, quantity, "completes", &format!("failed: {e}"))
    }
}

/// Prints rows as a markdown table.
pub fn markdown(rows: &[Row]) -> String {
    let mut s = String::from(
        "| case | solver | quantity | reference | measured | error | tolerance | pass |\n|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        s += &format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} |\n",
            r.case,
            r.solver,
            r.quantity,
            r.reference,
            r.measured,
            r.error,
            r.tolerance,
            if r.pass { "yes" } else { "**no**" }
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_pass_and_fail_by_their_tolerance() {
        assert!(Row::numeric("c", "s", "q", 1.0, 1.004, Tolerance::Relative(0.005)).pass);
        assert!(!Row::numeric("c", "s", "q", 1.0, 1.006, Tolerance::Relative(0.005)).pass);
        assert!(!Row::numeric("c", "s", "q", 1.0, f64::NAN, Tolerance::Absolute(1.0)).pass);
        assert!(Row::numeric("c", "s", "q", 0.0, 0.05, Tolerance::AtMost(0.1)).pass);
        let table = markdown(&[Row::categorical("c", "s", "q", "slides", "topples")]);
        assert!(
            table.contains("| slides | topples |") && table.contains("**no**"),
            "{table}"
        );
    }
}
