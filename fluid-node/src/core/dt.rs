//! The stable step an SPH solver proposes (Monaghan 1992; Morris et al. 1997): the smallest of
//! - CFL: C·h/(c + v_max) (sound crossing a smoothing length; Monaghan 1992),
//! - force: C·sqrt(h/|a|_max) (no particle moves more than ~h under its acceleration),
//! - viscous: 0.125·h²/ν (explicit diffusion; Morris et al. 1997), ν the fluid's viscosity
//!   plus, for WCSPH's artificial viscosity, its equivalent α·h·c0/10 (Monaghan 2005), which
//!   binds past α ≈ 6 at the default Courant number (α = 10 and 20 blew up without it),
//! - density diffusion: 0.125·h²/D with D = δ·h·c0, the δ-SPH term's diffusivity (Molteni &
//!   Colagrossi 2009), the same explicit bound as the viscous one: 0.125·h/(δ·c0), which binds
//!   past δ = 0.625 at the default Courant number 0.2 (a dam break at δ = 0.8 stopped on the
//!   density bound without it and runs with it; docs/VALIDATION.md, "Defaults derived from the
//!   scene"),
//! - penalty: ½·2/sqrt(K_S/m), the explicit limit of the Eq. 22 spring halved for its damper.

use shared::math::Real;

/// Inputs of the proposal.
#[derive(Debug, Clone, Copy, serde::Serialize, serde::Deserialize)]
pub struct StepLimits {
    /// Length scale of the kernel (smoothing length h) [m].
    pub h: Real,
    /// Speed of sound [m/s].
    pub sound_speed: Real,
    /// Kinematic viscosity acting in the scheme [m²/s] (0 for none), an artificial
    /// viscosity's equivalent included.
    pub viscosity: Real,
    /// Diffusivity of the density diffusion [m²/s], δ·h·c0 for δ-SPH (0 for none).
    pub diffusivity: Real,
    /// Eq. 22 spring K_S [N/m] and particle mass [kg].
    pub penalty_stiffness: Real,
    pub mass: Real,
    /// Courant number applied to the CFL and force limits.
    pub cfl: Real,
}

/// Which limit set the step, for messages and tests.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Limit {
    Cfl,
    Force,
    Viscous,
    Diffusion,
    Penalty,
}

impl StepLimits {
    /// The proposal for the current largest speed and acceleration.
    pub fn propose(&self, v_max: Real, a_max: Real) -> (Real, Limit) {
        let mut best = (self.cfl * self.h / (self.sound_speed + v_max), Limit::Cfl);
        let mut take = |dt: Real, l: Limit| {
            if dt < best.0 {
                best = (dt, l);
            }
        };
        if a_max > 0.0 {
            take(self.cfl * (self.h / a_max).sqrt(), Limit::Force);
        }
        if self.viscosity > 0.0 {
            take(0.125 * self.h * self.h / self.viscosity, Limit::Viscous);
        }
        if self.diffusivity > 0.0 {
            take(0.125 * self.h * self.h / self.diffusivity, Limit::Diffusion);
        }
        if self.penalty_stiffness > 0.0 {
            take((self.mass / self.penalty_stiffness).sqrt(), Limit::Penalty);
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_limit_can_bind() {
        let base = StepLimits {
            h: 0.01,
            sound_speed: 20.0,
            viscosity: 1e-6,
            diffusivity: 0.1 * 0.01 * 20.0,
            penalty_stiffness: 1.0,
            mass: 1e-3,
            cfl: 0.2,
        };
        let (dt, l) = base.propose(0.0, 9.81);
        assert_eq!(l, Limit::Cfl);
        assert!((dt - 0.2 * 0.01 / 20.0).abs() < 1e-15);
        assert_eq!(base.propose(0.0, 1e6).1, Limit::Force);
        assert_eq!(
            StepLimits {
                viscosity: 1.0,
                ..base
            }
            .propose(0.0, 9.81)
            .1,
            Limit::Viscous
        );
        // δ = 0.8 at the default Courant number: 0.125 h/(δ c0) < 0.2 h/c0.
        let (dt, l) = StepLimits {
            diffusivity: 0.8 * 0.01 * 20.0,
            ..base
        }
        .propose(0.0, 9.81);
        assert_eq!(l, Limit::Diffusion);
        assert!((dt - 0.125 * 0.01 / (0.8 * 20.0)).abs() < 1e-15);
        let stiff = StepLimits {
            penalty_stiffness: 1e6,
            ..base
        };
        let (dt, l) = stiff.propose(0.0, 9.81);
        assert_eq!(l, Limit::Penalty);
        // Half of 2/ω.
        assert!((dt - 1.0 / (1e6f64 / 1e-3).sqrt()).abs() < 1e-15);
    }
}
