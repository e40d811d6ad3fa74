//! Rao-Blackwellized composites: a density `p(x, y) = p(y) p(x | y)` over an angle y and a vector x.
//!
//! * The closed-form family is the densities crate's [`HarmonicGaussian`]: `p(y)` a generalised von
//!   Mises of order 2 and `p(x | y) = N(B φ(y), Σ)` with the features `φ(y) = (1, cos y, sin y)` and Σ
//!   the same for every y. This module holds its exact steps: linear processes and two kinds of
//!   measurement keep the form (see below); the seven-number azimuth-alignment filter is the special case
//!   `B = [a, c, −c^×]`, `Σ = σ² I`, η₂ = 0.
//! * The general fallback is the marginalized particle filter: a
//!   [`ParticleSet`](crate::particle::ParticleSet) of `(y, p(x | y))` conditioned with
//!   [`Given`](crate::particle::Given), each density of x conditioned exactly with the model of its
//!   particle's angle and weighted by that conditioning's log evidence (and the grid of
//!   [`CircularGrid`](crate::grid::CircularGrid) the same way, at fixed angles).
//!
//! The exact operations on a [`HarmonicGaussian`] (derivations in `docs/operators/rao_blackwell.md`):
//!
//! * **propagate** through `x′ = F x + u + w`, `w ~ N(0, Q)` ([`LinearProcess`]): `B ← F B + u e₀ᵀ`,
//!   `Σ ← F Σ Fᵀ + Q` (raised to its rounding when that leaves it singular, as the
//!   [Kalman filter](crate::kalman)'s prediction); p(y) unchanged.
//! * **condition** on `z = H x + n`, `n ~ N(0, R)` with H independent of y ([`LinearMeasurement`]):
//!   with `G = H B`, `S = H Σ Hᵀ + R`, `W = Gᵀ S⁻¹ G`, `g = Gᵀ S⁻¹ z`:
//!   `η₁ += (g₁ − W₀₁, g₂ − W₀₂)`, `η₂ += (−(W₁₁ − W₂₂)/4, −W₁₂/2)`; the Kalman gain `K = Σ Hᵀ S⁻¹`
//!   does not depend on y, so `B ← (I − K H) B + K z e₀ᵀ` and Σ by Joseph's form.
//! * **condition** on `z = R(y) H x + n`, `n ~ N(0, σ_m² I₂)`, R(y) the plane rotation
//!   ([`RotatedMeasurement`]), provided `H Σ Hᵀ = s I₂` is isotropic: then `S = (s + σ_m²) I` and
//!   `K(y) = Σ Hᵀ R(y)ᵀ / S`, so that `K(y) z = Σ Hᵀ (cos y z − sin y z^×) / S` is again linear in φ and
//!   `Σ⁺ = Σ − Σ Hᵀ H Σ / S` is independent of y (computed in Joseph's form
//!   `(I − K̄ H) Σ (I − K̄ H)ᵀ + σ_m² K̄ K̄ᵀ`, `K̄ = Σ Hᵀ / S`, equal to it here, which keeps σ_m² below
//!   the rounding of s). The exponent `−|z − R(y) H B φ|² / (2S)` is a
//!   trigonometric polynomial of order 2 in y. When `H Σ Hᵀ` is not isotropic, Σ⁺ depends on y and the
//!   family is not closed: the step refuses with [`OperatorError::NotClosed`].
//!
//! A conditioning step whose angle would be more concentrated than the generalised von Mises family
//! allows (`κ₁ + 4κ₂` up to [`GenVonMises2::MAX_CONCENTRATION`] = 1e16) is refused with the density's
//! error, and the composite is left as it was.
//!
//! Each conditioning returns the exact log evidence
//! `ln p(z) = constant + ln Z(η⁺) − ln Z(η)` with Z the [`GenVonMises2`] normaliser, and reports `()`.

use crate::error::all_finite;
use crate::kalman::{LinearMeasurement, LinearProcess, joseph, predicted};
use crate::numerics::symmetric_part;
use crate::{Condition, Conditioned, OperatorError, Propagate};
use liebayes_densities::{Density, GenVonMises2, HarmonicGaussian};
use nalgebra::{Cholesky, SMatrix, SVector, Vector2};
use std::f64::consts::PI;

