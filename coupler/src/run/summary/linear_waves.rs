//! Linear (Airy) wave theory for a piston wave maker: the reference the wave-maker summary
//! checks a run's waves against (docs/REFERENCES.md §3.6).
//!
//! - Dispersion: ω² = g k tanh(k h) (Dean & Dalrymple 1991, ch. 3).
//! - Group velocity: c_g = ½ (ω/k) (1 + 2kh / sinh 2kh) (ibid.).
//! - Piston wave maker (Biesel & Suquet 1951; Dean & Dalrymple 1991, ch. 6): a full-depth
//!   piston of stroke S (twice its amplitude) makes, beyond the evanescent modes (a few depths
//!   from it), a progressive wave of height H with
//!   H / S = 2 (cosh 2kh − 1) / (sinh 2kh + 2kh).

use std::f64::consts::TAU;

/// The wavenumber k [1/m] of a wave of angular frequency `omega` [1/s] on depth `depth` [m]
/// under gravity `g` [m/s²]: the root of ω² = g k tanh(k h), by Newton's method.
pub fn wavenumber(omega: f64, depth: f64, g: f64) -> f64 {
    // tanh x ≤ 1 and tanh x ≤ x make the deep-water ω²/g and the shallow-water ω/sqrt(g h)
    // both lower bounds of the root; Newton starts from the nearer one.
    let mut k = (omega * omega / g).max(omega / (g * depth).sqrt());
    for _ in 0..100 {
        let t = (k * depth).tanh();
        let f = g * k * t - omega * omega;
        let df = g * t + g * k * depth * (1.0 - t * t);
        let step = f / df;
        k -= step;
        if step.abs() <= 1e-15 * k {
            break;
        }
    }
    k
}

/// Group velocity [m/s] of wavenumber `k` on depth `depth` (energy travels at it: a wave
/// train's front reaches a gauge after distance / c_g).
pub fn group_velocity(k: f64, depth: f64, g: f64) -> f64 {
    let kh = k * depth;
    let c = (g / k * kh.tanh()).sqrt();
    0.5 * c * (1.0 + 2.0 * kh / (2.0 * kh).sinh())
}

/// Biesel's transfer function H/S of a full-depth piston wave maker at relative depth kh.
/// Tends to kh in shallow water (the piston's swept volume per period spread over a
/// wavelength) and to 2 in deep water.
pub fn piston_height_ratio(kh: f64) -> f64 {
    let s = 2.0 * kh;
    2.0 * (s.cosh() - 1.0) / (s.sinh() + s)
}

/// The wave a piston of amplitude `amplitude` [m] (stroke 2·amplitude) and period `period` [s]
/// makes on depth `depth` [m], by linear theory.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct PistonWave {
    pub period: f64,
    pub depth: f64,
    /// Wavelength 2π/k [m].
    pub wavelength: f64,
    pub kh: f64,
    pub group_velocity: f64,
    /// Progressive wave height H = S · H/S [m].
    pub height: f64,
}

impl PistonWave {
    pub fn new(amplitude: f64, period: f64, depth: f64, g: f64) -> PistonWave {
        let k = wavenumber(TAU / period, depth, g);
        PistonWave {
            period,
            depth,
            wavelength: TAU / k,
            kh: k * depth,
            group_velocity: group_velocity(k, depth, g),
            height: 2.0 * amplitude * piston_height_ratio(k * depth),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_wavenumber_solves_the_dispersion_relation_and_matches_the_tables() {
        let g = 9.81;
        for (omega, h) in [(0.1, 1.0), (2.0944, 1.0), (3.0, 0.5), (10.0, 50.0)] {
            let k = wavenumber(omega, h, g);
            let residual = g * k * (k * h).tanh() - omega * omega;
            assert!(
                residual.abs() < 1e-12 * omega * omega,
                "ω {omega}: {residual}"
            );
        }
        // Shore Protection Manual (1984), Table C-1: h/L₀ = 0.10 gives h/L = 0.1410;
        // h/L₀ = 0.02, h/L = 0.05763.
        for (h_l0, h_l) in [(0.10, 0.1410), (0.02, 0.05763)] {
            let (h, l0) = (1.0, 1.0 / h_l0);
            let omega = (TAU * g / l0).sqrt();
            let k = wavenumber(omega, h, g);
            let got = h * k / TAU;
            assert!((got / h_l - 1.0).abs() < 5e-4, "h/L₀ {h_l0}: h/L {got}");
        }
        // Deep water: k → ω²/g; group velocity → half the phase speed.
        let k = wavenumber(10.0, 50.0, g);
        assert!((k / (100.0 / g) - 1.0).abs() < 1e-12);
        let cg = group_velocity(k, 50.0, g);
        assert!((cg / (0.5 * 10.0 / k) - 1.0).abs() < 1e-9);
        // Shallow water: c_g → sqrt(g h).
        let k = wavenumber(0.01, 1.0, g);
        assert!((group_velocity(k, 1.0, g) / g.sqrt() - 1.0).abs() < 1e-4);
    }

    #[test]
    fn biesels_transfer_tends_to_kh_in_shallow_water_and_2_in_deep() {
        assert!((piston_height_ratio(1e-3) / 1e-3 - 1.0).abs() < 1e-3);
        assert!((piston_height_ratio(20.0) - 2.0).abs() < 1e-6);
        let mut last = 0.0;
        for i in 1..100 {
            let r = piston_height_ratio(0.05 * i as f64);
            assert!(r > last, "H/S increases with kh");
            last = r;
        }
        // The piston's wave is its stroke times the ratio at the kh of its period.
        let wave = PistonWave::new(0.2, 3.0, 1.0, 9.81);
        let k = wavenumber(TAU / 3.0, 1.0, 9.81);
        assert_eq!(wave.height, 0.4 * piston_height_ratio(k * 1.0));
        assert!((wave.wavelength - TAU / k).abs() < 1e-12);
    }
}
