//! The grid filter on the circle: a density over an angle held at n equally spaced cells, optionally
//! with a conditional density of other states in each cell (a bank of filters, Rao-Blackwellized over
//! the angle).
//!
//! Cell j sits at `θⱼ = 2πj/n` and holds a log weight `ln wⱼ` (the posterior mass of the cell,
//! normalised so that `Σ wⱼ = 1`) and a payload `Xⱼ`, the density of the other states given `θ = θⱼ`:
//!
//! * **condition** with [`Given`]: each payload is conditioned with the model of its cell's rotation,
//!   returning `p(z | θⱼ, past)`; `ln wⱼ += ln p(z | θⱼ, past)`; the log evidence is
//!   `ln p(z | past) = ln Σⱼ wⱼ p(z | θⱼ, past)` (the trapezoid rule over the circle, exponentially
//!   accurate for smooth periodic integrands while the grid resolves the posterior, and a point-mass
//!   approximation once the posterior is narrower than the spacing 2π/n);
//! * **condition** with [`Reweight`]: a likelihood of the angle alone, `ln wⱼ += ln p(z | θⱼ)`, the
//!   payloads unchanged;
//! * **propagate** with [`Given`]: each payload through its cell's process (the angle itself
//!   constant), or with [`Diffusion`], for a payload-free grid, the angle diffused by a circular
//!   convolution with a kernel.
//!
//! Every step is all or nothing and allocates nothing through the in-place methods (the first
//! diffusion allocates its workspace, kept for the next). Costs n payload steps per step. The
//! reference for anything angular: with enough cells it is exact wherever the payload steps are.

use crate::error::{reserve, with_capacity};
use crate::numerics::{LogWeights, Passes, binary_split, scale_by_power_of_two};
use crate::particle::{Given, LabelModel, Likelihood, Reweight};
use crate::traits::{condition_clone, propagate_clone};
use crate::{Condition, Conditioned, Evidence, OperatorError, Propagate};
use liebayes_manifolds::So2;
use nalgebra::Vector2;
use std::f64::consts::PI;

/// A density over an angle at n equally spaced cells, with a payload per cell.
#[derive(Clone, Debug)]
pub struct CircularGrid<X> {
    /// The normalised cell masses, with the buffer a Bayes step fills.
    weights: LogWeights,
    cells: Vec<X>,
    /// The stepped payloads, swapped with `cells` once a step has succeeded.
    spare: Vec<X>,
    /// The diffusion's kernel values and linear weights (2n values), kept between steps.
    workspace: Vec<f64>,
}

/// What a grid names when its size is refused.
const CELLS: &str = "number of grid cells";

/// `θⱼ = 2πj/n`.
fn cell_angle(j: usize, n: usize) -> f64 {
    2.0 * PI * j as f64 / n as f64
}

/// The rotation by `θⱼ`.
fn rotation_of(j: usize, n: usize) -> So2<f64> {
    So2::from_angle_unchecked(cell_angle(j, n))
}

impl<X: Clone> CircularGrid<X> {
    /// n cells with the uniform angle prior and the same payload in each.
    ///
    /// # Errors
    /// As [`from_log_density`](Self::from_log_density).
    pub fn uniform(n: usize, payload: X) -> Result<Self, OperatorError> {
        Self::from_log_density(n, |_| 0.0, |_| payload.clone())
    }
}

