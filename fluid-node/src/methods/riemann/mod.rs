//! `riemann`: weakly compressible SPH whose pairs exchange momentum and mass through a
//! low-dissipation Riemann solver (Zhang, Hu & Adams 2017, J. Comput. Phys. 335, 605–620) in
//! place of artificial viscosity and δ-SPH. Everything else is [`Wcsph`]'s: Tait's equation of
//! state, Wendland C2, the continuity equation, the integrators, the adaptive step, Adami's
//! walls; the pair sums are [`crate::methods::wcsph::riemann`].
//!
//! Why a method of its own: the Riemann solver's dissipation is scaled by the compression of
//! each pair (their Eq. 18 limiter), not by a constant viscosity, which is what an impact
//! pressure needs (docs/VALIDATION.md, "Impact pressure: resolution study"); as a registry entry
//! it runs every validation row, every rank test and the speed–accuracy chart as `wcsph` does.

use crate::kernels::WendlandC2;
use crate::methods::SphMethod;
use crate::methods::wcsph::{Flux, Wcsph, WcsphParams, sound_speed};
use crate::system::{FluidSystem, Initial, Layout};
use crate::validation::Check;
use serde::Deserialize;
use shared::math::{Real, Vector};
use shared::registry::{ParamCheck, SolverParams, Variant};
use shared::scene::{FieldError, Scene};
use shared::solver::{SolverError, StepReport};

/// `[fluid.riemann]`: WCSPH's parameters ([`WcsphParams`]: `sound_speed`, `gamma`,
/// `smoothing_ratio`, `integrator`, `cfl`, `skin`) without `alpha` and `delta`, whose work the
/// Riemann solver's dissipation does.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(transparent)]
pub struct RiemannParams(pub WcsphParams);

impl SolverParams for RiemannParams {
    fn check(&self, c: &mut ParamCheck) {
        self.0.check_shared(c);
        c.non_negative(
            "wall_limiter",
            self.0.wall_limiter,
            "e.g. wall_limiter = 10; 0 disables the walls' dissipation",
        );
        for (field, value) in [("alpha", self.0.alpha), ("delta", self.0.delta)] {
            if let Some(v) = value {
                c.fail(
                    field,
                    v,
                    "is not a parameter of riemann (its Riemann solver dissipates instead of artificial viscosity and δ-SPH)",
                    "remove it, or use solver = \"wcsph\"",
                );
            }
        }
    }
}

/// WCSPH with the Riemann flux: [`Wcsph`] built with [`Flux::Riemann`].
#[derive(serde::Serialize, serde::Deserialize)]
#[serde(transparent)]
pub struct Riemann(Wcsph);

impl SphMethod for Riemann {
    const NAME: &'static str = "riemann";
    const DESCRIPTION: &'static str = "weakly compressible SPH with a low-dissipation Riemann solver (Zhang, Hu & Adams 2017) in place of artificial viscosity and δ-SPH";
    /// 0.81 of WCSPH's rate, interleaved with it (docs/PERFORMANCE.md, "Fluid: cost per
    /// particle-step"), on WCSPH's measured 4.61·10⁶.
    const PARTICLE_STEPS_PER_SECOND: Option<f64> = Some(3.7e6);
    const SPLITS: bool = true;
    type Params = RiemannParams;
    type Kernel = WendlandC2;

    fn new(params: RiemannParams, init: &Initial) -> Result<(Self, Layout), SolverError> {
        let (wcsph, layout) = Wcsph::with_flux(params.0, Flux::Riemann, init)?;
        Ok((Self(wcsph), layout))
    }

    fn start(&mut self, sys: &mut FluidSystem) {
        self.0.start(sys)
    }

    fn step(&mut self, sys: &mut FluidSystem, dt: Real) -> Result<StepReport, SolverError> {
        self.0.step(sys, dt)
    }

    fn react(&mut self, sys: &mut FluidSystem) {
        self.0.react(sys)
    }

    fn fixed_wall_forces(&self, sys: &FluidSystem, i: usize, visit: &mut dyn FnMut(usize, Vector)) {
        self.0.fixed_wall_forces(sys, i, visit)
    }

    fn kernel(&self) -> &WendlandC2 {
        self.0.kernel()
    }

    fn density_check(&self) -> (bool, Real) {
        self.0.density_check()
    }

    fn dt_proposal(&self, v_max: Real, a_max: Real) -> Real {
        self.0.dt_proposal(v_max, a_max)
    }

    /// A speed of sound too low for the water's depth (`wcsph::sound_speed`).
    fn check_against(params: &RiemannParams, scene: &Scene) -> Vec<FieldError> {
        sound_speed::check(Self::NAME, params.0.sound_speed, params.0.gamma, scene)
            .into_iter()
            .collect()
    }

    /// Not in the stability maps: its step limits are WCSPH's, whose rows stand for both.
    fn study_variants(_study: &str) -> &'static [Variant] {
        &[]
    }

    /// With its walls' dissipation (`wcsph::riemann::WALL_ETA`) its interpolated impact peak,
    /// in the tank's width, is above the experiment's band at every resolution of the study
    /// and grows (141.8 → 190.7 → 201.9 mbar from H/dx = 15 to 60; docs/VALIDATION.md, "Impact
    /// pressure: resolution study"). The wall's load behind the sensor is inside the band from
    /// H/dx = 30 (102.5, 119.6 mbar: +17 %, past the +10 % of the growth row) and 4 % above it
    /// at 15 (136.0), each peak the highest crest of the load's ringing (at 15 a slam 81 ms
    /// after the onset, at 60 a crest 22 ms after it; docs/journal/2026-11-29-impact-pressures.md,
    /// "12:40, 30 Nov"; the ringing is the lattice's rows striking the wall in step, its
    /// period near dx/sqrt(gH) whatever c0: "The wall's load along the width"), and its
    /// impulse at H = 600 mm is within ±10 % of the median from 30 on
    /// (−9.9, −9.6 %) but 26.5 % short at 15, where the wall's load in the corner is the
    /// water's stress averaged over the kernel's reach (about 0.5 % short per millimetre of h,
    /// 52 mm there: "The wall's load along the width", "Where the wall's impulse goes") and over
    /// the 40 mm cell, whose mean in the finest run is itself 10–13 % below the sensor's point
    /// ("What a cell can read").
    fn known_limitation(check: &str, per_h: usize) -> Option<&'static str> {
        let crest =
            check == Check::ImpactPeak { per_h }.name() || check == Check::ImpactPeakGrowth.name();
        if crest {
            return Some(
                "the Riemann solver's interpolated impact crest is above the band at every resolution and grows; the wall's load is the reading for loads",
            );
        }
        let coarse = per_h == 15
            && (check == Check::WallPeak { per_h }.name()
                || check == Check::WallImpulse { per_h }.name());
        (coarse || check == Check::WallPeakGrowth.name()).then_some(
            "the wall's load rings after the impact and its peak is the highest crest: at H/dx = 15 a slam 81 ms after the onset, 4 % above the band (the first crest 88 mbar), at 60 a crest 22 ms after it, 17 % above the peak at 30 inside the band; at H/dx = 15, H = 600 mm, the impulse is 27 % short, the corner's stress averaged over the kernel's reach (0.5 % per mm of the smoothing length, 52 mm there) and over the 40 mm cell (the finest run's own mean over it 10–13 % below the sensor's point)",
        )
    }
}
