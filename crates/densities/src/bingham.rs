//! [`Bingham`]: the Bingham distribution on unit quaternions (S³ = SU(2)).

use crate::bingham_normalizer::log_normalizer_and_moments;
use crate::eigen::bounded_eigen;
use crate::error::{DensityError, finite};
use crate::traits::{
    Density, Entropy, KlDivergence, Product, Rotate, distribution_through_density,
};
use liebayes_manifolds::{LieGroup, Su2};
use nalgebra::{Matrix3, Matrix4, Quaternion, SymmetricEigen, Vector3, Vector4};
use rand::Rng;
use rand_distr::StandardNormal;

/// Accepted asymmetry of a parameter matrix and deviation of an orientation from orthogonality.
const TOLERANCE: f64 = 1e-10;

/// Largest accepted magnitude of an eigenvalue, so that parameter matrices `V diag(z) Vᵀ` and their sums
/// stay finite.
const MAX_EIGENVALUE: f64 = 1e300;

/// Proposals a draw may take before it gives up waiting for an acceptance. The acceptance rate of the
/// envelope is at least 0.43 over the whole accepted range (measured; see `docs/densities/bingham.md`),
/// so 200 proposals all rejected has probability below 1e-48.
const MAX_PROPOSALS: usize = 200;

/// The eigenvectors and eigenvalues of the symmetric part of `m`, the eigenvalues descending.
///
/// # Errors
/// As [`finite_eigen`].
fn sorted_eigen(
    what: &'static str,
    m: &Matrix4<f64>,
) -> Result<(Matrix4<f64>, Vector4<f64>), DensityError> {
    // Halves first: M + Mᵀ overflows for entries past f64::MAX / 2.
    let eigen = finite_eigen(what, m * 0.5 + m.transpose() * 0.5)?;
    let mut order = [0usize, 1, 2, 3];
    order.sort_by(|&i, &j| eigen.eigenvalues[j].total_cmp(&eigen.eigenvalues[i]));
    Ok((
        Matrix4::from_fn(|r, c| eigen.eigenvectors[(r, order[c])]),
        Vector4::from_fn(|k, _| eigen.eigenvalues[order[k]]),
    ))
}

/// The symmetric eigendecomposition ([`bounded_eigen`]), refused where it has not converged or is
/// not finite.
fn finite_eigen(
    what: &'static str,
    m: Matrix4<f64>,
) -> Result<SymmetricEigen<f64, nalgebra::U4>, DensityError> {
    bounded_eigen(m).ok_or_else(|| DensityError::OutOfRange {
        what,
        value: m.amax(),
        range: "symmetric matrices whose eigendecomposition is finite in f64 (entries within a \
                range of about 1e300 of each other)",
    })
}

/// Checks that the eigenvalue spread `max z − min z` is at most [`Bingham::MAX_SPREAD`] and that every
/// eigenvalue is within ±1e300.
pub(crate) fn check_spread(z: &[f64; 4]) -> Result<(), DensityError> {
    let max = z.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let min = z.iter().copied().fold(f64::INFINITY, f64::min);
    if max.abs().max(min.abs()) > MAX_EIGENVALUE {
        return Err(DensityError::OutOfRange {
            what: "Bingham eigenvalue",
            value: if max.abs() > min.abs() { max } else { min },
            range: "[-1e300, 1e300]",
        });
    }
    let spread = max - min;
    if spread > Bingham::MAX_SPREAD {
        return Err(DensityError::OutOfRange {
            what: "Bingham eigenvalue spread max z - min z",
            value: spread,
            range: "[0, 1e12]; beyond it (angular spreads below 0.3 arcseconds) use a ManifoldGaussian",
        });
    }
    Ok(())
}

