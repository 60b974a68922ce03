//! The strain dynamics of a deformable (12-DOF) DDA block: Shi's constant-strain block (Shi 1993,
//! §2.2–2.4; Shi 2001 for 3D), co-rotational.
//!
//! A material point at X (block frame, undeformed, centroid at the origin) is at
//! x = c + R (I + E) X ([`shared::geometry::strain`]). The unknowns of a deformable block are the six
//! rigid ones (centroid, rotation) and the six constant strains e = (εx, εy, εz, γyz, γzx, γxy)
//! in the block frame. R is carried exactly (as for rigid blocks), so E is a small strain
//! measured in the block's own frame and a spinning block neither grows nor strains.
//!
//! DDA's sub-matrices on the strain unknowns (Shi 1993, Eqs. 2.40–2.60 in 2D; the 3D analogues):
//!
//! - mass M_e = ρ ∫ T_eᵀ T_e dV ([`shared::geometry::strain::inertia`]): ρ V L²/12 on the normal strains
//!   and ρ V L²/24 on the shears of a cube of side L;
//! - stiffness V·D (D the isotropic elasticity, σ = D e): the strain energy ½ V eᵀ D e;
//! - a force f at the material point X loads the strains with T_e(X)ᵀ Rᵀ f
//!   ([`shared::geometry::strain::generalised_force`]); a uniform body force (gravity) gives nothing,
//!   because ∫ X dV = 0 about the centroid.
//!
//! **Neglected coupling.** The full 12×12 mass matrix has an off-diagonal block between the
//! rotation and the strain unknowns, ρ ∫ (θ × X)·(Ė X) dV = ρ Σ_{i<j} A_ij Ė_ij (J_ii − J_jj)
//! in the principal frame of J = ∫ X Xᵀ dV (A the skew matrix of θ): it vanishes for every
//! strain of a block with J ∝ 1 (a cube, a regular polyhedron) and for the normal strains of any
//! block in its principal frame; it is non-zero only for a shear γ_ij of a block with
//! J_ii ≠ J_jj, where it couples the angular acceleration about k with the shear acceleration
//! (a shear oscillation of an elongated block rocks it a little, and vice versa).
//! The translation–strain block is exactly zero (∫ X dV = 0). We keep the mass block-diagonal,
//! rigid 6×6 and strain 6×6, which is what lets the rigid part stay exactly as for rigid blocks.
//! Likewise the rigid inertia is that of the undeformed block (its change with E is O(ε)).

use shared::geometry::strain::{self, Matrix6, Strain};
use shared::math::{Matrix, Real};
use shared::scene::ElasticSpec;

/// The strain state and matrices of one deformable block.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct Elastic {
    pub young_modulus: Real,
    pub poisson_ratio: Real,
    /// Block volume V [m³].
    pub volume: Real,
    /// Elasticity D [Pa] (σ = D e).
    pub elasticity: Matrix6,
    /// Block stiffness V·D [N·m].
    pub stiffness: Matrix6,
    /// Strain mass M_e = ρ ∫ T_eᵀ T_e dV [kg·m²].
    pub mass: Matrix6,
    pub inv_mass: Matrix6,
    /// M_e^(−½), for the mass-normalised stiffness of the stability bound.
    pub inv_sqrt_mass: Matrix6,
    /// Mass-normalised block stiffness M_e^(−½) V D M_e^(−½) [1/s²].
    pub normalised_stiffness: Matrix6,
    /// ω² of the stiffest free elastic mode, λ_max(M_e^(−½) V D M_e^(−½)) [1/s²].
    pub omega2: Real,
    /// Strain e at the current time.
    pub strain: Strain,
    /// Strain rate ė [1/s].
    pub rate: Strain,
    /// Strain at the start of the last step (material displacement of contact points).
    pub prev_strain: Strain,
    /// (I + E)⁻¹ of the current strain (block-frame position of a world point).
    pub stretch_inv: Matrix,
}

impl Elastic {
    /// The strain part of a block of `volume`, `density` and unit-density inertia tensor about
    /// its centroid `unit_inertia` (body frame).
    pub fn new(spec: &ElasticSpec, volume: Real, density: Real, unit_inertia: &Matrix) -> Elastic {
        let elasticity = strain::elasticity(spec.young_modulus, spec.poisson_ratio);
        let stiffness = elasticity * volume;
        let mass = strain::inertia(&strain::second_moment(unit_inertia), density);
        let inv_mass = mass.try_inverse().unwrap_or_else(Matrix6::zeros);
        let inv_sqrt_mass = sym_inv_sqrt(&mass);
        let normalised_stiffness = inv_sqrt_mass * stiffness * inv_sqrt_mass;
        let omega2 = largest_eigenvalue(&normalised_stiffness);
        Elastic {
            young_modulus: spec.young_modulus,
            poisson_ratio: spec.poisson_ratio,
            volume,
            elasticity,
            stiffness,
            mass,
            inv_mass,
            inv_sqrt_mass,
            normalised_stiffness,
            omega2,
            strain: Strain::zeros(),
            rate: Strain::zeros(),
            prev_strain: Strain::zeros(),
            stretch_inv: Matrix::identity(),
        }
    }

    /// I + E of the current strain.
    #[inline]
    pub fn stretch(&self) -> Matrix {
        Matrix::identity() + strain::tensor(&self.strain)
    }

    /// Recomputes the cached (I + E)⁻¹ after the strain changed.
    #[inline]
    pub fn update_stretch(&mut self) {
        self.stretch_inv = self
            .stretch()
            .try_inverse()
            .unwrap_or_else(Matrix::identity);
    }

