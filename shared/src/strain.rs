//! The constant strain of a deformable DDA block (Shi 1993; Shi 2001, 3D-DDA): the six extra
//! unknowns of a 12-DOF block and the matrices built on them, shared by the solid node (which
//! integrates the strain) and the fluid node (which moves the block's surface with it and loads
//! it).
//!
//! A material point at X (block frame, centroid at the origin, undeformed) is at
//!
//! ```text
//! x = c + R (I + E) X,        E = [ εx    γxy/2 γzx/2 ]
//!                                 [ γxy/2 εy    γyz/2 ]
//!                                 [ γzx/2 γyz/2 εz    ]
//! ```
//!
//! with the strain vector e = (εx, εy, εz, γyz, γzx, γxy) (Shi's order, engineering shears).
//! The rotation R is carried exactly (co-rotational, as the rigid blocks' is), so a spinning
//! block does not grow; E is a small strain in the block's own frame. The strain part of DDA's
//! displacement matrix is T_e(X) with T_e(X)·e = E·X.

use crate::math::{Matrix, Real, Vector};

/// e = (εx, εy, εz, γyz, γzx, γxy).
pub type Strain = nalgebra::Vector6<Real>;
pub type Matrix6 = nalgebra::Matrix6<Real>;

/// The symmetric strain tensor E of a strain vector.
#[inline]
pub fn tensor(e: &Strain) -> Matrix {
    Matrix::new(
        e[0],
        0.5 * e[5],
        0.5 * e[4],
        0.5 * e[5],
        e[1],
        0.5 * e[3],
        0.5 * e[4],
        0.5 * e[3],
        e[2],
    )
}

/// The strain vector of a (symmetric part of a) tensor.
#[inline]
pub fn from_tensor(m: &Matrix) -> Strain {
    Strain::new(
        m[(0, 0)],
        m[(1, 1)],
        m[(2, 2)],
        m[(1, 2)] + m[(2, 1)],
        m[(0, 2)] + m[(2, 0)],
        m[(0, 1)] + m[(1, 0)],
    )
}

/// T_e(X)ᵀ f: the generalised force on the strain unknowns of a force `f` acting at the
/// material point `x` (both in the block frame). Its work over a strain change δe is
/// f · (δE X). Also the strain part of a contact spring's direction (f a unit vector).
#[inline]
pub fn generalised_force(x: &Vector, f: &Vector) -> Strain {
    Strain::new(
        f.x * x.x,
        f.y * x.y,
        f.z * x.z,
        0.5 * (f.y * x.z + f.z * x.y),
        0.5 * (f.z * x.x + f.x * x.z),
        0.5 * (f.x * x.y + f.y * x.x),
    )
}

/// Isotropic linear elasticity D (σ = D e, engineering shears): Shi's block stiffness is V·D.
pub fn elasticity(young: Real, poisson: Real) -> Matrix6 {
    let lambda = young * poisson / ((1.0 + poisson) * (1.0 - 2.0 * poisson));
    let mu = young / (2.0 * (1.0 + poisson));
    let mut d = Matrix6::zeros();
    for i in 0..3 {
        for j in 0..3 {
            d[(i, j)] = lambda;
        }
        d[(i, i)] = lambda + 2.0 * mu;
        d[(i + 3, i + 3)] = mu;
    }
    d
}

/// Second moment of volume J = ∫ X Xᵀ dV [m⁵] from the inertia tensor per unit density
/// I = tr(J)·1 − J about the centroid.
pub fn second_moment(unit_inertia: &Matrix) -> Matrix {
    Matrix::identity() * (0.5 * unit_inertia.trace()) - unit_inertia
}

/// The strain block of DDA's mass matrix, ρ ∫ T_eᵀ T_e dV, from the second moment J.
///
/// Row k of T_e(X) is Xᵀ B_k with constant 3×6 matrices B_k, so ∫ T_eᵀ T_e = Σ_k B_kᵀ J B_k.
/// For a cube of side L: ρ V L²/12 on the normal strains, ρ V L²/24 on the shears.
pub fn inertia(second_moment: &Matrix, density: Real) -> Matrix6 {
    // (row k, coordinate a, strain j, coefficient) of T_e(X)[k][j] = Σ_a X_a B_k[a][j].
    const TERMS: [(usize, usize, usize, Real); 9] = [
        (0, 0, 0, 1.0),
        (0, 2, 4, 0.5),
        (0, 1, 5, 0.5),
        (1, 1, 1, 1.0),
        (1, 2, 3, 0.5),
        (1, 0, 5, 0.5),
        (2, 2, 2, 1.0),
        (2, 1, 3, 0.5),
        (2, 0, 4, 0.5),
    ];
    let mut m = Matrix6::zeros();
    for &(k, a, i, ci) in &TERMS {
        for &(l, b, j, cj) in &TERMS {
            if k == l {
                m[(i, j)] += ci * cj * second_moment[(a, b)];
            }
        }
    }
    m * density
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn generalised_force_is_the_work_conjugate_of_the_strain() {
        let x = Vector::new(0.3, -0.2, 0.7);
        let f = Vector::new(1.5, 2.0, -0.4);
        let de = Strain::new(1e-3, -2e-3, 5e-4, 3e-3, -1e-3, 2e-3);
        let work = f.dot(&(tensor(&de) * x));
        assert!((generalised_force(&x, &f).dot(&de) - work).abs() < 1e-15);
        assert_eq!(from_tensor(&tensor(&de)), de);
    }

    #[test]
    fn cube_strain_inertia_and_elastic_frequencies() {
        // Unit-density cube of side L about its centroid: I = V L²/6 · 1.
        let (l, rho) = (2.0, 1000.0);
        let v = l * l * l;
        let j = second_moment(&(Matrix::identity() * (v * l * l / 6.0)));
        let m = inertia(&j, rho);
        for i in 0..3 {
            assert!((m[(i, i)] - rho * v * l * l / 12.0).abs() < 1e-9);
            assert!((m[(i + 3, i + 3)] - rho * v * l * l / 24.0).abs() < 1e-9);
        }
        assert!((m - Matrix6::from_diagonal(&m.diagonal())).norm() < 1e-9);
        // The shear mode of a constant-strain cube: ω² = 24 μ / (ρ L²).
        let (e, nu) = (1e6, 0.25);
        let d = elasticity(e, nu);
        let mu = e / (2.0 * (1.0 + nu));
        let w2 = d[(5, 5)] * v / m[(5, 5)];
        assert!((w2 / (24.0 * mu / (rho * l * l)) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn uniaxial_stress_gives_young_and_poisson() {
        let (e, nu) = (2e9, 0.3);
        let d = elasticity(e, nu);
        let strain = d.try_inverse().unwrap() * Strain::new(0.0, 0.0, -1e6, 0.0, 0.0, 0.0);
        assert!((strain[2] + 1e6 / e).abs() < 1e-15);
        assert!((strain[0] - nu * 1e6 / e).abs() < 1e-15);
    }
}