/// The Bingham distribution on the unit quaternions:
///
/// `p(q) = exp(qᵀ M q) / K(M)`, M a symmetric 4×4 matrix, q = (w, x, y, z) scalar first,
///
/// with respect to the **uniform probability measure on S³** (equivalently the normalised Haar measure of
/// SU(2); the raw surface-measure normaliser is larger by |S³| = 2π²). `p(q) = p(−q)`, so its push-forward
/// to SO(3) is a density on rotations (with respect to the normalised Haar measure of SO(3), the same
/// values).
///
/// Stored in eigen form `M = V diag(z) Vᵀ` with z sorted descending (column 0 of V is the mode). Only
/// differences of eigenvalues matter (qᵀq = 1), and the normaliser is computed once at construction,
/// with its gradient, the second moments `E[(vₖ · q)²] = ∂ ln K / ∂zₖ`. Normaliser: a one-dimensional
/// Bessel integral by tanh-sinh quadrature, measured within 5e-16 (ln K) and 3e-15 (moments,
/// relative) of 30-digit reference values for eigenvalue spreads from 0 to
/// [`MAX_SPREAD`](Self::MAX_SPREAD) = 1e12 (see `docs/densities/bingham.md`).
#[derive(Clone, Debug, PartialEq)]
pub struct Bingham {
    orientation: Matrix4<f64>,
    eigenvalues: Vector4<f64>,
    /// `ln K − z₀`: the normaliser without the largest eigenvalue, which only shifts it.
    log_normalizer_minus_max: f64,
    moments: Vector4<f64>,
    envelope: Envelope,
}

/// The angular central Gaussian envelope of the sampler, fixed by the eigenvalues.
#[derive(Clone, Debug, PartialEq)]
struct Envelope {
    /// `aₖ = z₀ − zₖ ≥ 0`.
    a: Vector4<f64>,
    /// `ωₖ = 1 + 2aₖ/b`.
    omega: Vector4<f64>,
    /// `ln M = −(4 − b)/2 + 2 ln(4/b)`, the log of the bound of density over envelope.
    log_bound: f64,
}

impl Envelope {
    /// b solves `Σ 1/(b + 2aₖ) = 1`: the left side decreases in b, is 4/b at a = 0, and passes 1 in
    /// (0, 4]; bisection to full precision.
    fn new(eigenvalues: &Vector4<f64>) -> Self {
        let a = eigenvalues.map(|z| eigenvalues[0] - z);
        let (mut lo, mut hi) = (1e-300, 4.0);
        for _ in 0..200 {
            let b = 0.5 * (lo + hi);
            if a.iter().map(|ak| 1.0 / (b + 2.0 * ak)).sum::<f64>() > 1.0 {
                lo = b;
            } else {
                hi = b;
            }
            if hi - lo <= 1e-15 * hi {
                break;
            }
        }
        let b = 0.5 * (lo + hi);
        Self {
            a,
            omega: a.map(|ak| 1.0 + 2.0 * ak / b),
            log_bound: -(4.0 - b) / 2.0 + 2.0 * (4.0 / b).ln(),
        }
    }
}

impl Bingham {
    /// The largest accepted eigenvalue spread `z_max − z_min`: the range over which the normaliser and
    /// its gradient are verified to 1e-14 against an independent computation
    /// (`docs/densities/bingham.md`). It corresponds to angular standard deviations down to about
    /// 1/√(2·10¹²) rad ≈ 0.15 arcseconds; tighter distributions are `ManifoldGaussian`s to within
    /// 1e-12.
    pub const MAX_SPREAD: f64 = 1e12;

