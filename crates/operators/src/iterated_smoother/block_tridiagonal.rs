//! Symmetric positive definite block-tridiagonal matrices: the normal matrix of a Gauss-Newton
//! step over a trajectory, factored by the block recursion in O(n D³).
//!
//! With diagonal blocks `A_k` and sub-diagonal blocks `B_k = Λ_{k+1,k}` (k = 0..n−1):
//!
//! * factor: `S_0 = A_0`, `S_k = L_k L_kᵀ` (Cholesky), `G_k = S_k⁻¹ B_kᵀ`,
//!   `S_{k+1} = A_{k+1} − B_k G_k`: `Λ = U D Uᵀ` with `D = diag(S_k)` and `G_kᵀ` below the unit
//!   diagonal of U (a block LDLᵀ, the block Thomas algorithm);
//! * solve `Λ x = b`: forward `y_0 = b_0`, `y_{k+1} = b_{k+1} − G_kᵀ y_k`; backward
//!   `x_{n−1} = S_{n−1}⁻¹ y_{n−1}`, `x_k = S_k⁻¹ y_k − G_k x_{k+1}`;
//! * the diagonal blocks of `Λ⁻¹`: `Σ_{n−1} = S_{n−1}⁻¹`, `Σ_k = S_k⁻¹ + G_k Σ_{k+1} G_kᵀ` (the
//!   inverse of `U D Uᵀ` is `U⁻ᵀ D⁻¹ U⁻¹`, and its diagonal blocks obey this backward recursion, the
//!   covariance recursion of the RTS smoother).
//!
//! Two backends run the same recursion: nalgebra's fixed-size matrices, and faer's dense matrices,
//! which the benchmark `smoother_solve` finds faster from [`FAER_FROM_DIMENSION`] on.

use crate::OperatorError;
use crate::error::{all_finite, check_size, with_capacity};
use crate::numerics::check_symmetric;
use faer::linalg::matmul::matmul;
use faer::linalg::solvers::{DenseSolveCore, Llt, Solve};
use faer::{Accum, Mat, Par, Side};
use nalgebra::{Cholesky, DMatrix, SMatrix, SVector};

/// The state dimension from which [`BlockTridiagonal::factor`] runs on faer rather than on
/// nalgebra's fixed-size matrices: the `smoother_solve` benchmark measured nalgebra 2.4 to 5 times
/// faster at D = 6 and faer faster at D = 15, 30 and 60 (see docs/benchmarks.md).
pub const FAER_FROM_DIMENSION: usize = 15;

/// The linear algebra the block recursion runs on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Backend {
    /// nalgebra's fixed-size `SMatrix<f64, D, D>` blocks, on the stack: fastest for small D.
    FixedSize,
    /// faer's dense `Mat<f64>` blocks (cache-blocked, vectorised products and Cholesky): fastest
    /// for large D.
    Faer,
}

impl Backend {
    /// The faster backend for blocks of dimension D: [`Backend::Faer`] from
    /// [`FAER_FROM_DIMENSION`] on, [`Backend::FixedSize`] below.
    pub fn for_dimension(dimension: usize) -> Self {
        if dimension >= FAER_FROM_DIMENSION {
            Backend::Faer
        } else {
            Backend::FixedSize
        }
    }
}

/// What the factorisation names when a block is refused.
const NOT_POSITIVE_DEFINITE: &str = "block-tridiagonal matrix (a Schur complement S_k = A_k − B_k−1 \
                                     S_k−1⁻¹ B_k−1ᵀ is not positive definite: check the noise \
                                     covariances and the Jacobians)";

