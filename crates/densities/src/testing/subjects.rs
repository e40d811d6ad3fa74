//! [`DensitySubject`] for every family of the crate: each integrates over its space with the rule of
//! [`quadrature`] placed at its location and width, and compares its sampler with its closed-form
//! moments.

use super::laws::DensitySubject;
use super::quadrature;
use crate::eigen::bounded_eigen;
use crate::{
    Bingham, Density, Gaussian, GenVonMises2, HarmonicGaussian, HeatKernelSo3, ManifoldGaussian,
    VonMises, VonMisesFisher,
};
use liebayes_manifolds::testing::LawSubject;
use liebayes_manifolds::{LieGroup, Manifold, S2, So2, So3, Su2};
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};
use std::fmt::Debug;

/// Fractions of the width at which [`manifold_neighbours`] perturbs a point.
const NEIGHBOUR_STEPS: [f64; 4] = [1e-6, 1e-3, 0.1, 1.0];

/// Points `x ⊞ (±h eᵢ)` for every tangent axis eᵢ and `h = width · {1e-6, 1e-3, 0.1, 1}`: the
/// neighbours [`DensitySubject::neighbours`] asks for, on any manifold.
pub fn manifold_neighbours<X: Manifold<D, Scalar = f64>, const D: usize>(
    x: &X,
    width: f64,
) -> Vec<X> {
    let mut points = Vec::with_capacity(8 * D);
    for step in NEIGHBOUR_STEPS {
        for i in 0..D {
            for sign in [-1.0, 1.0] {
                let mut v = SVector::<f64, D>::zeros();
                v[i] = sign * step * width;
                points.push(x.retract(&v));
            }
        }
    }
    points
}

/// `(cos θ, sin θ, cos 2θ, sin 2θ)`.
fn harmonics(x: &So2<f64>) -> [f64; 4] {
    let (c, s) = (x.cos(), x.sin());
    [c, s, c * c - s * s, 2.0 * c * s]
}

/// The entries of `v` and of `v vᵀ` on and above the diagonal.
fn first_and_second<const N: usize>(v: &SVector<f64, N>) -> Vec<f64> {
    let mut t: Vec<f64> = v.iter().copied().collect();
    for i in 0..N {
        for j in i..N {
            t.push(v[i] * v[j]);
        }
    }
    t
}

/// The entries of a mean m and of a second moment `S` on and above the diagonal.
fn mean_and_second<const N: usize>(
    mean: &SVector<f64, N>,
    second: &SMatrix<f64, N, N>,
) -> Vec<f64> {
    let mut t: Vec<f64> = mean.iter().copied().collect();
    for i in 0..N {
        for j in i..N {
            t.push(second[(i, j)]);
        }
    }
    t
}

/// The eigenvalues of a covariance (none for N = 0), from a dynamic copy: nalgebra's symmetric
/// eigensolver has no const-generic form and asserts on an empty matrix. `None` where the bounded
/// eigensolver (1000 iterations) does not converge or meets a non-finite entry.
fn eigenvalues<const N: usize>(covariance: &SMatrix<f64, N, N>) -> Option<nalgebra::DVector<f64>> {
    if N == 0 {
        return Some(nalgebra::DVector::zeros(0));
    }
    bounded_eigen(nalgebra::DMatrix::from_column_slice(
        N,
        N,
        covariance.as_slice(),
    ))
    .map(|eigen| eigen.eigenvalues)
}

/// The smallest standard deviation of a covariance (its smallest eigenvalue's root; 1 for N = 0,
/// which has no direction to step in); NaN where its eigenvalues cannot be computed, so that every
/// tolerance and neighbour built on it fails its law rather than passes it.
fn smallest_deviation<const N: usize>(covariance: &SMatrix<f64, N, N>) -> f64 {
    match eigenvalues(covariance) {
        None => f64::NAN,
        Some(eigenvalues) if eigenvalues.is_empty() => 1.0,
        Some(eigenvalues) => eigenvalues.min().max(0.0).sqrt(),
    }
}

/// `2 N cond(L) = 2 N √(λ_max/λ_min)`, the growth of the relative rounding of a Mahalanobis term
/// computed by a triangular solve with the Cholesky factor L of a covariance.
fn mahalanobis_condition<const N: usize>(covariance: &SMatrix<f64, N, N>) -> f64 {
    2.0 * N as f64 * covariance_condition(covariance).sqrt()
}

