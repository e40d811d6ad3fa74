//! Named approximations between the SO(3) families, by matching second moments of the unit quaternion:
//! the heat kernel, the manifold Gaussian and the left-translated anisotropic diffusion `LD(q̄, Σ)`
//! to and from the Bingham. Their errors, measured against concentration, are in
//! `docs/densities/heat_kernel_so3.md` and `docs/densities/bingham.md`.

use crate::bingham::Bingham;
use crate::eigen::bounded_eigen;
use crate::error::DensityError;
use crate::gaussian::within_scale;
use crate::heat_kernel::HeatKernelSo3;
use crate::manifold_gaussian::ManifoldGaussian;
use crate::quadrature;
use crate::traits::{Density, Rotate};
use liebayes_manifolds::{LieGroup, So3, Su2};
use nalgebra::{Matrix3, SymmetricEigen, Vector3};
use nalgebra::{Matrix4, Vector4};

impl HeatKernelSo3 {
    /// **Approximation**: the Bingham distribution with the same second moments `E[q qᵀ]` (so the same
    /// `E[R]`, the same centre and the same `E[tr R]` = 3e^(−s)). About the centre the heat kernel's quaternion
    /// has `E[w²] = E[(1 + cos t)/2] = (1 + 3e^(−s))/4` and `E[x²] = E[y²] = E[z²] = (1 − e^(−s))/4`
    /// exactly; [`Bingham::from_second_moment`] matches them. The Bingham's eigenvalue is about
    /// −2/s − 3/2 for small s (to leading order `E[x²] ≈ s/4` matches the Bingham's `−1/(2z)`), so s should stay
    /// above about 2e-12 for it to be within the Bingham's largest spread
    /// ([`MAX_SPREAD`](Bingham::MAX_SPREAD) = 1e12, the range its normaliser is verified on).
    ///
    /// # Errors
    /// Those of [`Bingham::from_second_moment`]: for s below about 2e-12, whose spread −2/s exceeds
    /// the largest a Bingham takes.
    pub fn to_bingham_moment_matched(&self) -> Result<Bingham, DensityError> {
        let decay = (-self.variance()).exp();
        let w2 = (1.0 + 3.0 * decay) / 4.0;
        let v2 = (-self.variance()).exp_m1() / -4.0; // (1 − e^(−s))/4 without cancellation
        let about_identity =
            Bingham::from_second_moment(Matrix4::from_diagonal(&Vector4::new(w2, v2, v2, v2)))?;
        about_identity.rotated(&self.mean().to_su2())
    }
}

impl Bingham {
    /// **Approximation**: the isotropic heat kernel with the same E[tr R] about the Bingham's mode:
    /// centre = mode, `e^(−s) = (4 E[(v₀ · q)²] − 1)/3 = 1 − (4/3)(m₁ + m₂ + m₃)` (the second form, with
    /// `ln_1p`, keeps the small moments' relative accuracy). Exact in the second moments for isotropic
    /// Binghams (equal z₁ = z₂ = z₃); for others it keeps only their average spread.
    ///
    /// # Errors
    /// [`DensityError::OutOfRange`] when the Bingham has no unique mode or is too diffuse for a heat
    /// kernel (`E[(v₀ · q)²] ≤ 1/4`, which only the uniform distribution reaches).
    pub fn to_heat_kernel_moment_matched(&self) -> Result<HeatKernelSo3, DensityError> {
        let mode = self.mode().ok_or(DensityError::OutOfRange {
            what: "gap between the two largest Bingham eigenvalues",
            value: self.eigenvalues()[0] - self.eigenvalues()[1],
            range: "(0, infinity): a heat kernel needs a unique mode",
        })?;
        let spread = self.eigen_moments().iter().skip(1).sum::<f64>();
        let trace_ratio = 1.0 - 4.0 / 3.0 * spread;
        if trace_ratio <= 0.0 {
            return Err(DensityError::OutOfRange {
                what: "second moment along the Bingham mode",
                value: 1.0 - spread,
                range: "(1/4, 1]",
            });
        }
        HeatKernelSo3::new(Su2::to_so3(&mode), -(-4.0 / 3.0 * spread).ln_1p())
    }
}

