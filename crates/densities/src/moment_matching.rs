//! Named approximations between the SO(3) families, by matching second moments of the unit quaternion.
//! Their errors, measured against concentration, are in `docs/densities/heat_kernel_so3.md`.

use crate::bingham::Bingham;
use crate::error::DensityError;
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
    /// above about 2e-4 for it to lie in the range the Bingham normaliser is verified on (eigenvalues
    /// down to −1e4).
    ///
    /// # Errors
    /// Those of [`Bingham::from_second_moment`] (never for finite s > 0 in practice).
    pub fn to_bingham_moment_matched(&self) -> Result<Bingham, DensityError> {
        let decay = (-self.variance()).exp();
        let w2 = (1.0 + 3.0 * decay) / 4.0;
        let v2 = (-self.variance()).exp_m1() / -4.0; // (1 − e^(−s))/4 without cancellation
        let about_identity =
            Bingham::from_second_moment(Matrix4::from_diagonal(&Vector4::new(w2, v2, v2, v2)))?;
        Ok(about_identity.rotated(&self.mean().to_su2()))
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

/// `E[q qᵀ]` of `q = exp(ξ)`, `ξ ~ N(0, Σ)`, by a 16-point-per-axis Gauss-Hermite cubature in the
/// eigenbasis of Σ (4096 points, exact for polynomials of degree 31 in ξ: to rounding for σ up to tens of
/// degrees).
fn quaternion_moments(covariance: &Matrix3<f64>) -> Matrix4<f64> {
    let eigen = SymmetricEigen::new(*covariance);
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
    moments
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
    /// Those of [`Bingham::from_second_moment`].
    pub fn to_bingham_moment_matched(&self) -> Result<Bingham, DensityError> {
        Ok(
            Bingham::from_second_moment(quaternion_moments(self.covariance()))?
                .rotated(&self.mean().to_su2()),
        )
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
    /// the iteration to stay positive definite (spreads beyond about 60°).
    pub fn to_manifold_gaussian_moment_matched(
        &self,
    ) -> Result<ManifoldGaussian<So3<f64>, 3>, DensityError> {
        let mode = self.mode().ok_or(DensityError::OutOfRange {
            what: "gap between the two largest Bingham eigenvalues",
            value: self.eigenvalues()[0] - self.eigenvalues()[1],
            range: "(0, infinity): a manifold Gaussian needs a unique mode",
        })?;
        let target = vector_block(&self.rotated(&mode.inverse()).second_moment());
        let mut covariance = target * 4.0;
        for _ in 0..50 {
            let residual = target - vector_block(&quaternion_moments(&covariance));
            if residual.amax() <= 1e-12 * target.amax() {
                break;
            }
            covariance += residual * 4.0;
        }
        ManifoldGaussian::new(mode.to_so3(), covariance)
    }
}
