//! The smoothing kernel W(r, h) of SPH interpolation (paper Eq. 11): one concept, one trait.

use shared::math::{Real, Vector};

/// A radially symmetric smoothing kernel with compact support.
///
/// Every quantity is a function of the distance r = |r_ij| only; the gradient is returned as the
/// factor F(r) = W'(r)/r, so that ∇_i W(r_ij) = F(r)·r_ij without a division by r in the hot loop
/// of each caller.
pub trait Kernel: Send + Sync {
    /// Radius beyond which the kernel and all its derivatives vanish.
    fn support(&self) -> Real;
    /// W(r).
    fn value(&self, r: Real) -> Real;
    /// W'(r)/r: multiply by r_ij = r_i − r_j to get ∇_i W.
    fn gradient_factor(&self, r: Real) -> Real;
    /// ∇²W(r).
    fn laplacian(&self, r: Real) -> Real;

    /// ∇_i W(r_ij) for the separation vector r_ij = r_i − r_j of length r.
    #[inline]
    fn gradient(&self, rij: &Vector, r: Real) -> Vector {
        rij * self.gradient_factor(r)
    }
}

/// The sum Σ_j m W(|x_i − x_j|) at a particle inside a full cubic lattice of spacing dx, itself
/// included: the density a summed-density scheme gives water at rest in the discrete sense,
/// its ρ0 (Müller's poly6 of Eq. 12, DFSPH's Wendland). The continuum ρ0 instead would start
/// every particle compressed or stretched by the kernel's lattice error (1 % for poly6 at
/// h = 2 dx).
pub fn lattice_density<K: Kernel>(kernel: &K, dx: Real, mass: Real) -> Real {
    let n = (kernel.support() / dx).ceil() as i64;
    let mut sum = 0.0;
    for i in -n..=n {
        for j in -n..=n {
            for k in -n..=n {
                let r = Vector::new(i as Real, j as Real, k as Real) * dx;
                sum += mass * kernel.value(r.norm());
            }
        }
    }
    sum
}