/// The eigendecomposition of a symmetric 3 × 3 matrix `m` ([`bounded_eigen`]).
///
/// # Errors
/// [`DensityError::OutOfRange`] naming `what` when it does not converge within its bound or is not
/// finite.
fn eigen3(
    what: &'static str,
    m: Matrix3<f64>,
) -> Result<SymmetricEigen<f64, nalgebra::U3>, DensityError> {
    bounded_eigen(m).ok_or_else(|| DensityError::OutOfRange {
        what,
        value: m.amax(),
        range: "symmetric matrices whose eigendecomposition converges in f64",
    })
}

/// `E[q qᵀ]` of `q = exp(ξ)`, `ξ ~ N(0, Σ)`, by a 16-point-per-axis Gauss-Hermite cubature in the
/// eigenbasis of Σ (4096 points, exact for polynomials of degree 31 in ξ: to rounding for σ up to tens of
/// degrees).
///
/// # Errors
/// [`DensityError::OutOfRange`] when the eigendecomposition of Σ does not converge (see
/// [`eigen3`]).
fn quaternion_moments(covariance: &Matrix3<f64>) -> Result<Matrix4<f64>, DensityError> {
    let eigen = eigen3("tangent covariance of the moment match", *covariance)?;
    let scale = eigen.eigenvalues.map(|l| l.max(0.0).sqrt());
    let rule = quadrature::gauss_hermite();
    let mut moments = Matrix4::zeros();
    for (a, wa) in rule {
        for (b, wb) in rule {
            for (c, wc) in rule {
                let xi =
                    eigen.eigenvectors * Vector3::new(a * scale[0], b * scale[1], c * scale[2]);
                let [w, x, y, z] = Su2::exp(&xi).to_quaternion_wxyz();
                let q = Vector4::new(w, x, y, z);
                moments += q * q.transpose() * (wa * wb * wc);
            }
        }
    }
    Ok(moments)
}

fn vector_block(moments: &Matrix4<f64>) -> Matrix3<f64> {
    Matrix3::from_fn(|r, c| moments[(r + 1, c + 1)])
}

impl ManifoldGaussian<So3<f64>, 3> {
    /// **Approximation**: the Bingham with the same second moments `E[q qᵀ]` as `q = μ exp(ξ)`,
    /// `ξ ~ N(0, Σ)` (computed by Gauss-Hermite cubature), fitted with
    /// [`Bingham::from_second_moment`]. The measured KL is in `docs/densities/bingham.md`.
    ///
    /// # Errors
    /// Those of [`Bingham::from_second_moment`], and [`DensityError::OutOfRange`] should the
    /// eigendecomposition of the covariance not converge within its bound of iterations.
    pub fn to_bingham_moment_matched(&self) -> Result<Bingham, DensityError> {
        Bingham::from_second_moment(quaternion_moments(self.covariance())?)?
            .rotated(&self.mean().to_su2())
    }
}

