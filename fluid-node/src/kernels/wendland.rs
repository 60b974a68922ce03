use super::kernel::Kernel;
use shared::math::Real;
use std::f64::consts::PI;

/// Wendland (1995) C2 kernel in 3D with smoothing length h and support 2h:
/// W = 21/(16π h³)·(1 − q/2)⁴(2q + 1), q = r/h ≤ 2. Positive Fourier transform, so it does not
/// suffer the pairing instability of the cubic spline (Dehnen & Aly 2012).
#[derive(Debug, Clone, Copy, serde::Serialize, serde::Deserialize)]
pub struct WendlandC2 {
    h: Real,
    inv_h: Real,
    alpha: Real,
}

impl WendlandC2 {
    /// `h` is the smoothing length; the support is 2h.
    pub fn new(h: Real) -> Self {
        Self {
            h,
            inv_h: 1.0 / h,
            alpha: 21.0 / (16.0 * PI * h.powi(3)),
        }
    }
    pub fn smoothing_length(&self) -> Real {
        self.h
    }

    /// [`Kernel::gradient_factor`] for r inside the support, without the test (callers mask
    /// the pairs outside), so that a vectorised pair loop has no branch.
    #[inline(always)]
    pub fn gradient_factor_inside(&self, r: Real) -> Real {
        let t = 1.0 - 0.5 * r * self.inv_h;
        -5.0 * self.alpha * t * t * t * self.inv_h * self.inv_h
    }
}

impl Kernel for WendlandC2 {
    fn support(&self) -> Real {
        2.0 * self.h
    }
    #[inline]
    fn value(&self, r: Real) -> Real {
        let q = r * self.inv_h;
        if q >= 2.0 {
            return 0.0;
        }
        let t = 1.0 - 0.5 * q;
        let t2 = t * t;
        self.alpha * t2 * t2 * (2.0 * q + 1.0)
    }
    #[inline]
    fn gradient_factor(&self, r: Real) -> Real {
        let q = r * self.inv_h;
        if q >= 2.0 {
            return 0.0;
        }
        let t = 1.0 - 0.5 * q;
        // dW/dr = −5α q (1 − q/2)³ / h, divided by r = q h.
        -5.0 * self.alpha * t * t * t * self.inv_h * self.inv_h
    }
    #[inline]
    fn laplacian(&self, r: Real) -> Real {
        let q = r * self.inv_h;
        if q >= 2.0 {
            return 0.0;
        }
        let t = 1.0 - 0.5 * q;
        -15.0 * self.alpha * t * t * (1.0 - q) * self.inv_h * self.inv_h
    }
}
