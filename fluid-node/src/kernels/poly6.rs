use super::kernel::Kernel;
use shared::math::Real;
use std::f64::consts::PI;

/// Müller et al. (2003) poly6 kernel, used for density (paper Eqs. 12–13):
/// W = 315/(64π h⁹)·(h² − r²)³ for r ≤ h. Its value needs only r², but its gradient vanishes at
/// r = 0, which is why pressure uses the spiky kernel instead.
#[derive(Debug, Clone, Copy, serde::Serialize, serde::Deserialize)]
pub struct Poly6 {
    h: Real,
    h2: Real,
    c: Real,
}

impl Poly6 {
    pub fn new(h: Real) -> Self {
        Self {
            h,
            h2: h * h,
            c: 315.0 / (64.0 * PI * h.powi(9)),
        }
    }

    /// The normalisation c of W = c (h² − r²)³.
    pub fn coefficient(&self) -> Real {
        self.c
    }

    /// W from the squared distance, saving the square root in the density loop.
    #[inline]
    pub fn value_r2(&self, r2: Real) -> Real {
        if r2 >= self.h2 {
            return 0.0;
        }
        let d = self.h2 - r2;
        self.c * d * d * d
    }
}

impl Kernel for Poly6 {
    fn support(&self) -> Real {
        self.h
    }
    #[inline]
    fn value(&self, r: Real) -> Real {
        self.value_r2(r * r)
    }
    #[inline]
    fn gradient_factor(&self, r: Real) -> Real {
        if r >= self.h {
            return 0.0;
        }
        let d = self.h2 - r * r;
        -6.0 * self.c * d * d
    }
    #[inline]
    fn laplacian(&self, r: Real) -> Real {
        if r >= self.h {
            return 0.0;
        }
        let r2 = r * r;
        -6.0 * self.c * (self.h2 - r2) * (3.0 * self.h2 - 7.0 * r2)
    }
}