impl Bingham {
    /// **Approximation**: the Gaussian in the tangent space at the Bingham's mode whose quaternion
    /// second moments about the mode match the Bingham's: Σ solves `E_Σ[v vᵀ] = E_Bingham[v vᵀ]` (v the
    /// vector part of `mode⁻¹ q`), by the fixed-point iteration `Σ ← Σ + 4 (E_B[v vᵀ] − E_Σ[v vᵀ])` from `4 E_B[v vᵀ]`
    /// (the leading order, v ≈ ξ/2), to a relative residual of 1e-12. The Bingham's other moments
    /// (the scalar block, and the cross terms, zero by symmetry for both) then agree too, as the
    /// trace is 1.
    ///
    /// # Errors
    /// [`DensityError::OutOfRange`] when the Bingham has no unique mode, or when it is too diffuse for
    /// the iteration to reach the residual in 250 steps (the iteration slows as a second
    /// moment of v approaches about 0.24, the largest `E_Σ[vᵢ²]` any Σ gives: spreads beyond about
    /// 60°, such as eigenvalue gaps of 0.2).
    pub fn to_manifold_gaussian_moment_matched(
        &self,
    ) -> Result<ManifoldGaussian<So3<f64>, 3>, DensityError> {
        let mode = self.mode().ok_or(DensityError::OutOfRange {
            what: "gap between the two largest Bingham eigenvalues",
            value: self.eigenvalues()[0] - self.eigenvalues()[1],
            range: "(0, infinity): a manifold Gaussian needs a unique mode",
        })?;
        let target = vector_block(&self.rotated(&mode.inverse())?.second_moment());
        let mut covariance = target * 4.0;
        let mut relative = f64::INFINITY;
        for _ in 0..MATCH_STEPS {
            let residual = target - vector_block(&quaternion_moments(&covariance)?);
            relative = residual.amax() / target.amax();
            if relative <= 1e-12 {
                return ManifoldGaussian::new(mode.to_so3(), covariance);
            }
            covariance += residual * 4.0;
        }
        Err(DensityError::OutOfRange {
            what: "relative residual of the Gaussian's second-moment match",
            value: relative,
            range: "[0, 1e-12]: the Bingham is too diffuse for a tangent Gaussian (its vector-part \
                    second moments near or beyond the largest a Gaussian reaches, about 0.24)",
        })
    }
}

/// The most fixed-point steps of [`Bingham::to_manifold_gaussian_moment_matched`] (each a cubature
/// of 4096 points): its contraction factor is 1 − 4 dE[vᵢ²]/dσᵢ, 0.87 at σ = 2 rad², so that a
/// match it can reach takes at most about 200 steps.
const MATCH_STEPS: usize = 250;

/// Accepted asymmetry of a diffusion covariance, relative to its largest entry.
const SYMMETRY_TOLERANCE: f64 = 1e-10;

/// Negative eigenvalues of a diffusion covariance taken for the rounding of a zero one, relative to
/// the largest eigenvalue magnitude: 64 ε, above the few ε of a symmetric eigendecomposition's
/// error.
const PSD_ROUNDING: f64 = 64.0 * f64::EPSILON;

/// The eigendecomposition of a diffusion covariance Σ, checked finite, within
/// [`MAX_SCALE`](crate::MAX_SCALE) = 1e100 rad² (the limit of every Gaussian; a diffusion is
/// uniform to rounding long before), symmetric (`|Σ − Σᵀ| ≤ 1e-10 max|Σᵢⱼ|`) and positive
/// semi-definite to rounding: eigenvalues down to `−64 ε max|λ|` (1.4e-14 of the largest
/// magnitude) are rounded up to 0, and any below refused, at every scale (an absolute floor of
/// `−1e-12 (1 + max|Σᵢⱼ|)` took `diag(−1e-13, 1e-20, 1e-20)` for positive semi-definite).
fn diffusion_eigen(
    covariance: &Matrix3<f64>,
) -> Result<(Vector3<f64>, Matrix3<f64>), DensityError> {
    for &v in covariance.iter() {
        crate::error::finite("diffusion covariance entry", v)?;
    }
    within_scale("diffusion covariance (rad^2)", covariance)?;
    let scale = covariance.amax();
    let asymmetry = (covariance - covariance.transpose()).amax();
    if asymmetry > SYMMETRY_TOLERANCE * scale {
        return Err(DensityError::OutOfRange {
            what: "asymmetry of the diffusion covariance",
            value: asymmetry,
            range: "symmetric matrices (rad^2)",
        });
    }
    let eigen = eigen3(
        "diffusion covariance",
        covariance * 0.5 + covariance.transpose() * 0.5,
    )?;
    let smallest = eigen.eigenvalues.min();
    if smallest < -PSD_ROUNDING * eigen.eigenvalues.amax() {
        return Err(DensityError::OutOfRange {
            what: "smallest eigenvalue of the diffusion covariance",
            value: smallest,
            range: "[0, infinity): a positive semi-definite matrix (rad^2)",
        });
    }
    Ok((eigen.eigenvalues.map(|v| v.max(0.0)), eigen.eigenvectors))
}

