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
//! The factors come from Λ itself ([`BlockTridiagonal::factor`]), or from a square root of it, a
//! block-bidiagonal whitened Jacobian J with `Λ = JᵀJ` ([`BlockJacobian::factor`]): a QR
//! factorisation of J, block by block, gives the upper block-bidiagonal R with `RᵀR = Λ`, so that
//! `L_k = R_kkᵀ` and `G_k = R_kk⁻¹ R_{k,k+1}`, without forming Λ. Forming Λ squares J's condition
//! number, and the Schur complements then cancel: a trajectory whose marginal covariances span more
//! than about 1e15 of the noise's scale (a constant-velocity track with process noise 1e-10 over
//! 300 unmeasured epochs) has a Λ that rounding leaves indefinite, while J's factorisation holds it.
//!
//! Two backends run the same recursion: nalgebra's fixed-size matrices, and faer's dense matrices,
//! which the benchmark `smoother_solve` finds faster from [`FAER_FROM_DIMENSION`] on.

use crate::OperatorError;
use crate::error::{all_finite, check_size, with_capacity};
use crate::numerics::check_symmetric;
use faer::linalg::matmul::matmul;
use faer::linalg::solvers::{Llt, Qr};
use faer::linalg::triangular_solve::{
    solve_lower_triangular_in_place, solve_upper_triangular_in_place,
};
use faer::{Accum, Mat, Par, Side};
use nalgebra::{Cholesky, DMatrix, DMatrixView, SMatrix, SVector};

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
    /// [`OperatorError::TooLarge`] when (nD)² is above [`MAX_ELEMENTS`](crate::MAX_ELEMENTS) or
    /// its memory cannot be allocated.
    pub fn to_dense(&self) -> Result<DMatrix<f64>, OperatorError> {
        const ENTRIES: &str = "entries of the dense normal matrix";
        let n = self.blocks() * D;
        // Up to 8 GB: memory the system cannot give is an error, not an abort.
        let mut entries = with_capacity(ENTRIES, n.saturating_mul(n))?;
        entries.resize(n * n, 0.0);
        let mut dense = DMatrix::from_vec(n, n, entries);
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

/// A block-bidiagonal whitened Jacobian J over n epochs of dimension D: rows in one epoch's state
/// (a prior's, a measurement's), and rows in two neighbouring epochs' states (a transition's,
/// `[J₁ J₂]` in x_k and x_{k+1}). Its normal matrix `Λ = JᵀJ` is [`BlockTridiagonal`];
/// [`BlockJacobian::factor`] factors Λ from J by QR (see the module docs), where forming Λ would
/// square J's condition number.
///
/// # Example
/// ```
/// use liebayes_operators::iterated_smoother::{Backend, BlockJacobian};
/// use nalgebra::{Matrix1, Vector1};
///
/// // A walk with unit noises, a prior on x₀ and a reading of x₁: J = [[1, 0], [−1, 1], [0, 1]].
/// let mut jacobian = BlockJacobian::<1>::new(2).unwrap();
/// jacobian.add_rows(0, Matrix1::new(1.0).as_view()).unwrap();
/// jacobian.set_transition(0, Matrix1::new(-1.0), Matrix1::new(1.0)).unwrap();
/// jacobian.add_rows(1, Matrix1::new(1.0).as_view()).unwrap();
/// // Λ = [[2, −1], [−1, 2]]: inverse [[2, 1], [1, 2]] / 3.
/// let factor = jacobian.factor_with(Backend::FixedSize).unwrap();
/// let marginals = factor.marginal_covariances().unwrap();
/// assert!((marginals[0][0] - 2.0 / 3.0).abs() < 1e-15);
/// let x = factor.solve(&[Vector1::new(1.0), Vector1::new(1.0)]).unwrap();
/// assert!((x[1][0] - 1.0).abs() < 1e-15);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct BlockJacobian<const D: usize> {
    /// Per epoch, its own rows (D columns), stacked.
    own: Vec<DMatrix<f64>>,
    /// Per transition k → k + 1, its rows in x_k and in x_{k+1} (zero until set).
    transitions: Vec<(SMatrix<f64, D, D>, SMatrix<f64, D, D>)>,
}

/// What the square-root factorisation names when an epoch's rows leave its state undetermined.
const RANK_DEFICIENT: &str = "block Jacobian (after the rows of the epochs before it, an epoch's \
                              rows do not determine its state: give every state a prior, a \
                              transition or a measurement in each of its directions)";