    /// The Bingham distribution `V diag(z) Vᵀ` from an orthogonal `orientation` V (columns are the
    /// eigenvectors, in quaternion coordinates, the first of the largest eigenvalue being the mode)
    /// and the eigenvalues (concentrations) z, in any order: they are sorted descending, the columns
    /// with them. Only differences of eigenvalues matter.
    ///
    /// # Errors
    /// [`DensityError::NonFinite`], or [`DensityError::OutOfRange`] when V is not orthogonal (to
    /// 1e-10), an eigenvalue lies beyond ±1e300 or their spread beyond [`Self::MAX_SPREAD`].
    ///
    /// # Example
    /// ```
    /// use liebayes_densities::{Bingham, Density};
    /// use liebayes_manifolds::Su2;
    /// use nalgebra::{Matrix4, Vector4};
    /// let p = Bingham::new(Matrix4::identity(), Vector4::new(0.0, -5.0, -5.0, -20.0)).unwrap();
    /// // The mode is the first eigenvector, and q and −q have the same density.
    /// let mode = p.mode().unwrap();
    /// assert_eq!(mode.to_quaternion_wxyz(), [1.0, 0.0, 0.0, 0.0]);
    /// assert_eq!(p.log_pdf(&mode), p.log_pdf(&mode.antipode()));
    /// // The second moments along the eigenvectors sum to 1.
    /// assert!((p.eigen_moments().sum() - 1.0).abs() < 1e-14);
    /// ```
    pub fn new(orientation: Matrix4<f64>, eigenvalues: Vector4<f64>) -> Result<Self, DensityError> {
        for &v in orientation.iter().chain(eigenvalues.iter()) {
            finite("Bingham orientation or eigenvalue", v)?;
        }
        let deviation = (orientation.transpose() * orientation - Matrix4::identity()).amax();
        if deviation > TOLERANCE {
            return Err(DensityError::OutOfRange {
                what: "deviation of the Bingham orientation from orthogonality",
                value: deviation,
                range: "orthogonal matrices (|V^T V - I| <= 1e-10)",
            });
        }
        let mut order = [0usize, 1, 2, 3];
        order.sort_by(|&i, &j| eigenvalues[j].total_cmp(&eigenvalues[i]));
        Self::from_sorted_eigen(
            Matrix4::from_fn(|r, c| orientation[(r, order[c])]),
            Vector4::from_fn(|k, _| eigenvalues[order[k]]),
        )
    }

    /// The Bingham distribution with parameter matrix `m` (symmetric; its quadratic form is in the
    /// quaternion's (w, x, y, z) coordinates), the natural parameter.
    ///
    /// # Errors
    /// [`DensityError::NonFinite`], or [`DensityError::OutOfRange`] for an asymmetric matrix, an
    /// eigenvalue beyond ±1e300 or an eigenvalue spread beyond [`Self::MAX_SPREAD`].
    pub fn from_natural(m: Matrix4<f64>) -> Result<Self, DensityError> {
        for &v in m.iter() {
            finite("Bingham parameter matrix", v)?;
        }
        let asymmetry = (m - m.transpose()).amax();
        if asymmetry > TOLERANCE * (1.0 + m.amax()) {
            return Err(DensityError::OutOfRange {
                what: "asymmetry of the Bingham parameter matrix",
                value: asymmetry,
                range: "symmetric matrices; symmetrise with (M + M^T)/2",
            });
        }
        let (orientation, eigenvalues) = sorted_eigen("Bingham parameter matrix", &m)?;
        Self::from_sorted_eigen(orientation, eigenvalues)
    }

