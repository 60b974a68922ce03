//! The kernels used by the solvers: Müller et al. (2003)'s three (paper Eqs. 13, 15, 19) and
//! Wendland's C2 (Wendland 1995), the one DualSPHysics-style WCSPH uses, behind one trait,
//! [`Kernel`] (`kernel.rs`).

mod kernel;
mod poly6;
mod spiky;
mod viscosity;
mod wendland;

pub use kernel::{Kernel, lattice_density};
pub use poly6::Poly6;
pub use spiky::Spiky;
pub use viscosity::ViscosityKernel;
pub use wendland::WendlandC2;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernels::Kernel;
    use std::f64::consts::PI;

    /// ∫ W dV over the support by Simpson's rule on 4π r² W(r).
    fn integral(k: &dyn Kernel) -> f64 {
        let n = 20_000;
        let h = k.support() / n as f64;
        let f = |r: f64| 4.0 * PI * r * r * k.value(r);
        let mut s = f(0.0) + f(k.support());
        for i in 1..n {
            s += f(i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
        }
        s * h / 3.0
    }

    fn kernels() -> Vec<(&'static str, Box<dyn Kernel>)> {
        vec![
            ("poly6", Box::new(Poly6::new(0.3))),
            ("spiky", Box::new(Spiky::new(0.3))),
            ("viscosity", Box::new(ViscosityKernel::new(0.3))),
            ("wendland", Box::new(WendlandC2::new(0.15))),
        ]
    }

    #[test]
    fn kernels_are_normalised() {
        for (name, k) in kernels() {
            let i = integral(k.as_ref());
            assert!((i - 1.0).abs() < 1e-6, "{name}: ∫W dV = {i}");
        }
    }

    #[test]
    fn derivatives_match_finite_differences() {
        for (name, k) in kernels() {
            let s = k.support();
            let e = 1e-6 * s;
            for frac in [0.2, 0.45, 0.7, 0.9] {
                let r = frac * s;
                let d1 = (k.value(r + e) - k.value(r - e)) / (2.0 * e);
                let d2 = (k.value(r + e) - 2.0 * k.value(r) + k.value(r - e)) / (e * e);
                let lap_fd = d2 + 2.0 * d1 / r;
                let g = k.gradient_factor(r) * r;
                assert!(
                    (g - d1).abs() <= 1e-5 * d1.abs().max(1.0),
                    "{name} W'({r}) = {g}, FD {d1}"
                );
                let lap = k.laplacian(r);
                // The viscosity kernel's Laplacian is Müller's closed form, exact only for the
                // kernel's own value; FD of a second derivative loses ~6 digits.
                assert!(
                    (lap - lap_fd).abs() <= 1e-3 * lap_fd.abs().max(1.0),
                    "{name} ∇²W({r}) = {lap}, FD {lap_fd}"
                );
            }
            assert_eq!(k.value(s * 1.0001), 0.0, "{name} outside support");
            assert_eq!(k.gradient_factor(s * 1.0001), 0.0, "{name} outside support");
        }
    }
}