/// `cond(P) = λ_max/λ_min`, the sensitivity of a Mahalanobis term to a relative perturbation of the
/// covariance (1 for N = 0; NaN where the eigenvalues cannot be computed, as
/// [`smallest_deviation`]).
fn covariance_condition<const N: usize>(covariance: &SMatrix<f64, N, N>) -> f64 {
    match eigenvalues(covariance) {
        None => f64::NAN,
        Some(eigenvalues) if eigenvalues.is_empty() => 1.0,
        Some(eigenvalues) => eigenvalues.max() / eigenvalues.min(),
    }
}

/// Gauss-Hermite points per axis for a product rule in dimension n: 8 up to 3 dimensions, 4 up to 6,
/// 3 beyond (all exact for a Gaussian times a polynomial of degree 5, which is what the laws integrate
/// for the Gaussian families).
fn hermite_points(n: usize) -> usize {
    match n {
        0..=3 => 8,
        4..=6 => 4,
        _ => 3,
    }
}

impl DensitySubject for VonMises {
    /// The trapezoid rule resolving the width `1/√(1 + κ)`.
    fn quadrature(&self) -> Vec<(So2<f64>, f64)> {
        quadrature::circle(1.0 / (1.0 + self.concentration()).sqrt())
    }

    fn neighbours(&self, x: &So2<f64>) -> Vec<So2<f64>> {
        manifold_neighbours(x, 1.0 / (1.0 + self.concentration()).sqrt())
    }

    /// `(cos θ, sin θ, cos 2θ, sin 2θ)`.
    fn statistics(&self, x: &So2<f64>) -> Vec<f64> {
        harmonics(x).to_vec()
    }

    /// The first two trigonometric moments `Aₙ(κ) u(nμ)`.
    fn exact_moments(&self) -> Vec<f64> {
        let one = self
            .trigonometric_moment(1)
            .unwrap_or_else(|_| nalgebra::Vector2::zeros());
        let two = self
            .trigonometric_moment(2)
            .unwrap_or_else(|_| nalgebra::Vector2::zeros());
        vec![one.x, one.y, two.x, two.y]
    }

    /// κ (the sensitivity of `κ cos(θ − μ)` to the rounding of θ) plus |ln Z|.
    fn log_scale(&self) -> f64 {
        self.concentration() + self.log_normalizer().abs()
    }
}

impl DensitySubject for GenVonMises2 {
    /// The trapezoid rule resolving the width `1/√(1 + κ₁ + 4κ₂)`.
    fn quadrature(&self) -> Vec<(So2<f64>, f64)> {
        quadrature::circle(1.0 / (1.0 + combined(self)).sqrt())
    }

    fn neighbours(&self, x: &So2<f64>) -> Vec<So2<f64>> {
        manifold_neighbours(x, 1.0 / (1.0 + combined(self)).sqrt())
    }

    /// `(cos θ, sin θ, cos 2θ, sin 2θ)`.
    fn statistics(&self, x: &So2<f64>) -> Vec<f64> {
        harmonics(x).to_vec()
    }

    /// [`GenVonMises2::trigonometric_moments`].
    fn exact_moments(&self) -> Vec<f64> {
        let (one, two) = self.trigonometric_moments();
        vec![one.x, one.y, two.x, two.y]
    }

    /// `κ₁ + 4κ₂` plus |ln Z|.
    fn log_scale(&self) -> f64 {
        combined(self) + self.log_normalizer().abs()
    }
}

/// `κ₁ + 4κ₂`.
fn combined(p: &GenVonMises2) -> f64 {
    let (eta1, eta2) = p.natural();
    eta1.norm() + 4.0 * eta2.norm()
}

impl DensitySubject for VonMisesFisher {
    /// The sphere rule about the mean direction (the z axis for the uniform distribution), width
    /// `1/(1 + κ)` in `t = 1 − μ · x`.
    fn quadrature(&self) -> Vec<(S2<f64>, f64)> {
        let axis = self
            .mean()
            .unwrap_or_else(|| S2::new_unchecked(Vector3::z()));
        quadrature::sphere(&axis, 1.0 / (1.0 + self.concentration()))
    }