/// A measurement's log-likelihood as a function of the angle, after x is integrated out:
/// `ln p(z | y, past) = constant + η₁ · u(y) + η₂ · u(2y)`, `u(y) = (cos y, sin y)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Harmonics {
    /// The y-independent part.
    pub constant: f64,
    /// First-harmonic coefficients.
    pub eta1: Vector2<f64>,
    /// Second-harmonic coefficients.
    pub eta2: Vector2<f64>,
}

impl Harmonics {
    /// The log-likelihood at y: finite, or the exact value's ±∞ where it overflows f64 (the terms
    /// are summed scaled by 1/8, exactly, so that no partial sum overflows before the total).
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] for a non-finite y or coefficient.
    pub fn at(&self, y: f64) -> Result<f64, OperatorError> {
        all_finite("angle y", [y].iter())?;
        all_finite(
            "harmonics coefficients",
            [self.constant].iter().chain(&self.eta1).chain(&self.eta2),
        )?;
        let (s, c) = y.sin_cos();
        // From the single angle: 2y overflows for |y| beyond f64::MAX / 2.
        let (s2, c2) = (2.0 * s * c, (c - s) * (c + s));
        let eighth = |v: &Vector2<f64>| v / 8.0;
        let scaled = self.constant / 8.0
            + eighth(&self.eta1).dot(&Vector2::new(c, s))
            + eighth(&self.eta2).dot(&Vector2::new(c2, s2));
        Ok(8.0 * scaled)
    }

    /// The harmonics, if every coefficient is finite.
    fn finite(self) -> Result<Self, OperatorError> {
        all_finite(
            "measurement's harmonics of the angle (they overflow: the measurement or the \
             composite is too large for its noise)",
            [self.constant].iter().chain(&self.eta1).chain(&self.eta2),
        )?;
        Ok(self)
    }
}

/// `z = R(y) H x + n`, `n ~ N(0, σ_m² I₂)`: a 2-vector of x seen in a frame turned by the angle y.
#[derive(Clone, Debug, PartialEq)]
pub struct RotatedMeasurement<const N: usize> {
    matrix: SMatrix<f64, 2, N>,
    variance: f64,
}

impl<const N: usize> RotatedMeasurement<N> {
    /// The measurement with matrix H (2 × N) and noise standard deviation σ_m, in
    /// [1.5e-154, 1.3e154] so that σ_m² is a positive normal number (a σ_m² that underflows to zero
    /// or a subnormal would make the innovation variance lose its meaning).
    ///
    /// # Errors
    /// [`OperatorError::NonFinite`] for a non-finite H, [`OperatorError::OutOfRange`] for σ_m
    /// outside that range.
    pub fn new(matrix: SMatrix<f64, 2, N>, sigma: f64) -> Result<Self, OperatorError> {
        all_finite("rotated measurement matrix H", matrix.iter())?;
        if !(sigma > 0.0 && (sigma * sigma).is_normal()) {
            return Err(OperatorError::OutOfRange {
                what: "rotated measurement noise standard deviation sigma_m",
                value: sigma,
                range: "[1.5e-154, 1.3e154] (sigma_m^2 must be a positive normal number)",
            });
        }
        Ok(Self {
            matrix,
            variance: sigma * sigma,
        })
    }

    /// H.
    pub fn matrix(&self) -> &SMatrix<f64, 2, N> {
        &self.matrix
    }

    /// σ_m².
    pub fn variance(&self) -> f64 {
        self.variance
    }
}

/// `u^× = (−u_y, u_x)`.
fn perp(u: &Vector2<f64>) -> Vector2<f64> {
    Vector2::new(-u.y, u.x)
}

/// `a × b = a_x b_y − a_y b_x`.
fn cross(a: &Vector2<f64>, b: &Vector2<f64>) -> f64 {
    a.x * b.y - a.y * b.x
}

/// `ln p(z | y, past)` of a y-independent linear measurement, as harmonics of y (see the module docs).
///
/// # Errors
/// [`OperatorError::NonFinite`] for a non-finite z or harmonics that overflow,
/// [`OperatorError::NotPositiveDefinite`] when `S = H Σ Hᵀ + R` is not.
pub fn linear_harmonics<const N: usize, const M: usize>(
    density: &HarmonicGaussian<N>,
    model: &LinearMeasurement<N, M>,
    z: &SVector<f64, M>,
) -> Result<Harmonics, OperatorError> {
    Ok(linear_step(density, model, z)?.0)
}

