//! Validation tables: one row per checked quantity, rendered as markdown. Shared by the fluid
//! validation (`fluid-validate`), the solid verification (`solid-validate`) and the docs.
//!
//! A row either must pass, or is a **known limitation**: a documented failure of a method as
//! published (e.g. the still-water pressure of Müller et al. 2003's Eq. 14), kept in the table
//! rather than hidden by a wider tolerance. A command succeeds when every row is as expected
//! ([`all_as_expected`]): every ordinary row passes and every known limitation still fails. A
//! known limitation that passes is reported too: the method or the docs changed, and the row
//! should become an ordinary one.

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
    /// Why this row is expected to fail (a documented limitation); None: it must pass.
    pub known_limitation: Option<String>,
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
            known_limitation: None,
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
            known_limitation: None,
        }
    }

    /// Marks the row as a known limitation: expected to fail, for the reason `why`.
    pub fn known_limitation(mut self, why: &str) -> Row {
        self.known_limitation = Some(why.into());
        self
    }

    /// True when the row came out as documented: an ordinary row passed, or a known limitation
    /// failed.
    pub fn as_expected(&self) -> bool {
        self.pass == self.known_limitation.is_none()
    }

    /// The table's pass column.
    pub fn verdict(&self) -> String {
        match (&self.known_limitation, self.pass) {
            (None, true) => "yes".into(),
            (None, false) => "**no**".into(),
            (Some(why), false) => format!("no (known limitation: {why})"),
            (Some(_), true) => "**yes, but listed as a known limitation**".into(),
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
            r.verdict()
        );
    }
    s
}

/// True when every row is as expected ([`Row::as_expected`]): what the validation commands exit
/// 0 on.
pub fn all_as_expected(rows: &[Row]) -> bool {
    rows.iter().all(Row::as_expected)
}

/// One line saying how the rows came out, for the end of a validation command's output.
pub fn outcome(rows: &[Row]) -> String {
    let known = rows.iter().filter(|r| r.known_limitation.is_some()).count();
    let failed = rows
        .iter()
        .filter(|r| r.known_limitation.is_none() && !r.pass)
        .count();
    let surprises = rows
        .iter()
        .filter(|r| r.known_limitation.is_some() && r.pass)
        .count();
    format!(
        "{} row(s): {} passed, {failed} failed, {known} known limitation(s) of which {surprises} unexpectedly passed",
        rows.len(),
        rows.iter()
            .filter(|r| r.known_limitation.is_none() && r.pass)
            .count()
    )
}

/// The median (the mean of the middle two for an even count), lowest and highest of `values`
/// (at least one): how a set of runs of one case is summed up against an experiment's
/// repeated runs.
pub fn median_range(values: &[Real]) -> (Real, Real, Real) {
    let mut v = values.to_vec();
    v.sort_by(Real::total_cmp);
    let n = v.len();
    let median = if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    };
    (median, v[0], v[n - 1])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_set_of_runs_gives_its_median_and_range() {
        assert_eq!(median_range(&[3.0, 1.0, 2.0]), (2.0, 1.0, 3.0));
        assert_eq!(median_range(&[4.0, 1.0, 2.0, 3.0]), (2.5, 1.0, 4.0));
    }

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

    fn row(pass: bool) -> Row {
        Row::categorical("c", "s", "q", "a", if pass { "a" } else { "b" })
    }

    #[test]
    fn every_row_as_documented_is_success() {
        let rows = [row(true), row(false).known_limitation("Eq. 14")];
        assert!(all_as_expected(&rows));
        let table = markdown(&rows);
        assert!(
            table.contains("no (known limitation: Eq. 14)") && !table.contains("**"),
            "{table}"
        );
        assert!(outcome(&rows).contains("1 passed, 0 failed, 1 known limitation(s) of which 0"));
    }

    #[test]
    fn an_ordinary_failure_is_failure() {
        let rows = [row(false), row(false).known_limitation("Eq. 14")];
        assert!(!all_as_expected(&rows));
        assert!(!rows[0].as_expected() && rows[1].as_expected());
    }

    #[test]
    fn a_known_limitation_that_passes_is_failure() {
        let rows = [row(true), row(true).known_limitation("Eq. 14")];
        assert!(!all_as_expected(&rows));
        assert!(markdown(&rows).contains("**yes, but listed as a known limitation**"));
        assert!(outcome(&rows).contains("of which 1 unexpectedly passed"));
    }

    #[test]
    fn no_rows_is_success_and_all_passing_is_success() {
        assert!(all_as_expected(&[]));
        assert!(all_as_expected(&[row(true), row(true)]));
    }
}
