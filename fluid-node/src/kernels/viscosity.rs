use super::kernel::Kernel;
use shared::math::Real;
use std::f64::consts::PI;

/// Müller et al. (2003) viscosity kernel (paper Eq. 19):
/// W = 15/(2π h³)·(−r³/(2h³) + r²/h² + h/(2r) − 1), whose Laplacian 45/(π h⁶)·(h − r) is
/// positive everywhere, so the viscous force (paper Eq. 18) only ever damps relative velocity.
#[derive(Debug, Clone, Copy, serde::Serialize, serde::Deserialize)]
pub struct ViscosityKernel {
    h: Real,
    c: Real,
    lap: Real,
}

impl ViscosityKernel {
    pub fn new(h: Real) -> Self {
        Self {
            h,
            c: 15.0 / (2.0 * PI * h.powi(3)),
            lap: 45.0 / (PI * h.powi(6)),
        }
    }

    /// The factor of ∇²W = lap·(h − r).
    pub fn laplacian_coefficient(&self) -> Real {
        self.lap
    }
}

impl Kernel for ViscosityKernel {
    fn support(&self) -> Real {
        self.h
    }
    #[inline]
    fn value(&self, r: Real) -> Real {
        if r >= self.h {
            return 0.0;
        }
        let h = self.h;
        let r = r.max(1e-12 * h);
        self.c * (-r * r * r / (2.0 * h * h * h) + r * r / (h * h) + h / (2.0 * r) - 1.0)
    }
    #[inline]
    fn gradient_factor(&self, r: Real) -> Real {
        if r >= self.h {
            return 0.0;
        }
        let h = self.h;
        let r = r.max(1e-12 * h);
        self.c * (-3.0 * r / (2.0 * h * h * h) + 2.0 / (h * h) - h / (2.0 * r * r * r))
    }
    #[inline]
    fn laplacian(&self, r: Real) -> Real {
        if r >= self.h {
            return 0.0;
        }
        self.lap * (self.h - r)
    }
}
