//! Named approximations between the SO(3) families, by matching second moments of the unit quaternion.
//! Their errors, measured against concentration, are in `docs/densities/heat_kernel_so3.md`.

use crate::bingham::Bingham;
use crate::error::DensityError;
use crate::heat_kernel::HeatKernelSo3;
use crate::traits::Density;
use liebayes_manifolds::Su2;
use nalgebra::{Matrix4, Vector4};

impl HeatKernelSo3 {
    /// **Approximation**: the Bingham distribution with the same second moments `E[q qᵀ]` (so the same
    /// E[R], the same centre and the same E[tr R] = 3e^(−s)). About the centre the heat kernel's quaternion
    /// has `E[w²] = E[(1 + cos t)/2] = (1 + 3e^(−s))/4` and `E[x²] = E[y²] = E[z²] = (1 − e^(−s))/4`
    /// exactly; [`Bingham::fit`] matches them. The Bingham's eigenvalue is about −2/s − 3/2 for small s
    /// (ERRATA.md), so s should stay above about 2e-4 for it to lie in the range the Bingham normaliser is
    /// verified on (eigenvalues down to −1e4).
    ///
    /// # Errors
    /// Those of [`Bingham::fit`] (never for finite s > 0 in practice).
    pub fn to_bingham_moment_matched(&self) -> Result<Bingham, DensityError> {
        let decay = (-self.variance()).exp();
        let w2 = (1.0 + 3.0 * decay) / 4.0;
        let v2 = (-self.variance()).exp_m1() / -4.0; // (1 − e^(−s))/4 without cancellation
        let about_identity = Bingham::fit(&Matrix4::from_diagonal(&Vector4::new(w2, v2, v2, v2)))?;
        Ok(about_identity.rotated_left(&self.center().to_su2()))
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
