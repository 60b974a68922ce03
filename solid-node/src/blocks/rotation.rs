//! Exact rotation updates.
//!
//! DDA's original first-order rotation (Shi 1993) moves a vertex by `θ × r`, which stretches every
//! block by a factor `1 + θ²` per step in area (`sqrt(1 + θ²)` in length): a spinning block
//! grows without bound. Here the incremental rotation vector `θ` of a step is turned into the
//! exact rotation `exp(θ)` (Rodrigues' formula, as a unit quaternion) and composed with the
//! block's orientation, so world vertices are always `R·local`, a rigid placement of the
//! block's original corners; nothing can grow.

use shared::math::{Real, Rotation, Vector};

/// The rotation by angle `|θ|` about `θ/|θ|` (the exponential map of so(3)). Below 1e-12 rad it
/// is the identity to machine precision, which `from_scaled_axis` already handles.
#[inline]
pub fn exp(theta: &Vector) -> Rotation {
    Rotation::from_scaled_axis(*theta)
}

/// Applies the incremental world-frame rotation `θ` to `q`: `q ← exp(θ)·q`, renormalised so
/// that round-off cannot accumulate over millions of steps.
#[inline]
pub fn integrate(q: &Rotation, theta: &Vector) -> Rotation {
    let mut r = exp(theta) * q;
    r.renormalize_fast();
    r
}

/// The rotation vector of `q` (its logarithm): the angle times the axis.
#[inline]
pub fn log(q: &Rotation) -> Vector {
    q.scaled_axis()
}

/// Angle [rad] of `q`, in [0, π].
#[inline]
pub fn angle(q: &Rotation) -> Real {
    q.angle()
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared::math::Point;

    /// 10⁵ steps of 0.01 rad about a tilted axis: every corner keeps its distance to the
    /// centroid to round-off, and the total angle is the sum of the increments.
    #[test]
    fn exact_rotation_does_not_grow_blocks() {
        let corners = [
            Point::new(0.5, 0.25, 0.1),
            Point::new(-0.5, 0.25, -0.1),
            Point::new(0.2, -0.7, 0.3),
        ];
        let axis = Vector::new(1.0, 2.0, -0.5).normalize();
        let dtheta = axis * 0.01;
        let mut q = Rotation::identity();
        let steps = 100_000;
        for _ in 0..steps {
            q = integrate(&q, &dtheta);
        }
        for c in &corners {
            let moved = q * c;
            let growth = moved.coords.norm() / c.coords.norm() - 1.0;
            assert!(growth.abs() < 1e-12, "corner grew by {growth:e}");
        }
        // 1000 rad in total: compare against the closed form rotation.
        let expected = exp(&(axis * (0.01 * steps as Real)));
        assert!(
            q.angle_to(&expected) < 1e-9,
            "angle error {}",
            q.angle_to(&expected)
        );
        // Shi's linearised update would have grown each length by (1 + θ²)^(n/2).
        let linear_growth = (1.0 + 0.01f64.powi(2)).powf(steps as Real / 2.0);
        assert!(linear_growth > 100.0, "reference growth {linear_growth}");
    }

    #[test]
    fn log_inverts_exp() {
        let theta = Vector::new(0.3, -0.2, 0.9);
        assert!((log(&exp(&theta)) - theta).norm() < 1e-14);
        assert!((angle(&exp(&theta)) - theta.norm()).abs() < 1e-14);
    }
}