/// A symmetric block-tridiagonal matrix of n × n blocks of size D × D: the diagonal blocks `A_k`
/// and the sub-diagonal blocks `B_k = Λ_{k+1,k}` (the super-diagonal ones are their transposes).
///
/// # Example
/// ```
/// use liebayes_operators::iterated_smoother::{Backend, BlockTridiagonal};
/// use nalgebra::{Matrix1, Vector1};
///
/// // [[2, −1], [−1, 2]]: inverse [[2, 1], [1, 2]] / 3.
/// let m = BlockTridiagonal::new(vec![Matrix1::new(2.0); 2], vec![Matrix1::new(-1.0)]).unwrap();
/// let factor = m.factor_with(Backend::FixedSize).unwrap();
/// let x = factor.solve(&[Vector1::new(1.0), Vector1::new(1.0)]).unwrap();
/// assert!((x[0][0] - 1.0).abs() < 1e-15 && (x[1][0] - 1.0).abs() < 1e-15);
/// let marginals = factor.marginal_covariances().unwrap();
/// assert!((marginals[0][0] - 2.0 / 3.0).abs() < 1e-15);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct BlockTridiagonal<const D: usize> {
    diagonal: Vec<SMatrix<f64, D, D>>,
    lower: Vec<SMatrix<f64, D, D>>,
}

impl<const D: usize> BlockTridiagonal<D> {
    /// The matrix with diagonal blocks `diagonal` (n ≥ 1 of them) and sub-diagonal blocks `lower`
    /// (n − 1 of them).
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`] when there is no block, the counts do not match, or a
    /// diagonal block is not symmetric (to a relative 1e-12: the factorisation reads one triangle),
    /// [`OperatorError::NonFinite`] for a NaN or infinite entry, [`OperatorError::TooLarge`] when
    /// n D² is above [`MAX_ELEMENTS`](crate::MAX_ELEMENTS).
    pub fn new(
        diagonal: Vec<SMatrix<f64, D, D>>,
        lower: Vec<SMatrix<f64, D, D>>,
    ) -> Result<Self, OperatorError> {
        if diagonal.is_empty() || lower.len() + 1 != diagonal.len() {
            return Err(OperatorError::OutOfRange {
                what: "number of sub-diagonal blocks",
                value: lower.len() as f64,
                range: "one fewer than the diagonal blocks, of which there must be at least one",
            });
        }
        check_size(
            "entries of the block-tridiagonal matrix",
            diagonal.len().saturating_mul(D * D),
        )?;
        for block in diagonal.iter().chain(&lower) {
            all_finite("block-tridiagonal matrix entry", block.iter())?;
        }
        for block in &diagonal {
            check_symmetric("diagonal block of the block-tridiagonal matrix", block)?;
        }
        Ok(Self { diagonal, lower })
    }

    /// The number of diagonal blocks n.
    pub fn blocks(&self) -> usize {
        self.diagonal.len()
    }

    /// The diagonal blocks `A_k`.
    pub fn diagonal(&self) -> &[SMatrix<f64, D, D>] {
        &self.diagonal
    }

    /// The sub-diagonal blocks `B_k = Λ_{k+1,k}`.
    pub fn lower(&self) -> &[SMatrix<f64, D, D>] {
        &self.lower
    }

    /// The matrix as a dense nD × nD nalgebra matrix (the naive alternative, and the reference of
    /// the tests).
    ///
    /// # Errors
    /// [`OperatorError::TooLarge`] when (nD)² is above [`MAX_ELEMENTS`](crate::MAX_ELEMENTS).
    pub fn to_dense(&self) -> Result<DMatrix<f64>, OperatorError> {
        let n = self.blocks() * D;
        check_size("entries of the dense normal matrix", n.saturating_mul(n))?;
        let mut dense = DMatrix::zeros(n, n);
        for (k, a) in self.diagonal.iter().enumerate() {
            dense.fixed_view_mut::<D, D>(k * D, k * D).copy_from(a);
        }
        for (k, b) in self.lower.iter().enumerate() {
            dense
                .fixed_view_mut::<D, D>((k + 1) * D, k * D)
                .copy_from(b);
            dense
                .fixed_view_mut::<D, D>(k * D, (k + 1) * D)
                .copy_from(&b.transpose());
        }
        Ok(dense)
    }

    /// The block factorisation, on the backend [`Backend::for_dimension`] picks for D.
    ///
    /// # Errors
    /// As [`Self::factor_with`].
    pub fn factor(&self) -> Result<BlockCholesky<D>, OperatorError> {
        self.factor_with(Backend::for_dimension(D))
    }

    /// The block factorisation on a given backend.
    ///
    /// # Errors
    /// [`OperatorError::NotPositiveDefinite`] when the matrix is not positive definite (a Schur
    /// complement has no Cholesky factor), [`OperatorError::TooLarge`] when the factors cannot be
    /// allocated.
    pub fn factor_with(&self, backend: Backend) -> Result<BlockCholesky<D>, OperatorError> {
        Ok(BlockCholesky {
            factors: match backend {
                Backend::FixedSize => Factors::FixedSize(Recursion::factor(self)?),
                Backend::Faer => Factors::Faer(Recursion::factor(self)?),
            },
        })
    }
}

/// The factorisation `Λ = U D Uᵀ` of a [`BlockTridiagonal`] matrix (see the module docs): solves
/// and the diagonal blocks of the inverse, each in O(n D³) without forming `Λ⁻¹`.
#[derive(Clone, Debug)]
pub struct BlockCholesky<const D: usize> {
    factors: Factors<D>,
}

/// The recursion's factors on one of the backends.
#[derive(Clone, Debug)]
enum Factors<const D: usize> {
    FixedSize(Recursion<FixedSize, D>),
    Faer(Recursion<Dense, D>),
}

impl<const D: usize> BlockCholesky<D> {
    /// The backend the factors live on.
    pub fn backend(&self) -> Backend {
        match self.factors {
            Factors::FixedSize(_) => Backend::FixedSize,
            Factors::Faer(_) => Backend::Faer,
        }
    }

    /// x with `Λ x = b`, b given block by block.
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`] when b does not have n blocks, [`OperatorError::NonFinite`] for
    /// a NaN or infinite entry of b or an x that overflows (a nearly singular Λ),
    /// [`OperatorError::TooLarge`] when x cannot be allocated.
    pub fn solve(&self, rhs: &[SVector<f64, D>]) -> Result<Vec<SVector<f64, D>>, OperatorError> {
        let blocks = match &self.factors {
            Factors::FixedSize(r) => r.factors.len(),
            Factors::Faer(r) => r.factors.len(),
        };
        if rhs.len() != blocks {
            return Err(OperatorError::OutOfRange {
                what: "number of right-hand-side blocks",
                value: rhs.len() as f64,
                range: "the number of diagonal blocks of the matrix",
            });
        }
        for b in rhs {
            all_finite("right-hand side", b.iter())?;
        }
        let x = match &self.factors {
            Factors::FixedSize(r) => r.solve(rhs)?,
            Factors::Faer(r) => r.solve(rhs)?,
        };
        all_finite(
            "solution of the block-tridiagonal system (the matrix is nearly singular)",
            x.iter().flat_map(|block| block.iter()),
        )?;
        Ok(x)
    }

    /// The diagonal blocks `Σ_k` of `Λ⁻¹` (by the backward recursion, never by inverting Λ).
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] when a block overflows (a nearly singular Λ),
    /// [`OperatorError::TooLarge`] when the result cannot be allocated.
    pub fn marginal_covariances(&self) -> Result<Vec<SMatrix<f64, D, D>>, OperatorError> {
        let marginals = match &self.factors {
            Factors::FixedSize(r) => r.marginals()?,
            Factors::Faer(r) => r.marginals()?,
        };
        all_finite(
            "marginal covariance of the block-tridiagonal inverse (the matrix is nearly singular)",
            marginals.iter().flat_map(|block| block.iter()),
        )?;
        Ok(marginals)
    }
}

