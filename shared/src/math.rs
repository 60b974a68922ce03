//! The scalar and vector types of the whole project, fixed in one place (as salva and rapier do).

/// Every physical quantity is computed in double precision: SPH pressure sums and DDA contact
/// springs both lose too much in `f32` over the millions of steps a run takes.
pub type Real = f64;
pub type Vector = nalgebra::Vector3<Real>;
pub type Point = nalgebra::Point3<Real>;
pub type Matrix = nalgebra::Matrix3<Real>;
pub type Rotation = nalgebra::UnitQuaternion<Real>;
pub type Isometry = nalgebra::Isometry3<Real>;
/// A rigid block's six velocities or loads, (linear, angular).
pub type Vector6 = nalgebra::SVector<Real, 6>;
/// A map between them (a block's mobility).
pub type Matrix6 = nalgebra::SMatrix<Real, 6, 6>;

/// Standard gravity [m/s²], the default of every scene.
pub const STANDARD_GRAVITY: Real = 9.81;

/// A number as messages print it: plainly (`{}`) at ordinary magnitudes, in exponent form
/// (`{:e}`) outside them. Rust's `{}` writes every digit, so a typo such as `1e300` in a
/// refused field came back as a line of 301 digits, and `1e-300` as 300 zeros. A precision
/// (`{:.3}`) applies to either form.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Readable(pub Real);

/// [`Readable`]: `format!("--dx {}", readable(dx))`.
pub fn readable(x: Real) -> Readable {
    Readable(x)
}

impl std::fmt::Display for Readable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // From 1e-4 (0.0001, still read at a glance) to below 1e6 (a million is "1e6").
        let plain = self.0 == 0.0 || !self.0.is_finite() || (1e-4..1e6).contains(&self.0.abs());
        if plain {
            std::fmt::Display::fmt(&self.0, f)
        } else {
            std::fmt::LowerExp::fmt(&self.0, f)
        }
    }
}

/// The first run of 20 digits or more in `text`: a number printed with Rust's `{}` far from 1
/// (`1e300` as 301 digits), which [`readable`] never prints. What the refusal tests look for
/// in every message (`coupler/tests/cli.rs`, `shared/tests/malformed_scenes.rs`).
pub fn long_number(text: &str) -> Option<&str> {
    let mut start = None;
    for (i, ch) in text.char_indices() {
        match (ch.is_ascii_digit(), start) {
            (true, None) => start = Some(i),
            (false, Some(s)) if i - s >= 20 => return Some(&text[s..i]),
            (false, Some(_)) => start = None,
            _ => {}
        }
    }
    start.filter(|&s| text.len() - s >= 20).map(|s| &text[s..])
}

#[cfg(test)]
mod tests {
    use super::readable;

    #[test]
    fn ordinary_numbers_print_plainly_and_the_rest_with_an_exponent() {
        for (x, text) in [
            (0.04, "0.04"),
            (-2.5, "-2.5"),
            (0.0, "0"),
            (60.0, "60"),
            (1e-4, "0.0001"),
            (999999.0, "999999"),
            (1e6, "1e6"),
            (1e300, "1e300"),
            (-1e300, "-1e300"),
            (1e-300, "1e-300"),
            (2.5e-7, "2.5e-7"),
            (f64::NAN, "NaN"),
            (f64::INFINITY, "inf"),
        ] {
            assert_eq!(readable(x).to_string(), text);
        }
        assert_eq!(format!("{:.3}", readable(2.0 / 3.0)), "0.667");
        assert_eq!(format!("{:.3}", readable(2.5e301)), "2.500e301");
    }
}