/// `ln p(z | y, past)` of a rotated measurement, as harmonics of y (see the module docs).
///
/// # Errors
/// [`OperatorError::NonFinite`] for a non-finite z or harmonics that overflow,
/// [`OperatorError::NotClosed`] when `H Σ Hᵀ` is not isotropic.
pub fn rotated_harmonics<const N: usize>(
    density: &HarmonicGaussian<N>,
    model: &RotatedMeasurement<N>,
    z: &Vector2<f64>,
) -> Result<Harmonics, OperatorError> {
    Ok(rotated_step(density, model, z)?.0)
}
/// The harmonics and the gain of a linear measurement.
fn linear_step<const N: usize, const M: usize>(
    density: &HarmonicGaussian<N>,
    model: &LinearMeasurement<N, M>,
    z: &SVector<f64, M>,
) -> Result<(Harmonics, SMatrix<f64, N, M>), OperatorError> {
    all_finite("measurement z", z.iter())?;
    let h = model.matrix();
    let s = h * density.covariance() * h.transpose() + model.noise();
    let factor = Cholesky::new(symmetric_part(&s)).ok_or(OperatorError::NotPositiveDefinite {
        what: "innovation covariance H Sigma H^T + R (make R positive definite)",
    })?;
    let g_matrix = h * density.features();
    let w = g_matrix.transpose() * factor.solve(&g_matrix);
    let s_inv_z = factor.solve(z);
    let g = g_matrix.transpose() * s_inv_z;
    let log_det = 2.0 * factor.l().diagonal().iter().map(|d| d.ln()).sum::<f64>();
    let harmonics = Harmonics {
        constant: -0.5 * z.dot(&s_inv_z) + g[0]
            - 0.5 * w[(0, 0)]
            - 0.25 * (w[(1, 1)] + w[(2, 2)])
            - 0.5 * (log_det + M as f64 * (2.0 * PI).ln()),
        eta1: Vector2::new(g[1] - w[(0, 1)], g[2] - w[(0, 2)]),
        eta2: Vector2::new(-0.25 * (w[(1, 1)] - w[(2, 2)]), -0.5 * w[(1, 2)]),
    }
    .finite()?;
    let gain = factor.solve(&(h * density.covariance())).transpose();
    Ok((harmonics, gain))
}

/// The harmonics and `S = s + σ_m²` of a rotated measurement.
fn rotated_step<const N: usize>(
    density: &HarmonicGaussian<N>,
    model: &RotatedMeasurement<N>,
    z: &Vector2<f64>,
) -> Result<(Harmonics, f64), OperatorError> {
    all_finite("measurement z", z.iter())?;
    let h = &model.matrix;
    let projected = h * density.covariance() * h.transpose();
    let s_iso = 0.5 * projected.trace();
    let anisotropy = (projected - SMatrix::<f64, 2, 2>::identity() * s_iso).amax();
    if anisotropy > 1e-10 * s_iso {
        return Err(OperatorError::NotClosed {
            what: "H Sigma H^T of a rotated measurement is not isotropic, so the posterior \
                       covariance would depend on the angle; use the grid or the marginalized \
                       particle filter",
            value: anisotropy / s_iso,
        });
    }
    let s = s_iso + model.variance;
    let g = h * density.features();
    let (b0, b1, b2) = (
        Vector2::new(g[(0, 0)], g[(1, 0)]),
        Vector2::new(g[(0, 1)], g[(1, 1)]),
        Vector2::new(g[(0, 2)], g[(1, 2)]),
    );
    let harmonics = Harmonics {
        constant: -(2.0 * PI * s).ln()
            - (z.norm_squared() - z.dot(&b1) - cross(&b2, z)
                + b0.norm_squared()
                + 0.5 * (b1.norm_squared() + b2.norm_squared()))
                / (2.0 * s),
        eta1: Vector2::new(z.dot(&b0) - b0.dot(&b1), cross(&b0, z) - b0.dot(&b2)) / s,
        eta2: Vector2::new(
            0.5 * (z.dot(&b1) - cross(&b2, z)) - 0.25 * (b1.norm_squared() - b2.norm_squared()),
            0.5 * (cross(&b1, z) + z.dot(&b2)) - 0.5 * b1.dot(&b2),
        ) / s,
    }
    .finite()?;
    Ok((harmonics, s))
}