    /// Stress σ = D e [Pa] (block frame, Shi's order).
    #[inline]
    pub fn stress(&self) -> Strain {
        self.elasticity * self.strain
    }

    /// Generalised elastic force on the strain unknowns, −V D e.
    #[inline]
    pub fn elastic_force(&self) -> Strain {
        -(self.stiffness * self.strain)
    }

    /// Strain energy ½ V eᵀ D e [J].
    #[inline]
    pub fn strain_energy(&self) -> Real {
        0.5 * self.strain.dot(&(self.stiffness * self.strain))
    }

    /// Kinetic energy of the strain rate, ½ ėᵀ M_e ė [J].
    #[inline]
    pub fn kinetic_energy(&self) -> Real {
        0.5 * self.rate.dot(&(self.mass * self.rate))
    }

    /// Von Mises equivalent stress [Pa].
    pub fn von_mises(&self) -> Real {
        let s = self.stress();
        let (a, b, c) = (s[0] - s[1], s[1] - s[2], s[2] - s[0]);
        (0.5 * (a * a + b * b + c * c) + 3.0 * (s[3] * s[3] + s[4] * s[4] + s[5] * s[5])).sqrt()
    }

    pub fn is_finite(&self) -> bool {
        self.strain
            .iter()
            .chain(self.rate.iter())
            .all(|x| x.is_finite())
    }
}

/// A^(−½) of a symmetric positive semi-definite 6×6 matrix (zero on its null space).
pub fn sym_inv_sqrt(a: &Matrix6) -> Matrix6 {
    let eig = a.symmetric_eigen();
    let d = eig
        .eigenvalues
        .map(|l| if l > 0.0 { 1.0 / l.sqrt() } else { 0.0 });
    eig.eigenvectors * Matrix6::from_diagonal(&d) * eig.eigenvectors.transpose()
}

/// Largest eigenvalue of a symmetric 6×6 matrix. The eigenvalues alone: nalgebra's QR
/// iteration then skips accumulating the Givens rotations into eigenvectors, and its
/// eigenvalues are the same bits as `symmetric_eigen`'s (the rotations never feed back).
pub fn largest_eigenvalue(a: &Matrix6) -> Real {
    a.symmetric_eigenvalues().max()
}

/// Angular frequencies ω of the constant-strain modes of a cube of side `l`: (volumetric,
/// deviatoric/shear). From M_e = ρ V L²/12 (normal), ρ V L²/24 (shear) and V·D: the volumetric
/// normal-strain mode (1, 1, 1) has stiffness 3K, so ω² = 36 K/(ρ L²); the deviatoric normal
/// modes (1, −1, 0) have 2μ, ω² = 24 μ/(ρ L²), the same as the shears (μ over ρL²/24).
pub fn cube_frequencies(young: Real, poisson: Real, density: Real, l: Real) -> (Real, Real) {
    let k = young / (3.0 * (1.0 - 2.0 * poisson));
    let mu = young / (2.0 * (1.0 + poisson));
    (
        (36.0 * k / density).sqrt() / l,
        (24.0 * mu / density).sqrt() / l,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cube_modes_match_the_closed_form() {
        let (l, rho) = (0.5, 2000.0);
        let v = l * l * l;
        let spec = ElasticSpec {
            young_modulus: 5e6,
            poisson_ratio: 0.25,
        };
        let el = Elastic::new(&spec, v, rho, &(Matrix::identity() * (v * l * l / 6.0)));
        let (w_vol, w_dev) = cube_frequencies(5e6, 0.25, rho, l);
        // For ν = 0.25, 3K = 2E > 2μ = 0.8E: the volumetric mode is the stiffest.
        assert!((el.omega2 / (w_vol * w_vol) - 1.0).abs() < 1e-12);
        let m = el.inv_sqrt_mass * el.stiffness * el.inv_sqrt_mass;
        let mut ev: Vec<Real> = m.symmetric_eigen().eigenvalues.iter().copied().collect();
        ev.sort_by(Real::total_cmp);
        for w2 in &ev[..5] {
            assert!((w2 / (w_dev * w_dev) - 1.0).abs() < 1e-12, "{ev:?}");
        }
    }

    #[test]
    fn energies_and_stress() {
        let l: Real = 1.0;
        let spec = ElasticSpec {
            young_modulus: 1e6,
            poisson_ratio: 0.3,
        };
        let mut el = Elastic::new(&spec, 1.0, 1000.0, &(Matrix::identity() / 6.0));
        el.strain = Strain::new(1e-3, 0.0, 0.0, 0.0, 0.0, 0.0);
        // Uniaxial strain: σx = (λ + 2μ) ε.
        let lambda = 1e6 * 0.3 / (1.3 * 0.4);
        let mu = 1e6 / 2.6;
        assert!((el.stress()[0] - (lambda + 2.0 * mu) * 1e-3).abs() < 1e-9);
        assert!((el.strain_energy() - 0.5 * (lambda + 2.0 * mu) * 1e-6 * l).abs() < 1e-12);
        el.rate = Strain::new(0.0, 0.0, 0.0, 0.0, 0.0, 2.0);
        assert!((el.kinetic_energy() - 0.5 * 4.0 * 1000.0 / 24.0).abs() < 1e-9);
        el.update_stretch();
        assert!((el.stretch_inv * el.stretch() - Matrix::identity()).norm() < 1e-15);
    }
}