    /// The likelihood of a measured direction as a Bingham density of the orientation q. A
    /// `reference` direction h (world frame) measured in the body frame as
    /// `v = R(q)ᵀ h + n`, `n ~ N(0, σ² I)` (R(q) the rotation of q, `x_world = R(q) x_body`), has
    /// the likelihood, for every unit q exactly,
    ///
    /// `exp(−|v − R(q)ᵀ h|² / (2σ²)) = exp(qᵀ M q)`,
    ///
    /// `M = [ −|v − h|²/(2σ²)   (v × h)ᵀ/σ² ;  (v × h)/σ²   (v hᵀ + h vᵀ)/σ² − |v + h|²/(2σ²) I ]`
    ///
    /// in the (w, x, y, z) coordinates. The result is that likelihood normalised over q: its
    /// [`natural`](Self::natural) parameter is M (to rounding), so a prior's posterior is
    /// `Bingham::from_natural(prior.natural() + M)` or [`Product::product`]. For unit vectors the
    /// eigenvalue spread is `2/σ²`; any finite vectors are accepted.
    ///
    /// # Errors
    /// [`DensityError::NonFinite`] for a non-finite component or σ; [`DensityError::OutOfRange`] for
    /// σ ≤ 0, for a matrix whose entries overflow, or for an eigenvalue spread beyond
    /// [`Self::MAX_SPREAD`] (σ below about 1.4e-6 for unit vectors).
    ///
    /// # Example
    /// ```
    /// use liebayes_densities::Bingham;
    /// use liebayes_manifolds::{LieGroup, Su2};
    /// use nalgebra::Vector3;
    /// let (reference, sigma) = (Vector3::z(), 0.1);
    /// let q = Su2::exp(&Vector3::new(0.2, -0.1, 0.4));
    /// let measured = q.to_rotation_matrix().transpose() * reference + Vector3::new(0.01, 0.0, -0.02);
    /// let m = Bingham::from_direction(&measured, &reference, sigma).unwrap().natural();
    /// // qᵀ M q is the Gaussian log-likelihood of the measured direction.
    /// let x = nalgebra::Vector4::from(q.to_quaternion_wxyz());
    /// let residual = measured - q.to_rotation_matrix().transpose() * reference;
    /// let expected = -residual.norm_squared() / (2.0 * sigma * sigma);
    /// assert!(((x.transpose() * m * x)[0] - expected).abs() < 1e-12);
    /// ```
    pub fn from_direction(
        measured: &Vector3<f64>,
        reference: &Vector3<f64>,
        sigma: f64,
    ) -> Result<Self, DensityError> {
        for &c in measured.iter() {
            finite("measured direction component", c)?;
        }
        for &c in reference.iter() {
            finite("reference direction component", c)?;
        }
        finite("direction noise standard deviation", sigma)?;
        if sigma <= 0.0 {
            return Err(DensityError::OutOfRange {
                what: "direction noise standard deviation",
                value: sigma,
                range: "(0, infinity)",
            });
        }
        let (v, h) = (measured, reference);
        let inv = 1.0 / (sigma * sigma);
        let cross = v.cross(h) * inv;
        let block = (v * h.transpose() + h * v.transpose()) * inv
            - Matrix3::identity() * ((v + h).norm_squared() * 0.5 * inv);
        let mut m = Matrix4::zeros();
        m[(0, 0)] = -(v - h).norm_squared() * 0.5 * inv;
        for i in 0..3 {
            m[(0, i + 1)] = cross[i];
            m[(i + 1, 0)] = cross[i];
            for j in 0..3 {
                m[(i + 1, j + 1)] = block[(i, j)];
            }
        }
        if !m.iter().all(|x| x.is_finite()) {
            return Err(DensityError::OutOfRange {
                what: "largest entry of the direction likelihood's parameter",
                value: m.amax(),
                range: "finite: |v|, |h| and 1/sigma^2 whose products stay within f64",
            });
        }
        Self::from_natural(m)
    }

    /// The uniform distribution on S³ (all eigenvalues 0), density 1 against the uniform probability
    /// measure.
    pub fn uniform() -> Self {
        Self::assemble(Matrix4::identity(), Vector4::zeros())
    }