/// The composite a step returns, if every number in it is finite (a product that overflows is
/// refused, not carried on).
fn checked<const N: usize, E>(
    g: Result<HarmonicGaussian<N>, E>,
) -> Result<HarmonicGaussian<N>, OperatorError>
where
    OperatorError: From<E>,
{
    let g = g?;
    let (eta1, eta2) = g.angle().natural();
    all_finite(
        "composite after the step (its features B or covariance Sigma overflow)",
        g.features()
            .iter()
            .chain(g.covariance().iter())
            .chain(eta1.iter())
            .chain(eta2.iter()),
    )?;
    Ok(g)
}

/// p(y) multiplied by `exp(harmonics)`, and the log evidence `constant + ln Z(η⁺) − ln Z(η)`.
fn reweighted_angle(
    prior: &GenVonMises2,
    h: &Harmonics,
) -> Result<(GenVonMises2, f64), OperatorError> {
    let (eta1, eta2) = prior.natural();
    let angle = GenVonMises2::from_natural(eta1 + h.eta1, eta2 + h.eta2)?;
    let log_evidence = h.constant + angle.log_normalizer() - prior.log_normalizer();
    all_finite(
        "log evidence of the composite's measurement (it overflows: the measurement is too far \
         from its prediction for the noise)",
        [log_evidence].iter(),
    )?;
    Ok((angle, log_evidence))
}

impl<const N: usize> Propagate<LinearProcess<N>> for HarmonicGaussian<N> {
    type Input = SVector<f64, N>;

    /// `B ← F B + u e₀ᵀ`, `Σ ← F Σ Fᵀ + Q`.
    fn propagate(
        &self,
        model: &LinearProcess<N>,
        u: &SVector<f64, N>,
    ) -> Result<Self, OperatorError> {
        all_finite("process input u", u.iter())?;
        let f = model.transition();
        let mut features = f * self.features();
        features.set_column(0, &(features.column(0) + u));
        let covariance = f * self.covariance() * f.transpose() + model.noise();
        checked(predicted(
            &covariance,
            |c| Self::new(self.angle().clone(), features, c),
            Self::cholesky_factor,
        ))
    }
}

impl<const N: usize, const M: usize> Condition<LinearMeasurement<N, M>> for HarmonicGaussian<N> {
    type Measurement = SVector<f64, M>;
    type Report = ();

    /// See the module docs.
    fn condition(
        &self,
        model: &LinearMeasurement<N, M>,
        z: &SVector<f64, M>,
    ) -> Result<Conditioned<Self>, OperatorError> {
        let (harmonics, gain) = linear_step(self, model, z)?;
        let (angle, log_evidence) = reweighted_angle(self.angle(), &harmonics)?;
        let mut features = self.features() - gain * (model.matrix() * self.features());
        features.set_column(0, &(features.column(0) + gain * z));
        let covariance = joseph(self.cholesky_factor(), &gain, model.matrix(), model.noise());
        Ok(Conditioned {
            posterior: checked(Self::new(angle, features, covariance))?,
            log_evidence,
            report: (),
        })
    }
}

impl<const N: usize> Condition<RotatedMeasurement<N>> for HarmonicGaussian<N> {
    type Measurement = Vector2<f64>;
    type Report = ();

    /// See the module docs.
    fn condition(
        &self,
        model: &RotatedMeasurement<N>,
        z: &Vector2<f64>,
    ) -> Result<Conditioned<Self>, OperatorError> {
        let (harmonics, s) = rotated_step(self, model, z)?;
        let (angle, log_evidence) = reweighted_angle(self.angle(), &harmonics)?;
        // K(y) (z − R(y) H B φ) with K(y) = Σ Hᵀ R(y)ᵀ / S: R(y)ᵀ z = cos y z − sin y z^×.
        let sigma = self.covariance();
        let sigma_ht = sigma * model.matrix.transpose() / s;
        let rotated_z = SMatrix::<f64, 2, 3>::from_columns(&[Vector2::zeros(), *z, -perp(z)]);
        let features = self.features() + sigma_ht * (rotated_z - model.matrix * self.features());
        // Joseph's form (I − K̄H) Σ (I − K̄H)ᵀ + σ_m² K̄ K̄ᵀ, K̄ = Σ Hᵀ / S: with H Σ Hᵀ = s I it
        // equals Σ − K̄ H Σ, which cancels to zero or below for σ_m² under the rounding of s.
        let noise = SMatrix::<f64, 2, 2>::identity() * model.variance;
        let covariance = joseph(self.cholesky_factor(), &sigma_ht, &model.matrix, &noise);
        Ok(Conditioned {
            posterior: checked(Self::new(angle, features, covariance))?,
            log_evidence,
            report: (),
        })
    }
}