impl<const D: usize> BlockJacobian<D> {
    /// A Jacobian of n ≥ 1 epochs with no rows yet.
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`] for n = 0, [`OperatorError::TooLarge`] when n D² is above
    /// [`MAX_ELEMENTS`](crate::MAX_ELEMENTS) or the blocks cannot be allocated.
    pub fn new(epochs: usize) -> Result<Self, OperatorError> {
        if epochs == 0 {
            return Err(OperatorError::OutOfRange {
                what: "number of epochs of a block Jacobian",
                value: 0.0,
                range: "at least 1",
            });
        }
        check_size(
            "entries of the block Jacobian",
            epochs.saturating_mul(D * D),
        )?;
        let mut own = with_capacity("epochs of the block Jacobian", epochs)?;
        own.resize(epochs, DMatrix::zeros(0, D));
        let mut transitions = with_capacity("transitions of the block Jacobian", epochs - 1)?;
        transitions.resize(epochs - 1, (SMatrix::zeros(), SMatrix::zeros()));
        Ok(Self { own, transitions })
    }

    /// The number of epochs n.
    pub fn epochs(&self) -> usize {
        self.own.len()
    }

    /// Appends rows in epoch k's state alone (D columns).
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`] for an epoch past the last or rows without D columns,
    /// [`OperatorError::NonFinite`] for a NaN or infinite entry, [`OperatorError::TooLarge`] when
    /// the epoch's rows would pass [`MAX_ELEMENTS`](crate::MAX_ELEMENTS) entries.
    pub fn add_rows(
        &mut self,
        epoch: usize,
        rows: DMatrixView<'_, f64>,
    ) -> Result<(), OperatorError> {
        if rows.ncols() != D {
            return Err(OperatorError::OutOfRange {
                what: "number of columns of block Jacobian rows",
                value: rows.ncols() as f64,
                range: "the state's dimension D",
            });
        }
        all_finite("block Jacobian entry", rows.iter())?;
        let own = self.own_mut(epoch)?;
        let start = own.nrows();
        check_size(
            "entries of an epoch of the block Jacobian",
            start.saturating_add(rows.nrows()).saturating_mul(D),
        )?;
        own.resize_vertically_mut(start + rows.nrows(), 0.0);
        own.rows_mut(start, rows.nrows()).copy_from(&rows);
        Ok(())
    }

    /// Sets the rows of transition k → k + 1: `first` in x_k, `second` in x_{k+1}.
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`] for a transition past the last,
    /// [`OperatorError::NonFinite`] for a NaN or infinite entry.
    pub fn set_transition(
        &mut self,
        k: usize,
        first: SMatrix<f64, D, D>,
        second: SMatrix<f64, D, D>,
    ) -> Result<(), OperatorError> {
        all_finite("block Jacobian entry", first.iter().chain(second.iter()))?;
        let slot = self
            .transitions
            .get_mut(k)
            .ok_or(OperatorError::OutOfRange {
                what: "transition of the block Jacobian",
                value: k as f64,
                range: "below the number of epochs minus one",
            })?;
        *slot = (first, second);
        Ok(())
    }

    /// Epoch k's own rows, or the error naming it.
    fn own_mut(&mut self, epoch: usize) -> Result<&mut DMatrix<f64>, OperatorError> {
        self.own.get_mut(epoch).ok_or(OperatorError::OutOfRange {
            what: "epoch of the block Jacobian",
            value: epoch as f64,
            range: "below its number of epochs",
        })
    }

    /// The normal matrix `JᵀJ` (the reference of the tests; [`Self::factor`] never forms it).
    ///
    /// # Errors
    /// As [`BlockTridiagonal::new`].
    pub fn normal(&self) -> Result<BlockTridiagonal<D>, OperatorError> {
        let mut diagonal: Vec<SMatrix<f64, D, D>> = self
            .own
            .iter()
            .map(|rows| SMatrix::from_fn(|i, j| rows.column(i).dot(&rows.column(j))))
            .collect();
        let mut lower = Vec::with_capacity(self.transitions.len());
        for (k, (first, second)) in self.transitions.iter().enumerate() {
            diagonal[k] += first.tr_mul(first);
            diagonal[k + 1] += second.tr_mul(second);
            lower.push(second.tr_mul(first));
        }
        BlockTridiagonal::new(diagonal, lower)
    }

    /// The factorisation of `JᵀJ` from J, on the backend [`Backend::for_dimension`] picks for D.
    ///
    /// # Errors
    /// As [`Self::factor_with`].
    pub fn factor(&self) -> Result<BlockCholesky<D>, OperatorError> {
        self.factor_with(Backend::for_dimension(D))
    }

    /// The factorisation of `JᵀJ` from J by block QR: epoch by epoch, the rows carried from the
    /// epochs before, the epoch's own rows and its transition's rows, `[T_k 0; O_k 0; J₁ J₂]`, are
    /// reduced by Householder reflections to `[R_kk R_{k,k+1}; 0 T_{k+1}]` (`T_0` empty). O(n D³).
    /// On [`Backend::FixedSize`] each column's pivot row is the one of largest magnitude in it
    /// (Powell and Reid's row pivoting); on [`Backend::Faer`] the rows are sorted by their largest
    /// magnitude first and reduced by faer's blocked QR. Either way the large rows (a transition's
    /// with a tiny process noise) are reduced before the small ones (a reading's), whose
    /// information would otherwise be lost to their rounding.
    ///
    /// # Errors
    /// [`OperatorError::NotPositiveDefinite`] when an epoch's state is left undetermined (JᵀJ is
    /// singular: a diagonal entry of `R_kk` is zero), [`OperatorError::NonFinite`] when one
    /// overflows, [`OperatorError::TooLarge`] when the factors cannot be allocated.
    pub fn factor_with(&self, backend: Backend) -> Result<BlockCholesky<D>, OperatorError> {
        let n = self.epochs();
        let mut diagonal = with_capacity("blocks of the factorisation", n)?;
        let mut upper = with_capacity("blocks of the factorisation", n - 1)?;
        let mut carried = SMatrix::<f64, D, D>::zeros();
        for (k, own) in self.own.iter().enumerate() {
            let transition = self.transitions.get(k);
            let width = if transition.is_some() { 2 * D } else { D };
            let rows = D + own.nrows() + if transition.is_some() { D } else { 0 };
            let mut stacked = DMatrix::zeros(rows, width);
            stacked.view_mut((0, 0), (D, D)).copy_from(&carried);
            stacked.view_mut((D, 0), (own.nrows(), D)).copy_from(own);
            if let Some((first, second)) = transition {
                let at = D + own.nrows();
                stacked.view_mut((at, 0), (D, D)).copy_from(first);
                stacked.view_mut((at, D), (D, D)).copy_from(second);
            }
            // At least `width` rows: D carried and, with a transition, D more.
            let r = match backend {
                Backend::FixedSize => {
                    reduce_to_triangular(&mut stacked);
                    stacked
                }
                Backend::Faer => reduce_sorted_by_faer(&stacked),
            };
            let mut top = r.rows(0, D).into_owned();
            for i in 0..D {
                // Rows of R may change sign (with Q's columns): RᵀR is the same, and L_k = R_kkᵀ
                // needs a positive diagonal.
                if top[(i, i)] < 0.0 {
                    top.row_mut(i).neg_mut();
                }
            }
            let block = SMatrix::<f64, D, D>::from_fn(|i, j| top[(i, j)]);
            all_finite("square-root factor of the normal matrix", top.iter())?;
            if (0..D).any(|i| block[(i, i)] <= 0.0) {
                return Err(OperatorError::NotPositiveDefinite {
                    what: RANK_DEFICIENT,
                });
            }
            diagonal.push(block);
            if transition.is_some() {
                upper.push(SMatrix::<f64, D, D>::from_fn(|i, j| top[(i, D + j)]));
                carried = SMatrix::from_fn(|i, j| r[(D + i, D + j)]);
            }
        }
        Ok(BlockCholesky {
            factors: match backend {
                Backend::FixedSize => Factors::FixedSize(Recursion::from_root(&diagonal, &upper)?),
                Backend::Faer => Factors::Faer(Recursion::from_root(&diagonal, &upper)?),
            },
        })
    }
}

/// Reduces `a` (at least as many rows as columns) to its R factor in place, by Householder
/// reflections with row pivoting (Powell and Reid): before column j is reduced, the row of largest
/// magnitude in it from row j on is swapped to row j. A whitened Jacobian holds rows of very
/// different scales (a transition with process noise 1e-30 weighs 1e15, a reading 1): reduced by a
/// small pivot, the large row's entries in the next columns would be the difference of two numbers
/// of its size, and the small rows' information (all the smoother knows of the state) would be
/// lost to their rounding. The entries below the diagonal are left zero.
fn reduce_to_triangular(a: &mut DMatrix<f64>) {
    let (rows, columns) = a.shape();
    for j in 0..columns.min(rows) {
        let pivot = (j..rows)
            .max_by(|&x, &y| a[(x, j)].abs().total_cmp(&a[(y, j)].abs()))
            .unwrap_or(j);
        a.swap_rows(j, pivot);
        // Column-major: column c from row j is `data[c * rows + j..(c + 1) * rows]`.
        let data = a.as_mut_slice();
        let (before, after) = data.split_at_mut((j + 1) * rows);
        let x = &mut before[j * rows + j..];
        let largest = x[0].abs();
        if largest == 0.0 || !largest.is_finite() {
            // A zero column is reduced already; an infinite one is refused by the caller.
            continue;
        }
        // ‖x‖ scaled by its largest entry (no overflow or underflow in the squares), R_jj = α with
        // the sign opposite to x_j, so that v_j = x_j − α adds magnitudes.
        let norm = largest * x.iter().map(|v| (v / largest).powi(2)).sum::<f64>().sqrt();
        let alpha = if x[0] > 0.0 { -norm } else { norm };
        let head = x[0] - alpha;
        // H = I − 2 v vᵀ / vᵀv with v = (head, x_{j+1}, …) and vᵀv = −2 α head.
        for column in after.chunks_exact_mut(rows) {
            let y = &mut column[j..];
            let dot = head * y[0] + x[1..].iter().zip(&y[1..]).map(|(v, w)| v * w).sum::<f64>();
            let factor = dot / alpha / head;
            y[0] += factor * head;
            for (w, v) in y[1..].iter_mut().zip(&x[1..]) {
                *w += factor * v;
            }
        }
        x[0] = alpha;
        x[1..].fill(0.0);
    }
}

/// The R factor of `a` (at least as many rows as columns) by faer's blocked Householder QR, the rows
/// first sorted by their largest magnitude, largest first (Cox and Higham's row sorting: the large
/// rows are reduced first, as [`reduce_to_triangular`]'s pivoting does column by column).
fn reduce_sorted_by_faer(a: &DMatrix<f64>) -> DMatrix<f64> {
    let (rows, columns) = a.shape();
    let mut order: Vec<(f64, usize)> = (0..rows).map(|i| (a.row(i).amax(), i)).collect();
    order.sort_by(|x, y| y.0.total_cmp(&x.0));
    let sorted = Mat::from_fn(rows, columns, |i, j| a[(order[i].1, j)]);
    let r = Qr::new(sorted.as_ref()).thin_R().to_owned();
    DMatrix::from_fn(
        columns,
        columns,
        |i, j| if i <= j { r[(i, j)] } else { 0.0 },
    )
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
    /// The factor whose lower-triangular L (positive diagonal) is given.
    fn from_lower(l: &SMatrix<f64, D, D>) -> Self::Factor;
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
    fn from_lower(l: &SMatrix<f64, D, D>) -> Self::Factor {
        Cholesky::pack_dirty(*l)
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
    /// The lower-triangular Cholesky factor L.
    type Factor = Mat<f64>;

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
        Llt::new(s.as_ref(), Side::Lower)
            .ok()
            .map(|llt| llt.L().to_owned())
    }
    fn from_lower(l: &SMatrix<f64, D, D>) -> Self::Factor {
        Self::block(l)
    }
    fn solve_transposed(f: &Self::Factor, b: &Self::Block) -> Self::Block {
        let mut x = b.transpose().to_owned();
        solve_in_place(f, &mut x);
        x
    }
    fn solve_vector(f: &Self::Factor, v: &Self::Vector) -> Self::Vector {
        let mut x = v.clone();
        solve_in_place(f, &mut x);
        x
    }
    fn inverse(f: &Self::Factor) -> Self::Block {
        let mut x = Mat::identity(D, D);
        solve_in_place(f, &mut x);
        x
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

/// `x ← (L Lᵀ)⁻¹ x` for a lower-triangular L with a positive diagonal.
fn solve_in_place(l: &Mat<f64>, x: &mut Mat<f64>) {
    solve_lower_triangular_in_place(l.as_ref(), x.as_mut(), Par::Seq);
    solve_upper_triangular_in_place(l.transpose(), x.as_mut(), Par::Seq);
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

    /// From the blocks of R (`RᵀR = Λ`, upper block-bidiagonal, each `R_kk` upper triangular with
    /// a positive diagonal): `L_k = R_kkᵀ`, `G_k = R_kk⁻¹ R_{k,k+1}`.
    fn from_root(
        diagonal: &[SMatrix<f64, D, D>],
        upper: &[SMatrix<f64, D, D>],
    ) -> Result<Self, OperatorError> {
        let mut factors = with_capacity("blocks of the factorisation", diagonal.len())?;
        let mut gains = with_capacity("blocks of the factorisation", upper.len())?;
        for r in diagonal {
            factors.push(B::from_lower(&r.transpose()));
        }
        for (r, coupling) in diagonal.iter().zip(upper) {
            let gain =
                r.solve_upper_triangular(coupling)
                    .ok_or(OperatorError::NotPositiveDefinite {
                        what: RANK_DEFICIENT,
                    })?;
            all_finite("square-root factor of the normal matrix", gain.iter())?;
            gains.push(B::block(&gain));
        }
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