    /// The maximum-likelihood Bingham for a second-moment (scatter) matrix `S = (1/n) Σ qᵢ qᵢᵀ`
    /// (normalised to trace 1), the inverse of [`second_moment`](Self::second_moment):
    /// eigenvectors of S, and eigenvalues z (largest 0) solving `E_z[uₖ²] = sₖ` for the eigenvalues
    /// sₖ of S. The equations are solved by damped Newton's method from `zₖ = 1/(2s₀) − 1/(2sₖ)` (the
    /// concentrated limit), with the Jacobian by backward differences of the accurate gradient, to a
    /// relative moment residual of 1e-11 (or until no halving of the step decreases it: its rounding
    /// floor), at most 100 steps.
    ///
    /// # Errors
    /// [`DensityError::NonFinite`], or [`DensityError::OutOfRange`] when S is not symmetric positive
    /// semi-definite with a positive finite trace, when an eigenvalue of S is zero (infinite
    /// concentration: all samples on a lower-dimensional sphere), or when the fitted eigenvalue spread
    /// exceeds [`Self::MAX_SPREAD`] (an eigenvalue of S below about 1/(2·10¹²) of the largest).
    pub fn from_second_moment(scatter: Matrix4<f64>) -> Result<Self, DensityError> {
        for &v in scatter.iter() {
            finite("scatter matrix", v)?;
        }
        let trace = scatter.trace();
        // Every entry is finite (checked above), so the asymmetry is finite or +∞ and plain comparisons decide.
        if trace <= 0.0
            || !trace.is_finite()
            || (scatter - scatter.transpose()).amax() > TOLERANCE * trace
        {
            return Err(DensityError::OutOfRange {
                what: "trace of the scatter matrix",
                value: trace,
                range: "symmetric positive semi-definite matrices with a positive trace",
            });
        }
        let eigen = finite_eigen(
            "scatter matrix",
            (scatter * 0.5 + scatter.transpose() * 0.5) / trace,
        )?;
        let mut order = [0usize, 1, 2, 3];
        order.sort_by(|&i, &j| eigen.eigenvalues[j].total_cmp(&eigen.eigenvalues[i]));
        let orientation = Matrix4::from_fn(|r, c| eigen.eigenvectors[(r, order[c])]);
        let target = Vector4::from_fn(|k, _| eigen.eigenvalues[order[k]]);
        if target[3] <= 0.0 {
            return Err(DensityError::OutOfRange {
                what: "smallest eigenvalue of the normalised scatter matrix",
                value: target[3],
                range: "(0, 1/4]: a zero eigenvalue means infinite concentration",
            });
        }
        let residual = |z: &Vector3<f64>| -> Vector3<f64> {
            let (_, m) = log_normalizer_and_moments(&[0.0, z[0], z[1], z[2]]);
            Vector3::new(m[1] - target[1], m[2] - target[2], m[3] - target[3])
        };
        // The residual relative to each target moment: the small ones (about 1/(2 spread)) matter
        // as much as the large ones, whose rounding alone is larger than them.
        let relative = |r: &Vector3<f64>| {
            (0..3)
                .map(|k| r[k].abs() / target[k + 1])
                .fold(0.0, f64::max)
        };
        let mut z = Vector3::from_fn(|k, _| 0.5 / target[0] - 0.5 / target[k + 1]);
        let mut r = residual(&z);
        for _ in 0..100 {
            if relative(&r) <= 1e-11 {
                break;
            }
            // Backward differences (z − h stays ≤ 0): three normaliser calls where central ones took
            // six. Their O(h) error only slows the iteration by a factor of about 1e-6 a step; the
            // residual itself, which decides the result, is exact.
            let mut jacobian = Matrix3::zeros();
            for col in 0..3 {
                let h = 1e-6 * (1.0 + z[col].abs());
                let mut minus = z;
                minus[col] -= h;
                jacobian.set_column(col, &((r - residual(&minus)) / h));
            }
            let Some(step) = jacobian.lu().solve(&r) else {
                break;
            };
            // Halve the step until the residual decreases (and the eigenvalues stay ≤ 0), at most 20
            // times; a step that cannot decrease it at all means the residual is at its rounding
            // floor, and further iterations would only repeat the 20 halvings.
            let mut improved = false;
            let mut scale = 1.0;
            for _ in 0..20 {
                let candidate = (z - step * scale).map(|v| v.min(0.0));
                let r_candidate = residual(&candidate);
                if relative(&r_candidate) < relative(&r) {
                    z = candidate;
                    r = r_candidate;
                    improved = true;
                    break;
                }
                scale *= 0.5;
            }
            if !improved {
                break;
            }
        }
        Self::from_sorted_eigen(orientation, Vector4::new(0.0, z[0], z[1], z[2]))
    }

    fn from_sorted_eigen(
        orientation: Matrix4<f64>,
        eigenvalues: Vector4<f64>,
    ) -> Result<Self, DensityError> {
        for &v in eigenvalues.iter() {
            finite("Bingham eigenvalue", v)?;
        }
        check_spread(&eigenvalues.into())?;
        Ok(Self::assemble(orientation, eigenvalues))
    }

