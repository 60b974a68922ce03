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