/// The block operations of the recursion, on one backend.
trait Blocks<const D: usize> {
    /// A D × D block.
    type Block: Clone + std::fmt::Debug;
    /// A block of D entries of a vector.
    type Vector;
    /// The Cholesky factor of a block.
    type Factor: Clone + std::fmt::Debug;

    fn block(m: &SMatrix<f64, D, D>) -> Self::Block;
    fn vector(v: &SVector<f64, D>) -> Self::Vector;
    fn to_block(b: &Self::Block) -> SMatrix<f64, D, D>;
    fn to_vector(v: &Self::Vector) -> SVector<f64, D>;
    /// The Cholesky factor of a symmetric block, `None` when it is not positive definite.
    fn cholesky(s: Self::Block) -> Option<Self::Factor>;
    /// `S⁻¹ Bᵀ`.
    fn solve_transposed(f: &Self::Factor, b: &Self::Block) -> Self::Block;
    /// `S⁻¹ v`.
    fn solve_vector(f: &Self::Factor, v: &Self::Vector) -> Self::Vector;
    /// `S⁻¹`.
    fn inverse(f: &Self::Factor) -> Self::Block;
    /// `a − b c`.
    fn sub_product(a: &Self::Block, b: &Self::Block, c: &Self::Block) -> Self::Block;
    /// `y − m v` (or `y − mᵀ v` when `transposed`).
    fn sub_product_vector(
        y: &Self::Vector,
        m: &Self::Block,
        transposed: bool,
        v: &Self::Vector,
    ) -> Self::Vector;
    /// `s + m c mᵀ`.
    fn add_congruence(s: &Self::Block, m: &Self::Block, c: &Self::Block) -> Self::Block;
}