    fn neighbours(&self, x: &S2<f64>) -> Vec<S2<f64>> {
        manifold_neighbours(x, 1.0 / (1.0 + self.concentration()).sqrt())
    }

    /// The point x ∈ R³.
    fn statistics(&self, x: &S2<f64>) -> Vec<f64> {
        x.as_vector().iter().copied().collect()
    }

    /// [`VonMisesFisher::first_moment`].
    fn exact_moments(&self) -> Vec<f64> {
        self.first_moment().iter().copied().collect()
    }

    /// κ plus |ln Z|.
    fn log_scale(&self) -> f64 {
        self.concentration() + self.log_normalizer().abs()
    }
}

/// The standard deviations `1/√(2aₖ)` of the coordinates `vₖ · q` of a concentrated Bingham
/// (`aₖ = z₀ − zₖ`; 10, diffuse, for `aₖ = 0`).
fn bingham_widths(p: &Bingham) -> [f64; 3] {
    let z = p.eigenvalues();
    std::array::from_fn(|k| {
        let a = z[0] - z[k + 1];
        if a > 0.005 {
            (0.5 / a).sqrt().min(10.0)
        } else {
            10.0
        }
    })
}

impl DensitySubject for Bingham {
    /// The S³ rule in the eigenvector frame, with the standard deviations `1/√(2aₖ)` of the
    /// coordinates `vₖ · q` (`aₖ = z₀ − zₖ`; 10, diffuse, for small aₖ).
    fn quadrature(&self) -> Vec<(Su2<f64>, f64)> {
        quadrature::s3(self.orientation(), &bingham_widths(self))
    }

    fn neighbours(&self, x: &Su2<f64>) -> Vec<Su2<f64>> {
        // Tangent steps ξ move vₖ · q by about |ξ|/2.
        let width = 2.0 * bingham_widths(self).iter().copied().fold(1.0, f64::min);
        manifold_neighbours(x, width)
    }

    /// The entries of `q qᵀ` on and above the diagonal.
    fn statistics(&self, x: &Su2<f64>) -> Vec<f64> {
        let [w, a, b, c] = x.to_quaternion_wxyz();
        let q = [w, a, b, c];
        let mut t = Vec::with_capacity(10);
        for i in 0..4 {
            for j in i..4 {
                t.push(q[i] * q[j]);
            }
        }
        t
    }

    /// [`Bingham::second_moment`].
    fn exact_moments(&self) -> Vec<f64> {
        let m = self.second_moment();
        let mut t = Vec::with_capacity(10);
        for i in 0..4 {
            for j in i..4 {
                t.push(m[(i, j)]);
            }
        }
        t
    }

    /// The eigenvalue spread plus |ln K|.
    fn log_scale(&self) -> f64 {
        let z = self.eigenvalues();
        (z[0] - z[3]) + self.log_normalizer().abs()
    }
}

impl DensitySubject for HeatKernelSo3 {
    /// The SO(3) rule about the centre with the isotropic spread `min(√s, 1)`.
    fn quadrature(&self) -> Vec<(So3<f64>, f64)> {
        quadrature::so3(
            &self.mean(),
            &(Matrix3::identity() * self.variance().sqrt().min(1.0)),
        )
    }

    fn neighbours(&self, x: &So3<f64>) -> Vec<So3<f64>> {
        manifold_neighbours(x, self.variance().sqrt().min(1.0))
    }

    /// The entries of the rotation matrix.
    fn statistics(&self, x: &So3<f64>) -> Vec<f64> {
        x.to_matrix().iter().copied().collect()
    }

    /// [`HeatKernelSo3::first_moment`], `E[R] = e^(−s) C`.
    fn exact_moments(&self) -> Vec<f64> {
        self.first_moment().iter().copied().collect()
    }

    /// p's SO(3) rule in spherical form, `c_p exp(t n)`, the angles t on the panels of
    /// `angle_panels`, with the directions' polar axis along
    /// m, the axis of `c_q⁻¹ c_p`, and the polar panels split where the point crosses the cut locus
    /// of q's centre (`m · n = cot(δ/2) cot(t/2)`, δ the angle of `c_q⁻¹ c_p`), along which q's log
    /// density has a kink of slope up to π/s_q.
    fn pair_quadrature(&self, other: &Self) -> Vec<(So3<f64>, f64)> {
        heat_kernel_pair_quadrature(self, other)
    }

