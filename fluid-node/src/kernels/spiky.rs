use super::kernel::Kernel;
use shared::math::Real;
use std::f64::consts::PI;

/// Desbrun's spiky kernel as used by Müller et al. (2003) for pressure (paper Eq. 15):
/// W = 15/(π h⁶)·(h − r)³, ∇W = −45/(π h⁶)·(h − r)²·r̂ for r ≤ h. Its gradient does not vanish
/// at r = 0, so close particles keep repelling each other instead of clustering.
///
/// The paper prints Eq. 15 garbled; this is Müller's form, which the paper cites.
#[derive(Debug, Clone, Copy, serde::Serialize, serde::Deserialize)]
pub struct Spiky {
    h: Real,
    c: Real,
}

impl Spiky {
    pub fn new(h: Real) -> Self {
        Self {
            h,
            c: 15.0 / (PI * h.powi(6)),
        }
    }

    /// The normalisation c of W = c (h − r)³ (so W'(r)/r = −3c (h − r)²/r).
    pub fn coefficient(&self) -> Real {
        self.c
    }
}

impl Kernel for Spiky {
    fn support(&self) -> Real {
        self.h
    }
    #[inline]
    fn value(&self, r: Real) -> Real {
        if r >= self.h {
            return 0.0;
        }
        let d = self.h - r;
        self.c * d * d * d
    }
    #[inline]
    fn gradient_factor(&self, r: Real) -> Real {
        if r >= self.h {
            return 0.0;
        }
        let d = self.h - r;
        // r̂ = r_ij / r; guard the coincident pair, whose direction is undefined.
        -3.0 * self.c * d * d / r.max(1e-12 * self.h)
    }
    #[inline]
    fn laplacian(&self, r: Real) -> Real {
        if r >= self.h {
            return 0.0;
        }
        let d = self.h - r;
        6.0 * self.c * d * (2.0 * r - self.h) / r.max(1e-12 * self.h)
    }
}