    /// The density of validated, sorted eigen parameters: the normaliser, moments and envelope.
    fn assemble(orientation: Matrix4<f64>, eigenvalues: Vector4<f64>) -> Self {
        let (log_normalizer_minus_max, moments) = log_normalizer_and_moments(&eigenvalues.into());
        Self {
            orientation,
            eigenvalues,
            log_normalizer_minus_max,
            moments: Vector4::from(moments),
            envelope: Envelope::new(&eigenvalues),
        }
    }

    /// The natural parameter, the parameter matrix `M = V diag(z) Vᵀ`.
    pub fn natural(&self) -> Matrix4<f64> {
        self.orientation * Matrix4::from_diagonal(&self.eigenvalues) * self.orientation.transpose()
    }

    /// The eigenvalues (concentrations) z, descending.
    pub fn eigenvalues(&self) -> Vector4<f64> {
        self.eigenvalues
    }

    /// The orthogonal matrix V of eigenvectors (column k belongs to eigenvalue k).
    pub fn orientation(&self) -> &Matrix4<f64> {
        &self.orientation
    }

    /// The second moments along the eigenvectors, `E[(vₖ · q)²] = ∂ ln K / ∂zₖ` (they sum to 1).
    pub fn eigen_moments(&self) -> Vector4<f64> {
        self.moments
    }

    /// The second-moment matrix `E[q qᵀ] = V diag(E[(vₖ · q)²]) Vᵀ`.
    pub fn second_moment(&self) -> Matrix4<f64> {
        self.orientation * Matrix4::from_diagonal(&self.moments) * self.orientation.transpose()
    }

    /// `ln K` against the raw surface measure of S³ (the uniform-measure value plus ln 2π²).
    pub fn log_normalizer_surface(&self) -> f64 {
        self.log_normalizer() + (2.0 * std::f64::consts::PI * std::f64::consts::PI).ln()
    }
}

impl Rotate<Su2<f64>> for Bingham {
    /// The eigenvectors turned by the left multiplication `q ↦ g q` (orthogonal for unit g), the same
    /// eigenvalues.
    fn rotated(&self, g: &Su2<f64>) -> Result<Self, DensityError> {
        let [w, x, y, z] = g.to_quaternion_wxyz();
        // Left multiplication g q as a matrix acting on (w, x, y, z).
        let left = Matrix4::new(w, -x, -y, -z, x, w, -z, y, y, z, w, -x, z, -y, x, w);
        Ok(Self {
            orientation: left * self.orientation,
            ..self.clone()
        })
    }

    /// `g q`.
    fn act(g: &Su2<f64>, q: &Su2<f64>) -> Su2<f64> {
        g.compose(q)
    }
}

distribution_through_density!(Bingham);

fn coordinates(q: &Su2<f64>) -> Vector4<f64> {
    let [w, x, y, z] = q.to_quaternion_wxyz();
    Vector4::new(w, x, y, z)
}

impl Density for Bingham {
    type Point = Su2<f64>;

    /// `qᵀ M q − ln K`, against the uniform probability measure on S³, evaluated as
    /// `−Σ_(k≥1) (z₀ − zₖ) uₖ² − (ln K − z₀)` with `u = Vᵀ q` (|u| = 1), so that a large common
    /// eigenvalue z₀ cancels exactly instead of in floating point.
    fn log_pdf(&self, q: &Su2<f64>) -> f64 {
        let u = self.orientation.transpose() * coordinates(q);
        -u.component_mul(&u).dot(&self.envelope.a) - self.log_normalizer_minus_max
    }

    /// `ln K(z) = ln E_uniform[exp(Σ zₖ uₖ²)]`.
    fn log_normalizer(&self) -> f64 {
        self.eigenvalues[0] + self.log_normalizer_minus_max
    }