    /// `π²/(2s)`, the largest `t²/(2s)` of the log density, plus `1.5 |ln s|`.
    fn log_scale(&self) -> f64 {
        let s = self.variance();
        std::f64::consts::PI.powi(2) / (2.0 * s) + 1.5 * s.ln().abs()
    }
}

/// See [`DensitySubject::pair_quadrature`] for [`HeatKernelSo3`].
fn heat_kernel_pair_quadrature(p: &HeatKernelSo3, q: &HeatKernelSo3) -> Vec<(So3<f64>, f64)> {
    use std::f64::consts::PI;
    let d = q.mean().inverse().compose(&p.mean()).log();
    let delta = d.norm();
    let m = if delta > 0.0 { d / delta } else { Vector3::z() };
    // An orthonormal frame (e₁, e₂, m).
    let helper = if m.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let e1 = m.cross(&helper).normalize();
    let e2 = m.cross(&e1);
    let (sd, cd) = (0.5 * delta).sin_cos();
    // 64 Gauss-Legendre points on [−1, 1] where no kink is in range. The integrand does not depend
    // on the azimuth about m (the angle of q's centre to R depends on t and m · n only), so one
    // azimuth with weight 2π integrates it exactly.
    let polar = quadrature::gauss_legendre(64);
    let azimuths = 1;
    let h = 2.0 * PI / f64::from(azimuths);
    let mut nodes = Vec::new();
    for (t, wt) in angle_panels(p.variance(), q.variance(), delta) {
        let (st, ct) = (0.5 * t).sin_cos();
        let kink = if sd * st > 0.0 {
            cd * ct / (sd * st)
        } else {
            f64::INFINITY
        };
        // (c, weight): graded from the kink, where q's log density turns over an angle of s_q/π,
        // `dt′ ≈ 2 sin(δ/2) sin(t/2) dc`.
        let directions: Vec<(f64, f64)> = if kink.abs() < 1.0 {
            let width = (q.variance() / (2.0 * PI * sd * st)).min(1.0);
            let below = quadrature::peaked(width, kink + 1.0, 32);
            let above = quadrature::peaked(width, 1.0 - kink, 32);
            below
                .into_iter()
                .map(|(x, w)| (kink - x, w))
                .chain(above.into_iter().map(|(x, w)| (kink + x, w)))
                .collect()
        } else {
            polar.iter().map(|&(x, w)| (x, w)).collect()
        };
        let haar = t * t * half_angle_sinc(t).powi(2) / (8.0 * PI * PI);
        for &(c, wc) in &directions {
            let sine = (1.0 - c * c).max(0.0).sqrt();
            for k in 0..azimuths {
                let (s, co) = (h * f64::from(k)).sin_cos();
                let n = m * c + (e1 * co + e2 * s) * sine;
                nodes.push((p.mean().compose(&So3::exp(&(n * t))), wt * wc * h * haar));
            }
        }
    }
    nodes
}

/// Nodes in the rotation angle t ∈ [0, π] of `c_p⁻¹ R` for the KL law: split at `π − δ`, where the
/// cut locus of q's centre enters the directions (and the inner integral stops being smooth in t),
/// and at π; each piece is covered from both ends by [`peaked`](quadrature::peaked) panels, of
/// width `√s_p` at 0 (p's mass) and `min(s_q/π, √s_p)` at the splits (q's log density turns over
/// an angle of about s_q/π there, where its two nearest images meet; p's mass may lie there too).
fn angle_panels(s_p: f64, s_q: f64, delta: f64) -> Vec<(f64, f64)> {
    use std::f64::consts::PI;
    // At the splits q's turning width, or p's width where p is narrower (its mass may lie there).
    let w_p = s_p.sqrt().min(1.0);
    let w_q = (s_q / PI).min(w_p);
    let split = PI - delta;
    let mut pieces = Vec::new();
    if split > 0.0 && split < PI {
        pieces.push((0.0, split, w_p, w_q));
        pieces.push((split, PI, w_q, w_q));
    } else {
        pieces.push((0.0, PI, w_p, w_q));
    }
    let mut nodes = Vec::new();
    for (a, b, wa, wb) in pieces {
        let half = 0.5 * (b - a);
        for (x, w) in quadrature::peaked(wa, half, 32) {
            nodes.push((a + x, w));
        }
        for (x, w) in quadrature::peaked(wb, half, 32) {
            nodes.push((b - x, w));
        }
    }
    nodes
}