/// nalgebra's fixed-size matrices.
#[derive(Clone, Copy, Debug)]
struct FixedSize;

impl<const D: usize> Blocks<D> for FixedSize {
    type Block = SMatrix<f64, D, D>;
    type Vector = SVector<f64, D>;
    type Factor = Cholesky<f64, nalgebra::Const<D>>;

    fn block(m: &SMatrix<f64, D, D>) -> Self::Block {
        *m
    }
    fn vector(v: &SVector<f64, D>) -> Self::Vector {
        *v
    }
    fn to_block(b: &Self::Block) -> SMatrix<f64, D, D> {
        *b
    }
    fn to_vector(v: &Self::Vector) -> SVector<f64, D> {
        *v
    }
    fn cholesky(s: Self::Block) -> Option<Self::Factor> {
        Cholesky::new(s)
    }
    fn solve_transposed(f: &Self::Factor, b: &Self::Block) -> Self::Block {
        f.solve(&b.transpose())
    }
    fn solve_vector(f: &Self::Factor, v: &Self::Vector) -> Self::Vector {
        f.solve(v)
    }
    fn inverse(f: &Self::Factor) -> Self::Block {
        f.inverse()
    }
    fn sub_product(a: &Self::Block, b: &Self::Block, c: &Self::Block) -> Self::Block {
        a - b * c
    }
    fn sub_product_vector(
        y: &Self::Vector,
        m: &Self::Block,
        transposed: bool,
        v: &Self::Vector,
    ) -> Self::Vector {
        if transposed {
            y - m.tr_mul(v)
        } else {
            y - m * v
        }
    }
    fn add_congruence(s: &Self::Block, m: &Self::Block, c: &Self::Block) -> Self::Block {
        s + m * c * m.transpose()
    }
}

/// faer's dense matrices (sequential: the crate is built without faer's rayon feature).
#[derive(Clone, Copy, Debug)]
struct Dense;

impl<const D: usize> Blocks<D> for Dense {
    type Block = Mat<f64>;
    type Vector = Mat<f64>;
    type Factor = Llt<f64>;

    fn block(m: &SMatrix<f64, D, D>) -> Self::Block {
        Mat::from_fn(D, D, |i, j| m[(i, j)])
    }
    fn vector(v: &SVector<f64, D>) -> Self::Vector {
        Mat::from_fn(D, 1, |i, _| v[i])
    }
    fn to_block(b: &Self::Block) -> SMatrix<f64, D, D> {
        SMatrix::from_fn(|i, j| b[(i, j)])
    }
    fn to_vector(v: &Self::Vector) -> SVector<f64, D> {
        SVector::from_fn(|i, _| v[(i, 0)])
    }
    fn cholesky(s: Self::Block) -> Option<Self::Factor> {
        Llt::new(s.as_ref(), Side::Lower).ok()
    }
    fn solve_transposed(f: &Self::Factor, b: &Self::Block) -> Self::Block {
        let mut x = b.transpose().to_owned();
        f.solve_in_place(x.as_mut());
        x
    }
    fn solve_vector(f: &Self::Factor, v: &Self::Vector) -> Self::Vector {
        let mut x = v.clone();
        f.solve_in_place(x.as_mut());
        x
    }
    fn inverse(f: &Self::Factor) -> Self::Block {
        f.inverse()
    }
    fn sub_product(a: &Self::Block, b: &Self::Block, c: &Self::Block) -> Self::Block {
        let mut out = a.clone();
        matmul(out.as_mut(), Accum::Add, b, c, -1.0, Par::Seq);
        out
    }
    fn sub_product_vector(
        y: &Self::Vector,
        m: &Self::Block,
        transposed: bool,
        v: &Self::Vector,
    ) -> Self::Vector {
        let mut out = y.clone();
        if transposed {
            matmul(out.as_mut(), Accum::Add, m.transpose(), v, -1.0, Par::Seq);
        } else {
            matmul(out.as_mut(), Accum::Add, m, v, -1.0, Par::Seq);
        }
        out
    }
    fn add_congruence(s: &Self::Block, m: &Self::Block, c: &Self::Block) -> Self::Block {
        let mut mc = Mat::zeros(D, D);
        matmul(mc.as_mut(), Accum::Replace, m, c, 1.0, Par::Seq);
        let mut out = s.clone();
        matmul(out.as_mut(), Accum::Add, &mc, m.transpose(), 1.0, Par::Seq);
        out
    }
}