impl Bingham {
    /// The second-moment matrix `E[q qᵀ]` of the left-translated anisotropic diffusion `LD(1, Σ)`
    /// about the identity: the unit quaternion of the Brownian motion `dR = R [dW]ₓ` on SO(3) with
    /// body-frame increments of covariance Σ per unit time, at time 1 (equivalently the limit of
    /// the random walk `q ← q exp(ξ/2)`, `ξ ~ N(0, Σ/n)`, after n steps). Exact: the rotation's
    /// first moment is `E[R] = expm((Σ − tr Σ I)/2)`, so along an eigenvector of Σ (eigenvalue
    /// σᵢ²) it is `eᵢ = exp(−(σⱼ² + σₖ²)/2)`; with `dᵢ = 1 − eᵢ`, the quaternion's moments are
    /// `E[w²] = 1 − (d₁ + d₂ + d₃)/4`, `E[uᵢ²] = (dⱼ + dₖ − dᵢ)/4` along the eigenvectors, and the
    /// cross terms zero. Computed with `exp_m1`, so tiny variances keep their relative accuracy.
    /// For `LD(q̄, Σ)` the moments are `L(q̄) E[q qᵀ] L(q̄)ᵀ`, L the left multiplication.
    ///
    /// # Errors
    /// [`DensityError::NonFinite`] for a non-finite entry; [`DensityError::OutOfRange`] for an
    /// entry above 1e100, a non-symmetric Σ or a negative eigenvalue.
    pub fn diffusion_second_moment(
        covariance: &Matrix3<f64>,
    ) -> Result<Matrix4<f64>, DensityError> {
        let (values, vectors) = diffusion_eigen(covariance)?;
        let total: f64 = values.sum();
        let d = values.map(|v| -(-(total - v) / 2.0).exp_m1());
        let sum_d = d.sum();
        let mut moments = Matrix4::zeros();
        moments[(0, 0)] = 1.0 - sum_d / 4.0;
        let diagonal = d.map(|di| (sum_d - 2.0 * di) / 4.0);
        let block = vectors * Matrix3::from_diagonal(&diagonal) * vectors.transpose();
        for i in 0..3 {
            for j in 0..3 {
                moments[(i + 1, j + 1)] = block[(i, j)];
            }
        }
        Ok(moments)
    }

    /// **Approximation**: the Bingham with the second moments of the left-translated diffusion
    /// `LD(mean, Σ)` (`R = R(mean) exp([ξ]ₓ)`, ξ the Brownian motion of
    /// [`diffusion_second_moment`](Self::diffusion_second_moment)): those moments fitted by
    /// [`Bingham::from_second_moment`] about the identity, then turned to `mean` (`q ↦ mean q`).
    /// Exact in the second moments (to the fit's 1e-11, relative). For an isotropic Σ = s I it is
    /// [`HeatKernelSo3::to_bingham_moment_matched`]. Range: Σ positive semi-definite with every
    /// `σⱼ² + σₖ²` above about 4e-6 rad² (the Bingham's [`MAX_SPREAD`](Self::MAX_SPREAD)).
    ///
    /// # Errors
    /// As [`diffusion_second_moment`](Self::diffusion_second_moment), and those of
    /// [`Bingham::from_second_moment`] for a diffusion too concentrated for a Bingham.
    ///
    /// # Example
    /// ```
    /// use liebayes_densities::Bingham;
    /// use liebayes_manifolds::{LieGroup, Manifold, Su2};
    /// use nalgebra::{Matrix3, Vector3};
    /// let mean = Su2::exp(&Vector3::new(0.5, 0.0, -0.3));
    /// let sigma = Matrix3::from_diagonal(&Vector3::new(0.01, 0.02, 0.04));
    /// let bingham = Bingham::from_diffusion_moment_matched(&mean, &sigma).unwrap();
    /// // Matching back gives the diffusion again.
    /// let (back, back_sigma) = bingham.to_diffusion_moment_matched().unwrap();
    /// assert!(back.distance(&mean) < 1e-9);
    /// assert!((back_sigma - sigma).amax() < 1e-9);
    /// ```
    pub fn from_diffusion_moment_matched(
        mean: &Su2<f64>,
        covariance: &Matrix3<f64>,
    ) -> Result<Self, DensityError> {
        let moments = Self::diffusion_second_moment(covariance)?;
        Self::from_second_moment(moments)?.rotated(mean)
    }