/// `sin(θ/2)/(θ/2)`, 1 at θ = 0.
fn half_angle_sinc(theta: f64) -> f64 {
    if theta < 1e-8 {
        1.0
    } else {
        (0.5 * theta).sin() / (0.5 * theta)
    }
}

impl<const N: usize> DensitySubject for Gaussian<N> {
    /// The Gauss-Hermite rule in the covariance's eigen-coordinates.
    fn quadrature(&self) -> Vec<(SVector<f64, N>, f64)> {
        quadrature::rn(self.mean(), self.covariance(), hermite_points(N))
    }

    fn neighbours(&self, x: &SVector<f64, N>) -> Vec<SVector<f64, N>> {
        let width = smallest_deviation(self.covariance());
        manifold_neighbours(&liebayes_manifolds::Rn::new_unchecked(*x), width)
            .into_iter()
            .map(|p| *p.coords())
            .collect()
    }

    /// The entries of x and of x xᵀ on and above the diagonal.
    fn statistics(&self, x: &SVector<f64, N>) -> Vec<f64> {
        first_and_second(x)
    }

    /// μ and `Σ + μ μᵀ`.
    fn exact_moments(&self) -> Vec<f64> {
        let m = self.mean();
        mean_and_second(m, &(self.covariance() + m * m.transpose()))
    }

    /// `12 (1 + |μ|∞)/σ_min`: the rounding `ε |μ|` of a point's coordinates, amplified by the
    /// Mahalanobis term's slope out to 12 standard deviations, plus |ln Z|.
    fn log_scale(&self) -> f64 {
        12.0 * (1.0 + self.mean().amax()) / smallest_deviation(self.covariance())
            + self.log_normalizer().abs()
    }

    /// `2 N cond(L)`.
    fn log_condition(&self) -> f64 {
        mahalanobis_condition(self.covariance())
    }

    /// `cond(P)`.
    fn parameter_condition(&self) -> f64 {
        covariance_condition(self.covariance())
    }
}

impl<X, const D: usize> DensitySubject for ManifoldGaussian<X, D>
where
    X: LawSubject<D, Scalar = f64> + Clone + Debug,
{
    /// The Gauss-Hermite rule in the tangent space at the mean, against the tangent Lebesgue measure
    /// (the family's base measure).
    fn quadrature(&self) -> Vec<(X, f64)> {
        quadrature::tangent(self.mean(), self.covariance(), hermite_points(D))
    }

    fn neighbours(&self, x: &X) -> Vec<X> {
        manifold_neighbours(x, smallest_deviation(self.covariance()))
    }

    /// The tangent vector `δ = x ⊟ μ` and the entries of `δ δᵀ` on and above the diagonal.
    fn statistics(&self, x: &X) -> Vec<f64> {
        first_and_second(&self.mean().local(x))
    }

    /// `E[δ] = 0`, `E[δ δᵀ] = P`.
    fn exact_moments(&self) -> Vec<f64> {
        mean_and_second(&SVector::<f64, D>::zeros(), self.covariance())
    }

    /// `12 (coordinate scale)/σ_min` (the rounding of a point's coordinates through the Mahalanobis
    /// term) plus |ln Z|.
    fn log_scale(&self) -> f64 {
        12.0 * self.mean().coordinate_scale() / smallest_deviation(self.covariance())
            + self.log_normalizer().abs()
    }

    /// `2 D cond(L)`.
    fn log_condition(&self) -> f64 {
        mahalanobis_condition(self.covariance())
    }

    /// `cond(P)`.
    fn parameter_condition(&self) -> f64 {
        covariance_condition(self.covariance())
    }
}