impl<X> CircularGrid<X> {
    /// n cells weighted by an (unnormalised) log density of the angle, cell j carrying `payload(θⱼ)`.
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`] for n = 0, [`OperatorError::TooLarge`] for n above
    /// [`MAX_ELEMENTS`](crate::MAX_ELEMENTS) or when the cells cannot be allocated (checked before
    /// any payload is built), [`OperatorError::NonFinite`] when the log density is NaN or +∞
    /// somewhere, or −∞ everywhere.
    pub fn from_log_density(
        n: usize,
        log_density: impl Fn(f64) -> f64,
        payload: impl Fn(f64) -> X,
    ) -> Result<Self, OperatorError> {
        if n == 0 {
            return Err(OperatorError::OutOfRange {
                what: "number of grid cells",
                value: 0.0,
                range: "at least 1",
            });
        }
        let mut weights = LogWeights::uniform(CELLS, n)?;
        let mut cells = with_capacity(CELLS, n)?;
        let spare = with_capacity(CELLS, n)?;
        let pending = weights.pending();
        pending.extend((0..n).map(|j| log_density(cell_angle(j, n))));
        weights.replace_with_pending("grid prior log density")?;
        cells.extend((0..n).map(|j| payload(cell_angle(j, n))));
        Ok(Self {
            weights,
            cells,
            spare,
            workspace: Vec::new(),
        })
    }

    /// n cells with the given (unnormalised) log weights `ln wⱼ` and payloads, cell j at angle
    /// `2πj/n`: a saved grid read back, or a prior computed elsewhere. The weights are normalised
    /// here without leaving the log domain (−∞ is a zero weight).
    ///
    /// # Errors
    /// [`OperatorError::OutOfRange`] for no cells or a number of weights different from the number
    /// of cells, [`OperatorError::TooLarge`] for more than [`MAX_ELEMENTS`](crate::MAX_ELEMENTS)
    /// cells or when the grid's buffers cannot be allocated, [`OperatorError::NonFinite`] for a NaN
    /// or +∞ log weight, or −∞ everywhere.
    pub fn from_log_weights(log_weights: &[f64], cells: Vec<X>) -> Result<Self, OperatorError> {
        let n = cells.len();
        if n == 0 || log_weights.len() != n {
            return Err(OperatorError::OutOfRange {
                what: "number of grid log weights",
                value: log_weights.len() as f64,
                range: "equal to the number of cells, at least 1",
            });
        }
        let mut weights = LogWeights::uniform(CELLS, n)?;
        let spare = with_capacity(CELLS, n)?;
        let pending = weights.pending();
        pending.extend_from_slice(log_weights);
        weights.replace_with_pending("grid log weight")?;
        Ok(Self {
            weights,
            cells,
            spare,
            workspace: Vec::new(),
        })
    }

    /// The number of cells n.
    pub fn len(&self) -> usize {
        self.cells.len()
    }

    /// Always false: a grid has at least one cell.
    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }

    /// The angle of cell j, `2πj/n`.
    pub fn angle(&self, j: usize) -> f64 {
        cell_angle(j, self.len())
    }

    /// The rotation of cell j, by the angle `2πj/n`: what [`Given`] and [`Reweight`] give their
    /// models.
    pub fn rotation(&self, j: usize) -> So2<f64> {
        rotation_of(j, self.len())
    }

    /// The normalised log weights `ln wⱼ` (posterior cell masses).
    pub fn log_weights(&self) -> &[f64] {
        self.weights.values()
    }

    /// The payloads, `p(x | θⱼ)`.
    pub fn cells(&self) -> &[X] {
        &self.cells
    }

    /// `Σⱼ wⱼ f(θⱼ, Xⱼ)`.
    pub fn expectation<T>(&self, f: impl Fn(f64, &X) -> T) -> T
    where
        T: std::ops::Mul<f64, Output = T> + std::iter::Sum,
    {
        let n = self.len();
        self.log_weights()
            .iter()
            .zip(&self.cells)
            .enumerate()
            .map(|(j, (l, x))| f(cell_angle(j, n), x) * l.exp())
            .sum()
    }

    /// The first trigonometric moment `E (cos θ, sin θ)`: its direction is the circular mean, its
    /// length the mean resultant length ρ.
    pub fn first_moment(&self) -> Vector2<f64> {
        self.expectation(|t, _| {
            let (s, c) = t.sin_cos();
            Vector2::new(c, s)
        })
    }
}

/// What a failed Bayes step of a grid names.
const CELL_LIKELIHOOD: &str = "grid cell log-likelihood";

impl<X, F> Propagate<Given<F>> for CircularGrid<X>
where
    F: LabelModel<So2<f64>>,
    X: Propagate<F::Model> + Clone,
{
    type Input = X::Input;

    /// A clone of the grid, propagated in place.
    fn propagate(&self, model: &Given<F>, input: &X::Input) -> Result<Self, OperatorError> {
        propagate_clone(self, model, input)
    }

    /// Each payload through the process `F(rotation(j))` of its cell, into the spare buffer; the
    /// angle itself is constant, so the weights are unchanged.
    ///
    /// # Errors
    /// The first error of `F` or of a payload's step; the grid is then unchanged.
    fn propagate_in_place(
        &mut self,
        model: &Given<F>,
        input: &X::Input,
    ) -> Result<(), OperatorError> {
        let n = self.len();
        self.spare.clear();
        for (j, x) in self.cells.iter().enumerate() {
            let process = model.0.at(&rotation_of(j, n))?;
            self.spare.push(x.propagate(&process, input)?);
        }
        std::mem::swap(&mut self.cells, &mut self.spare);
        Ok(())
    }
}

impl<X, F> Condition<Given<F>> for CircularGrid<X>
where
    F: LabelModel<So2<f64>>,
    X: Condition<F::Model> + Clone,
{
    type Measurement = X::Measurement;
    type Report = ();

    /// A clone of the grid, conditioned in place.
    fn condition(
        &self,
        model: &Given<F>,
        z: &X::Measurement,
    ) -> Result<Conditioned<Self>, OperatorError> {
        condition_clone::<Self, Given<F>>(self, model, z)
    }

    /// The Rao-Blackwellized grid's Bayes step: each payload conditioned with the model
    /// `F(rotation(j))` of its cell, `ln wⱼ += ln p(z | θⱼ, past)` (that conditioning's log
    /// evidence), normalised; returns `ln p(z | past) = ln Σⱼ wⱼ p(z | θⱼ, past)`. The payloads'
    /// reports are not kept.
    ///
    /// # Errors
    /// The first error of `F` or of a payload's conditioning, [`OperatorError::NonFinite`] for a
    /// NaN or +∞ log evidence, when every cell has likelihood zero or when the log evidence is
    /// below −f64::MAX; the grid is then unchanged.
    fn condition_in_place(
        &mut self,
        model: &Given<F>,
        z: &X::Measurement,
    ) -> Result<Evidence, OperatorError> {
        let n = self.len();
        self.spare.clear();
        let pending = self.weights.pending();
        pending.clear();
        for (j, x) in self.cells.iter().enumerate() {
            let step = x.condition(&model.0.at(&rotation_of(j, n))?, z)?;
            self.spare.push(step.posterior);
            pending.push(step.log_evidence);
        }
        let log_evidence = self.weights.add_pending(CELL_LIKELIHOOD, Passes::Serial)?;
        std::mem::swap(&mut self.cells, &mut self.spare);
        Ok(Evidence {
            log_evidence,
            report: (),
        })
    }
}

impl<X, L> Condition<Reweight<L>> for CircularGrid<X>
where
    X: Clone,
    L: Likelihood<So2<f64>>,
{
    type Measurement = L::Measurement;
    type Report = ();

    /// A clone of the grid, conditioned in place.
    fn condition(
        &self,
        model: &Reweight<L>,
        z: &L::Measurement,
    ) -> Result<Conditioned<Self>, OperatorError> {
        condition_clone::<Self, Reweight<L>>(self, model, z)
    }

    /// Bayes with a likelihood of the angle alone: `ln wⱼ += ln p(z | θⱼ)` with the cell's
    /// rotation, normalised, the payloads unchanged; returns `ln p(z) = ln Σⱼ wⱼ p(z | θⱼ)`.
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] for a NaN or +∞ log-likelihood, when every cell has likelihood
    /// zero or when the log evidence is below −f64::MAX; the grid is then unchanged.
    fn condition_in_place(
        &mut self,
        model: &Reweight<L>,
        z: &L::Measurement,
    ) -> Result<Evidence, OperatorError> {
        let n = self.len();
        let pending = self.weights.pending();
        pending.clear();
        pending.extend((0..n).map(|j| model.0.log_likelihood(&rotation_of(j, n), z)));
        Ok(Evidence {
            log_evidence: self.weights.add_pending(CELL_LIKELIHOOD, Passes::Serial)?,
            report: (),
        })
    }
}

/// The angle diffused, `θ′ = θ + w`, w with the density `k(w)` on the circle (a von Mises, a wrapped
/// normal …), the process model of a payload-free [`CircularGrid`]. The kernel is evaluated at the
/// grid's n increments, the rotations by `2πk/n`, and need not be normalised: any finite,
/// non-negative values that are not all zero. The step is a direct circular convolution, O(n²)
/// (which keeps the relative accuracy of tiny weights an FFT would lose): grids of at most
/// [`MAX_DIFFUSION_CELLS`] cells.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Diffusion<K>(pub K);

/// The most cells a [`Diffusion`] step takes: 2¹⁶, about 4e9 products a step (seconds), the bound
/// on its O(n²) work.
pub const MAX_DIFFUSION_CELLS: usize = 1 << 16;

/// Below this, a diffused weight's plain sum of products may hold products rounded in the subnormal
/// range (each below 2.2e-308, at most 2¹⁶ of them: a relative error under 1e-22 above it), or
/// none at all where every product underflowed: the cell is summed in logarithms instead.
const PLAIN_SUM: f64 = 1e-280;

/// `ln Σⱼ exp(logsⱼ) k(θᵢ − θⱼ)` by log-sum-exp: a diffused cell whose products are too small for
/// the plain sum (the identity kernel keeps a weight of e⁻⁸⁰⁰ against 1 this way). O(n), with a
/// logarithm and an exponential a term.
fn log_convolution(i: usize, kernel: &[f64], logs: &[f64]) -> f64 {
    let n = kernel.len();
    let term = |j: usize| logs[j] + kernel[if j <= i { i - j } else { i + n - j }].ln();
    let largest = (0..n).map(term).fold(f64::NEG_INFINITY, f64::max);
    if largest == f64::NEG_INFINITY {
        return largest;
    }
    largest + (0..n).map(|j| (term(j) - largest).exp()).sum::<f64>().ln()
}

impl<K> Propagate<Diffusion<K>> for CircularGrid<()>
where
    K: Fn(&So2<f64>) -> f64,
{
    type Input = ();

    /// A clone of the grid, propagated in place.
    fn propagate(&self, model: &Diffusion<K>, input: &()) -> Result<Self, OperatorError> {
        propagate_clone(self, model, input)
    }

    /// Chapman-Kolmogorov for `θ′ = θ + w`: the circular convolution
    /// `w′ᵢ = Σⱼ wⱼ k(θᵢ − θⱼ) / Σⱼ k(θⱼ)`. O(n²); the kernel's values are computed once per step,
    /// into a workspace allocated at the first diffusion and kept. Any kernel values from subnormal
    /// to f64::MAX are exact to rounding (the kernel is scaled by a power of two), and a weight far
    /// below the largest (down to the smallest positive double, not only to e⁻⁷⁴⁵) keeps its value:
    /// a cell whose products are that small is summed in logarithms.
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] when the kernel is negative, NaN or infinite somewhere, or zero
    /// everywhere; [`OperatorError::TooLarge`] for a grid of more than [`MAX_DIFFUSION_CELLS`]
    /// cells or when its workspace cannot be allocated (first step). The grid is then unchanged.
    fn propagate_in_place(&mut self, model: &Diffusion<K>, (): &()) -> Result<(), OperatorError> {
        let n = self.len();
        if n > MAX_DIFFUSION_CELLS {
            return Err(OperatorError::TooLarge {
                what: "cells of a grid diffused by a direct O(n^2) convolution",
                value: n,
                max: MAX_DIFFUSION_CELLS,
            });
        }
        self.workspace.clear();
        // n ≤ MAX_DIFFUSION_CELLS, so 3n does not overflow.
        reserve(
            &mut self.workspace,
            "diffusion workspace (three times the cells)",
            3 * n,
        )?;
        self.workspace
            .extend((0..n).map(|j| (model.0)(&rotation_of(j, n))));
        let (mut largest, mut invalid) = (0.0_f64, None);
        for &v in &self.workspace {
            if !(v.is_finite() && v >= 0.0) {
                invalid = invalid.or(Some(v));
            }
            largest = largest.max(v);
        }
        if invalid.is_some() || largest == 0.0 {
            return Err(OperatorError::NonFinite {
                what: "diffusion kernel (it must be finite, non-negative and not zero everywhere)",
                value: invalid.unwrap_or(largest),
            });
        }
        // The kernel scaled exactly by a power of two to a largest value in [½, 1), and the weights
        // by their largest: the products and sums neither overflow nor round in the subnormal
        // range, and a weight far below the largest keeps its value. The common factors go with
        // the normalisation.
        let (_, exponent) = binary_split(largest);
        for v in &mut self.workspace {
            *v = scale_by_power_of_two(*v, -exponent);
        }
        let heaviest = self
            .weights
            .values()
            .iter()
            .copied()
            .fold(f64::NEG_INFINITY, f64::max);
        self.workspace
            .extend(self.weights.values().iter().map(|l| l - heaviest));
        self.workspace.extend_from_within(n..2 * n);
        for l in &mut self.workspace[2 * n..] {
            *l = l.exp();
        }
        let (k, rest) = self.workspace.split_at(n);
        let (logs, w) = rest.split_at(n);
        let pending = self.weights.pending();
        pending.clear();
        // k(θᵢ − θⱼ) = k[i − j] for j ≤ i and k[i − j + n] after: two runs, no index arithmetic.
        pending.extend((0..n).map(|i| {
            let before: f64 = w[..=i]
                .iter()
                .zip(k[..=i].iter().rev())
                .map(|(w, k)| w * k)
                .sum();
            let after: f64 = w[i + 1..]
                .iter()
                .zip(k[i + 1..].iter().rev())
                .map(|(w, k)| w * k)
                .sum();
            let sum = before + after;
            if sum >= PLAIN_SUM {
                sum.ln()
            } else {
                log_convolution(i, k, logs)
            }
        }));
        self.weights.replace_with_pending("diffused grid weight")
    }
}