    /// Exact rejection sampling from an angular central Gaussian envelope (Kent, Ganeiber & Mardia,
    /// 2013). With `aₖ = z₀ − zₖ ≥ 0`, b solving `Σ 1/(b + 2aₖ) = 1` and `ωₖ = 1 + 2aₖ/b`: draw
    /// `yₖ ~ N(0, 1/ωₖ)`, `u = y/|y|`, and accept when
    /// `ln U < −Σ aₖuₖ² + 2 ln(Σ ωₖuₖ²) + (4 − b)/2 − 2 ln(4/b)`. The acceptance rate is at least 0.43
    /// over the accepted range (measured); a draw makes at most 200 proposals and, were all rejected
    /// (probability below 1e-48), keeps the last one.
    fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> Su2<f64> {
        let Envelope {
            a,
            omega,
            log_bound,
        } = &self.envelope;
        let mut u = Vector4::new(1.0, 0.0, 0.0, 0.0);
        for _ in 0..MAX_PROPOSALS {
            let y = Vector4::from_fn(|k, _| rng.sample::<f64, _>(StandardNormal) / omega[k].sqrt());
            let norm = y.norm();
            if norm == 0.0 {
                continue;
            }
            u = y / norm;
            let u2 = u.component_mul(&u);
            let log_ratio = -a.dot(&u2) + 2.0 * omega.dot(&u2).ln() - log_bound;
            if rng.random::<f64>().ln() < log_ratio {
                break;
            }
        }
        let q = self.orientation * u;
        Su2::from_quaternion_unchecked(Quaternion::new(q[0], q[1], q[2], q[3]).normalize())
    }

    /// The eigenvector of the largest eigenvalue, with `w ≥ 0` (−q is a mode too); none when the
    /// largest eigenvalue is repeated (the maxima form a circle or more): a gap within the
    /// rounding of eigenvalues computed from a matrix of their size, `8 eps (|z₀| + z₀ − z₃)`. Only
    /// differences of eigenvalues matter to the distribution, so a common shift enters only
    /// through that rounding, and a gap of 10 beside a spread of 1e12 is a mode.
    fn mode(&self) -> Option<Su2<f64>> {
        let z = &self.eigenvalues;
        if z[0] - z[1] <= 8.0 * f64::EPSILON * (z[0].abs() + (z[0] - z[3])) {
            return None;
        }
        let v = self.orientation.column(0);
        let sign = if v[0] < 0.0 { -1.0 } else { 1.0 };
        Some(Su2::from_quaternion_unchecked(
            Quaternion::new(v[0], v[1], v[2], v[3]).normalize() * sign,
        ))
    }
}

impl Bingham {
    /// `M − z₀ I = V diag(z − z₀) Vᵀ`: the parameter matrix less its largest eigenvalue, of the
    /// size of the spread whatever the shift z₀.
    fn natural_less_largest(&self) -> Matrix4<f64> {
        let a = self.eigenvalues.add_scalar(-self.eigenvalues[0]);
        self.orientation * Matrix4::from_diagonal(&a) * self.orientation.transpose()
    }

    /// The product of [`Product::product`] and the largest eigenvalue of
    /// `M₁ + M₂ − (z₁₀ + z₂₀) I`: the eigendecomposition is of that shift-free sum, so the
    /// eigenvalue gaps keep their precision beside a large common eigenvalue (from
    /// `M₁ + M₂` itself, an offset of 1e15 turned gaps (2, 6, 20) into (3.25, 7, 20.5)).
    fn product_and_largest(&self, other: &Self) -> Result<(Self, f64), DensityError> {
        let (orientation, shifted) = sorted_eigen(
            "Bingham product's parameter matrix",
            &(self.natural_less_largest() + other.natural_less_largest()),
        )?;
        let shift = self.eigenvalues[0] + other.eigenvalues[0];
        let joint = Self::from_sorted_eigen(orientation, shifted.add_scalar(shift))?;
        Ok((joint, shifted[0]))
    }
}

impl Product for Bingham {
    /// `M = M₁ + M₂`, eigendecomposed as `(M₁ − z₁₀ I) + (M₂ − z₂₀ I)` and shifted back.
    ///
    /// # Errors
    /// As [`from_natural`](Bingham::from_natural), where the sum's eigenvalue spread exceeds
    /// [`Bingham::MAX_SPREAD`].
    fn product(&self, other: &Self) -> Result<Self, DensityError> {
        Ok(self.product_and_largest(other)?.0)
    }