    /// **Approximation**: the left-translated diffusion `LD(q̄, Σ)` with the second moments of the
    /// Bingham, the inverse of [`from_diffusion_moment_matched`](Self::from_diffusion_moment_matched):
    /// q̄ the mode (w ≥ 0) and, with U the vector block of `E[p pᵀ]` for `p = q̄⁻¹ q`, in U's
    /// eigenbasis `dᵢ = 2(Uⱼⱼ + Uₖₖ)`, `ln eᵢ = ln(1 − dᵢ)`, `tr Σ = −Σ ln eᵢ` and
    /// `σᵢ² = 2 ln eᵢ + tr Σ`. For an isotropic Bingham it is the heat kernel of
    /// [`to_heat_kernel_moment_matched`](Self::to_heat_kernel_moment_matched). The covariance
    /// returned is symmetric positive definite (its Cholesky factorisation succeeds).
    ///
    /// # Errors
    /// [`DensityError::OutOfRange`] when the Bingham has no unique mode, is too diffuse for a
    /// diffusion (a `dᵢ ≥ 1`), or too anisotropic (its moments are those of no diffusion: a
    /// `σᵢ² ≤ 0`, or a covariance that is not numerically positive definite).
    pub fn to_diffusion_moment_matched(&self) -> Result<(Su2<f64>, Matrix3<f64>), DensityError> {
        let mode = self.mode().ok_or(DensityError::OutOfRange {
            what: "gap between the two largest Bingham eigenvalues",
            value: self.eigenvalues()[0] - self.eigenvalues()[1],
            range: "(0, infinity): a diffusion needs a unique mode",
        })?;
        let about = self.rotated(&mode.inverse())?;
        let s = about.second_moment();
        let block = Matrix3::from_fn(|r, c| 0.5 * (s[(r + 1, c + 1)] + s[(c + 1, r + 1)]));
        let eigen = eigen3("vector moments of the Bingham about its mode", block)?;
        let u = eigen.eigenvalues;
        let d = Vector3::new(
            2.0 * (u[1] + u[2]),
            2.0 * (u[0] + u[2]),
            2.0 * (u[0] + u[1]),
        );
        if let Some(&di) = d.iter().find(|&&di| !(0.0..1.0).contains(&di)) {
            return Err(DensityError::OutOfRange {
                what: "decay 2(U_jj + U_kk) of the Bingham's vector moments about its mode",
                value: di,
                range: "[0, 1): a Bingham concentrated enough for a diffusion",
            });
        }
        let log_e = d.map(|di| (-di).ln_1p());
        let total = -log_e.sum();
        let variances = log_e.map(|l| 2.0 * l + total);
        let smallest = variances.min();
        let not_definite = DensityError::OutOfRange {
            what: "smallest variance of the matched diffusion (rad^2)",
            value: smallest,
            range: "(0, infinity): a Bingham whose moments are those of a diffusion",
        };
        if smallest.is_nan() || smallest <= 0.0 {
            return Err(not_definite);
        }
        let covariance = eigen.eigenvectors
            * Matrix3::from_diagonal(&variances)
            * eigen.eigenvectors.transpose();
        let covariance = (covariance + covariance.transpose()) * 0.5;
        if covariance.cholesky().is_none() {
            return Err(not_definite);
        }
        Ok((mode, covariance))
    }
}