impl<const N: usize> DensitySubject for HarmonicGaussian<N> {
    /// The angle's trapezoid rule times, at each angle y, the Gauss-Hermite rule of the conditional
    /// `N(B φ(y), Σ)`.
    fn quadrature(&self) -> Vec<((So2<f64>, SVector<f64, N>), f64)> {
        let zero = SVector::<f64, N>::zeros();
        let conditional = quadrature::rn(&zero, self.covariance(), hermite_points(N));
        let mut nodes = Vec::new();
        for (y, wy) in self.angle().quadrature() {
            let mean = self.conditional_mean(&y);
            for (delta, wx) in &conditional {
                nodes.push(((y, mean + delta), wy * wx));
            }
        }
        nodes
    }

    fn neighbours(&self, (y, x): &(So2<f64>, SVector<f64, N>)) -> Vec<(So2<f64>, SVector<f64, N>)> {
        let mut points: Vec<_> = self
            .angle()
            .neighbours(y)
            .into_iter()
            .map(|z| (z, *x))
            .collect();
        let width = smallest_deviation(self.covariance());
        points.extend(
            manifold_neighbours(&liebayes_manifolds::Rn::new_unchecked(*x), width)
                .into_iter()
                .map(|p| (*y, *p.coords())),
        );
        points
    }

    /// `(cos y, sin y, cos 2y, sin 2y)`, the entries of x and of x xᵀ on and above the diagonal.
    fn statistics(&self, (y, x): &(So2<f64>, SVector<f64, N>)) -> Vec<f64> {
        let mut t = harmonics(y).to_vec();
        t.extend(first_and_second(x));
        t
    }

    /// The angle's trigonometric moments and [`HarmonicGaussian::marginal_moments`].
    fn exact_moments(&self) -> Vec<f64> {
        let mut t = self.angle().exact_moments();
        let (mean, covariance) = self.marginal_moments();
        t.extend(mean_and_second(
            &mean,
            &(covariance + mean * mean.transpose()),
        ));
        t
    }

    /// The angle's scale plus that of the conditional Gaussian, `12 (1 + max |B|)/σ_min`.
    fn log_scale(&self) -> f64 {
        self.angle().log_scale()
            + 12.0 * (1.0 + self.features().amax()) / smallest_deviation(self.covariance())
            + self.log_normalizer().abs()
    }

    /// `2 N cond(L)` of the conditional covariance.
    fn log_condition(&self) -> f64 {
        mahalanobis_condition(self.covariance())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A zero-dimensional Gaussian (which `Gaussian::new` accepts) made the subject's helpers
    /// panic on nalgebra's assert on an empty eigenproblem; its rule is R⁰'s one point.
    #[test]
    fn a_zero_dimensional_gaussian_is_a_subject() {
        let g = Gaussian::<0>::new(SVector::zeros(), SMatrix::zeros()).unwrap();
        let nodes = g.quadrature();
        assert_eq!(nodes.len(), 1);
        assert!(
            g.neighbours(&nodes[0].0)
                .iter()
                .all(nalgebra::Matrix::is_empty)
        );
        assert!(g.log_condition().is_finite());
        assert!(g.log_scale().is_finite());
    }

    /// The subjects' scales came from nalgebra's unbounded eigensolver, and a covariance without
    /// eigenvalues gave a smallest deviation of 0 (its NaN eigenvalues clamped). With the bounded
    /// solver, such a covariance gives NaN scales, which fail every tolerance built on them.
    #[test]
    fn covariances_without_eigenvalues_give_nan_scales() {
        for bad in [f64::NAN, f64::INFINITY] {
            let covariance = Matrix3::new(1.0, 0.2, 0.0, 0.2, bad, 0.0, 0.0, 0.0, 1.0);
            assert!(smallest_deviation(&covariance).is_nan(), "{bad}");
            assert!(covariance_condition(&covariance).is_nan(), "{bad}");
            assert!(mahalanobis_condition(&covariance).is_nan(), "{bad}");
        }
        let fine = Matrix3::from_diagonal(&Vector3::new(4.0, 1.0, 0.25));
        assert!((smallest_deviation(&fine) - 0.5).abs() < 1e-15);
        assert!((covariance_condition(&fine) - 16.0).abs() < 1e-13);
    }
}
