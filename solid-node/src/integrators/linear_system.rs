//! The global equations of the implicit scheme (paper Eq. 4): a symmetric, positive definite
//! matrix of N×N blocks (one row of blocks per free block, one off-diagonal block per pair of
//! free blocks in contact), solved by conjugate gradients preconditioned with the inverse
//! diagonal blocks.
//!
//! Shi (1993) stores DDA's matrix the same way (6×6 sub-matrices for rigid blocks, 12×12 with
//! strains) and solves it iteratively; the 2M/Δt² term makes the diagonal blocks dominant, so
//! block Jacobi preconditioning converges in a few iterations, and a block without free
//! neighbours is solved exactly in one.
//!
//! The block size is a const generic: N = 6 for a scene of rigid blocks (the fixed-size 6×6
//! arithmetic of before, nothing paid for deformability), N = 12 when a scene has a
//! deformable block (rigid blocks then carry six identity strain rows that solve to zero).

use nalgebra::{SMatrix, SVector};
use shared::math::Real;

/// One N×N block of the matrix and one N-vector of unknowns.
pub type BlockMat<const N: usize> = SMatrix<Real, N, N>;
pub type BlockVec<const N: usize> = SVector<Real, N>;
pub type Mat6 = BlockMat<6>;
pub type Vec6 = BlockVec<6>;

/// A · x = b with A block-sparse, symmetric. Buffers are kept between solves.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct BlockSystem<const N: usize> {
    pub diag: Vec<BlockMat<N>>,
    /// Off-diagonal blocks (i, j, A_ij) with i < j; A_ji = A_ijᵀ.
    pub off: Vec<(u32, u32, BlockMat<N>)>,
    pub rhs: Vec<BlockVec<N>>,
    inv_diag: Vec<BlockMat<N>>,
    r: Vec<BlockVec<N>>,
    z: Vec<BlockVec<N>>,
    p: Vec<BlockVec<N>>,
    ap: Vec<BlockVec<N>>,
}

impl<const N: usize> Default for BlockSystem<N> {
    fn default() -> Self {
        BlockSystem {
            diag: Vec::new(),
            off: Vec::new(),
            rhs: Vec::new(),
            inv_diag: Vec::new(),
            r: Vec::new(),
            z: Vec::new(),
            p: Vec::new(),
            ap: Vec::new(),
        }
    }
}

/// Why a solve failed.
#[derive(Debug, Clone, PartialEq)]
pub enum SolveError {
    /// A diagonal block is not invertible.
    Singular(usize),
    /// No convergence within the iteration limit: the residual reached.
    NoConvergence(Real),
}

impl<const N: usize> BlockSystem<N> {
    /// Empties the system for `n` block rows, keeping capacity.
    pub fn reset(&mut self, n: usize) {
        self.diag.clear();
        self.diag.resize(n, BlockMat::<N>::zeros());
        self.rhs.clear();
        self.rhs.resize(n, BlockVec::<N>::zeros());
        self.off.clear();
    }

    /// Adds `m` to block (i, j) of the matrix, i ≠ j. Consecutive additions to the same
    /// block are merged (contacts arrive grouped by pair).
    pub fn add_off(&mut self, i: usize, j: usize, m: &BlockMat<N>) {
        let (a, b, m) = if i < j {
            (i as u32, j as u32, *m)
        } else {
            (j as u32, i as u32, m.transpose())
        };
        match self.off.last_mut() {
            Some((x, y, acc)) if *x == a && *y == b => *acc += m,
            _ => self.off.push((a, b, m)),
        }
    }

    /// y = A x.
    pub fn apply(&self, x: &[BlockVec<N>], y: &mut [BlockVec<N>]) {
        for ((yi, d), xi) in y.iter_mut().zip(&self.diag).zip(x) {
            *yi = d * xi;
        }
        for (i, j, m) in &self.off {
            let (i, j) = (*i as usize, *j as usize);
            y[i] += m * x[j];
            y[j] += m.tr_mul(&x[i]);
        }
    }