    /// `ln K(M₁ + M₂) − ln K(M₁) − ln K(M₂)`, with every largest eigenvalue taken out:
    /// `(ln K₁₂ − z₁₂₀) + z′ − (ln K₁ − z₁₀) − (ln K₂ − z₂₀)`, z′ the largest eigenvalue of
    /// `M₁ + M₂ − (z₁₀ + z₂₀) I`, so that no terms of the size of the eigenvalues cancel.
    ///
    /// # Errors
    /// As [`product`](Product::product).
    fn log_product_integral(&self, other: &Self) -> Result<f64, DensityError> {
        let (joint, largest) = self.product_and_largest(other)?;
        Ok(joint.log_normalizer_minus_max + largest
            - self.log_normalizer_minus_max
            - other.log_normalizer_minus_max)
    }
}

impl Entropy for Bingham {
    /// `ln K − Σ zₖ E[(vₖ · q)²]`, evaluated as `(ln K − z₀) + Σ (z₀ − zₖ) E[(vₖ · q)²]` (the moments
    /// sum to 1), free of the cancellation of a large z₀.
    fn entropy(&self) -> f64 {
        self.log_normalizer_minus_max + self.envelope.a.dot(&self.moments)
    }
}

impl KlDivergence for Bingham {
    /// `ln K_q − ln K_p + tr((M_p − M_q) E_p[q qᵀ])`, evaluated with the largest eigenvalues taken out
    /// of both: `(ln K_q − z_q0) − (ln K_p − z_p0) − Σ a_pk E_p[(v_pk · q)²] + Σ a_qk E_p[(v_qk · q)²]`,
    /// `a = z₀ − z`.
    fn kl_divergence(&self, other: &Self) -> f64 {
        let second = self.second_moment();
        let along_other = Vector4::from_fn(|k, _| {
            let v = other.orientation.column(k);
            v.dot(&(second * v))
        });
        other.log_normalizer_minus_max
            - self.log_normalizer_minus_max
            - self.envelope.a.dot(&self.moments)
            + other.envelope.a.dot(&along_other)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    /// The acceptance rate `E_envelope[density / (M · envelope)]` of the sampler, by 20 000 proposals,
    /// over eigenvalue gaps from 0 to the largest spread accepted (1e12), including the shapes that
    /// make the envelope worst (one, two or three gaps large, the others 0). The documented bound,
    /// 0.43, is the worst measured (0.443, three equal gaps of 1e6) rounded down; the standard error is
    /// below 0.004.
    #[test]
    fn acceptance_rate_is_bounded_below_over_the_whole_range() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(17);
        let mut worst = 1.0_f64;
        for gaps in [
            [0.0, 0.0, 0.0],
            [1.0, 2.0, 3.0],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, 10.0],
            [0.0, 10.0, 10.0],
            [10.0, 10.0, 10.0],
            [0.0, 0.0, 1e6],
            [0.0, 1e6, 1e6],
            [1e6, 1e6, 1e6],
            [1.0, 1e3, 1e6],
            [0.0, 0.0, 1e12],
            [0.0, 1e12, 1e12],
            [1e12, 1e12, 1e12],
            [1.0, 1e6, 1e12],
            [0.3, 3.0, 30.0],
        ] {
            let z = Vector4::new(0.0, -gaps[0], -gaps[1], -gaps[2]);
            let Envelope {
                a,
                omega,
                log_bound,
            } = Envelope::new(&z);
            let draws = 20_000;
            let mut accepted = 0.0;
            for _ in 0..draws {
                let y =
                    Vector4::from_fn(|k, _| rng.sample::<f64, _>(StandardNormal) / omega[k].sqrt());
                let u = y / y.norm();
                let u2 = u.component_mul(&u);
                let log_ratio = -a.dot(&u2) + 2.0 * omega.dot(&u2).ln() - log_bound;
                assert!(
                    log_ratio <= 1e-12,
                    "{gaps:?}: the envelope must bound the density"
                );
                accepted += log_ratio.exp();
            }
            let rate = accepted / f64::from(draws);
            eprintln!("gaps {gaps:?}: acceptance rate {rate:.3}");
            worst = worst.min(rate);
        }
        assert!(worst >= 0.43, "worst acceptance rate {worst}");
    }
}
