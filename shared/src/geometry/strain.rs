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

/// Where a block's material points are and how fast they move, computed once per pose:
/// x = c + F X and ẋ = v + ω × (F X) + R Ė X, with F = R (I + E). For a rigid block F = R and
/// the strain terms vanish.
#[derive(Debug, Clone, Copy)]
pub struct MaterialMap {
    pub centroid: Vector,
    /// F = R (I + E).
    pub map: Matrix,
    /// F⁻¹.
    pub inverse: Matrix,
    pub rotation: Matrix,
    pub velocity: Vector,
    pub angular_velocity: Vector,
    /// R Ė.
    pub strain_velocity: Matrix,
    pub deformable: bool,
}

impl MaterialMap {
    /// Builds the map of a block at centroid `c`, rotation `r`, velocities `v`, `w`, strain `e`
    /// and strain rate `e_dot` (`None` for a rigid block).
    pub fn new(
        c: Vector,
        r: Matrix,
        v: Vector,
        w: Vector,
        strain: Option<(&Strain, &Strain)>,
    ) -> Self {
        let (map, strain_velocity) = match strain {
            Some((e, e_dot)) => (r * (Matrix::identity() + tensor(e)), r * tensor(e_dot)),
            None => (r, Matrix::zeros()),
        };
        Self {
            centroid: c,
            inverse: map.try_inverse().unwrap_or_else(|| r.transpose()),
            map,
            rotation: r,
            velocity: v,
            angular_velocity: w,
            strain_velocity,
            deformable: strain.is_some(),
        }
    }

    /// World position of the material point X.
    #[inline]
    pub fn position(&self, x: &Vector) -> Vector {
        self.centroid + self.map * x
    }

    /// Material point X now at world position `p`.
    #[inline]
    pub fn material(&self, p: &Vector) -> Vector {
        self.inverse * (p - self.centroid)
    }

    /// Velocity of the material point X.
    #[inline]
    pub fn velocity(&self, x: &Vector) -> Vector {
        let rigid = self.velocity + self.angular_velocity.cross(&(self.map * x));
        if self.deformable {
            rigid + self.strain_velocity * x
        } else {
            rigid
        }
    }

    /// Generalised strain load of a world force `f` at the material point X (zero when rigid).
    #[inline]
    pub fn strain_load(&self, x: &Vector, f: &Vector) -> Strain {
        if self.deformable {
            generalised_force(x, &(self.rotation.transpose() * f))
        } else {
            Strain::zeros()
        }
    }
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
    fn material_map_velocity_is_the_time_derivative_of_position() {
        let r = nalgebra::Rotation3::from_euler_angles(0.3, -0.2, 0.5).into_inner();
        let w = Vector::new(0.4, -1.0, 0.3);
        let (e, e_dot) = (
            Strain::new(0.01, -0.02, 0.005, 0.01, 0.0, -0.03),
            Strain::new(0.1, 0.2, -0.1, 0.3, -0.2, 0.1),
        );
        let (c, v) = (Vector::new(1.0, 2.0, 3.0), Vector::new(0.5, 0.0, -1.0));
        let at = |t: Real| {
            let rt = nalgebra::Rotation3::new(w * t).into_inner() * r;
            MaterialMap::new(c + v * t, rt, v, w, Some((&(e + e_dot * t), &e_dot)))
        };
        let x = Vector::new(0.2, -0.4, 0.3);
        let h = 1e-6;
        let fd = (at(h).position(&x) - at(-h).position(&x)) / (2.0 * h);
        assert!((fd - at(0.0).velocity(&x)).norm() < 1e-8, "{fd}");
        let m = at(0.0);
        assert!((m.material(&m.position(&x)) - x).norm() < 1e-14);
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