    /// Solves A x = rhs by block-Jacobi preconditioned conjugate gradients, starting from the
    /// given `x`. Returns the number of iterations.
    pub fn solve(
        &mut self,
        x: &mut [BlockVec<N>],
        rel_tol: Real,
        max_iter: usize,
    ) -> Result<usize, SolveError> {
        let n = self.diag.len();
        self.inv_diag.clear();
        for (i, d) in self.diag.iter().enumerate() {
            let inv = d
                .cholesky()
                .map(|c| c.inverse())
                .ok_or(SolveError::Singular(i))?;
            self.inv_diag.push(inv);
        }
        for v in [&mut self.r, &mut self.z, &mut self.p, &mut self.ap] {
            v.clear();
            v.resize(n, BlockVec::<N>::zeros());
        }
        let mut r = std::mem::take(&mut self.r);
        let mut ap = std::mem::take(&mut self.ap);
        self.apply(x, &mut ap);
        for ((ri, bi), ai) in r.iter_mut().zip(&self.rhs).zip(&ap) {
            *ri = bi - ai;
        }
        let b_norm = self
            .rhs
            .iter()
            .map(|v| v.norm_squared())
            .sum::<Real>()
            .sqrt()
            .max(Real::MIN_POSITIVE);
        let mut rz = 0.0;
        for (((zi, pi), di), ri) in self
            .z
            .iter_mut()
            .zip(self.p.iter_mut())
            .zip(&self.inv_diag)
            .zip(&r)
        {
            *zi = di * ri;
            *pi = *zi;
            rz += ri.dot(zi);
        }
        let mut result = Err(SolveError::NoConvergence(Real::INFINITY));
        for it in 0..=max_iter {
            let r_norm = r.iter().map(|v| v.norm_squared()).sum::<Real>().sqrt();
            if r_norm <= rel_tol * b_norm {
                result = Ok(it);
                break;
            }
            if it == max_iter {
                result = Err(SolveError::NoConvergence(r_norm / b_norm));
                break;
            }
            self.apply(&self.p, &mut ap);
            let pap: Real = self.p.iter().zip(&ap).map(|(p, q)| p.dot(q)).sum();
            if pap.is_nan() || pap <= 0.0 {
                result = Err(SolveError::NoConvergence(r_norm / b_norm));
                break;
            }
            let alpha = rz / pap;
            let mut rz_new = 0.0;
            for (((xi, pi), ri), ai) in x.iter_mut().zip(&self.p).zip(r.iter_mut()).zip(&ap) {
                *xi += pi * alpha;
                *ri -= ai * alpha;
            }
            for ((zi, di), ri) in self.z.iter_mut().zip(&self.inv_diag).zip(&r) {
                *zi = di * ri;
                rz_new += ri.dot(zi);
            }
            let beta = rz_new / rz;
            rz = rz_new;
            for (pi, zi) in self.p.iter_mut().zip(&self.z) {
                *pi = zi + *pi * beta;
            }
        }
        self.r = r;
        self.ap = ap;
        result
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A chain of 50 blocks coupled by springs, against a dense solve.
    #[test]
    fn pcg_matches_dense_solution() {
        let n = 50;
        let mut sys = BlockSystem::<6>::default();
        sys.reset(n);
        let mut seed = 7u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for i in 0..n {
            let g = Mat6::from_fn(|_, _| rnd());
            sys.diag[i] = g * g.transpose() + Mat6::identity() * 3.0;
            sys.rhs[i] = Vec6::from_fn(|_, _| rnd());
        }
        for i in 0..n - 1 {
            let g = Vec6::from_fn(|_, _| rnd());
            let k = g * g.transpose();
            sys.diag[i] += k;
            sys.diag[i + 1] += k;
            sys.add_off(i + 1, i, &(-k));
        }
        let mut x = vec![Vec6::zeros(); n];
        let iters = sys.solve(&mut x, 1e-12, 500).unwrap();
        assert!(iters > 1 && iters < 200, "{iters} iterations");
        let mut dense = nalgebra::DMatrix::<f64>::zeros(6 * n, 6 * n);
        let mut b = nalgebra::DVector::<f64>::zeros(6 * n);
        for i in 0..n {
            dense
                .view_mut((6 * i, 6 * i), (6, 6))
                .copy_from(&sys.diag[i]);
            b.rows_mut(6 * i, 6).copy_from(&sys.rhs[i]);
        }
        for (i, j, m) in &sys.off {
            let (i, j) = (*i as usize, *j as usize);
            dense.view_mut((6 * i, 6 * j), (6, 6)).copy_from(m);
            dense
                .view_mut((6 * j, 6 * i), (6, 6))
                .copy_from(&m.transpose());
        }
        let exact = dense.lu().solve(&b).unwrap();
        let err: f64 = (0..n)
            .map(|i| (x[i] - exact.rows(6 * i, 6)).norm_squared())
            .sum::<f64>()
            .sqrt();
        assert!(err < 1e-9 * exact.norm(), "error {err:e}");
    }
}