/// The factors `L_k` of the Schur complements and the gains `G_k = S_k⁻¹ B_kᵀ`.
#[derive(Clone, Debug)]
struct Recursion<B: Blocks<D>, const D: usize> {
    factors: Vec<B::Factor>,
    gains: Vec<B::Block>,
}

impl<B: Blocks<D>, const D: usize> Recursion<B, D> {
    fn factor(m: &BlockTridiagonal<D>) -> Result<Self, OperatorError> {
        let n = m.blocks();
        let mut factors = with_capacity("blocks of the factorisation", n)?;
        let mut gains = with_capacity("blocks of the factorisation", n - 1)?;
        let cholesky = |s| {
            B::cholesky(s).ok_or(OperatorError::NotPositiveDefinite {
                what: NOT_POSITIVE_DEFINITE,
            })
        };
        let mut factor = cholesky(B::block(&m.diagonal[0]))?;
        for (lower, diagonal) in m.lower.iter().zip(&m.diagonal[1..]) {
            let lower = B::block(lower);
            let gain = B::solve_transposed(&factor, &lower);
            let schur = B::sub_product(&B::block(diagonal), &lower, &gain);
            factors.push(std::mem::replace(&mut factor, cholesky(schur)?));
            gains.push(gain);
        }
        factors.push(factor);
        Ok(Self { factors, gains })
    }

    fn solve(&self, rhs: &[SVector<f64, D>]) -> Result<Vec<SVector<f64, D>>, OperatorError> {
        let n = self.factors.len();
        let mut forward: Vec<B::Vector> = with_capacity("blocks of the solution", n)?;
        forward.push(B::vector(&rhs[0]));
        for (b, gain) in rhs[1..].iter().zip(&self.gains) {
            let previous = forward.last().expect("one block pushed before");
            let next = B::sub_product_vector(&B::vector(b), gain, true, previous);
            forward.push(next);
        }
        let mut x = with_capacity("blocks of the solution", n)?;
        let mut next = B::solve_vector(&self.factors[n - 1], &forward[n - 1]);
        for k in (0..n - 1).rev() {
            let current = B::sub_product_vector(
                &B::solve_vector(&self.factors[k], &forward[k]),
                &self.gains[k],
                false,
                &next,
            );
            x.push(B::to_vector(&next));
            next = current;
        }
        x.push(B::to_vector(&next));
        x.reverse();
        Ok(x)
    }

    fn marginals(&self) -> Result<Vec<SMatrix<f64, D, D>>, OperatorError> {
        let n = self.factors.len();
        let mut marginals = with_capacity("marginal covariances", n)?;
        let mut next = B::inverse(&self.factors[n - 1]);
        for k in (0..n - 1).rev() {
            let current = B::add_congruence(&B::inverse(&self.factors[k]), &self.gains[k], &next);
            marginals.push(B::to_block(&next));
            next = current;
        }
        marginals.push(B::to_block(&next));
        marginals.reverse();
        Ok(marginals)
    }
}
