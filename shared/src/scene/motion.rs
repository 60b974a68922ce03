//! Prescribed motion of kinematic blocks, evaluated where it is needed (the solid node).

use super::MotionSpec;
use crate::math::Vector;
use std::f64::consts::TAU;

impl MotionSpec {
    /// Ramp factor s(t) and its rate: a smoothstep 3τ² − 2τ³ over `ramp` seconds, so a piston
    /// starts without an infinite acceleration.
    fn ramp(ramp: f64, t: f64) -> (f64, f64) {
        if ramp <= 0.0 || t >= ramp {
            return (1.0, 0.0);
        }
        let tau = (t / ramp).max(0.0);
        (
            tau * tau * (3.0 - 2.0 * tau),
            6.0 * tau * (1.0 - tau) / ramp,
        )
    }

    /// Displacement of the block from its scene position at time t [m].
    pub fn displacement(&self, t: f64) -> Vector {
        match self {
            MotionSpec::Sine {
                amplitude,
                period,
                phase,
                ramp,
            } => {
                let (s, _) = Self::ramp(*ramp, t);
                let w = TAU / period;
                Vector::from(*amplitude) * (s * ((w * t + phase).sin() - phase.sin()))
            }
            MotionSpec::Linear { velocity } => Vector::from(*velocity) * t,
        }
    }

    /// Velocity at time t [m/s], the exact derivative of [`Self::displacement`].
    pub fn velocity(&self, t: f64) -> Vector {
        match self {
            MotionSpec::Sine {
                amplitude,
                period,
                phase,
                ramp,
            } => {
                let (s, ds) = Self::ramp(*ramp, t);
                let w = TAU / period;
                let f = (w * t + phase).sin() - phase.sin();
                Vector::from(*amplitude) * (ds * f + s * w * (w * t + phase).cos())
            }
            MotionSpec::Linear { velocity } => Vector::from(*velocity),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn velocity_is_derivative_of_displacement() {
        let m = MotionSpec::Sine {
            amplitude: [0.3, 0.0, 0.0],
            period: 2.0,
            phase: 0.4,
            ramp: 1.0,
        };
        for &t in &[0.1, 0.5, 0.99, 1.5, 3.2] {
            let h = 1e-6;
            let fd = (m.displacement(t + h) - m.displacement(t - h)) / (2.0 * h);
            assert!((fd - m.velocity(t)).norm() < 1e-6, "t = {t}");
        }
        assert!(m.displacement(0.0).norm() < 1e-15);
    }
}
