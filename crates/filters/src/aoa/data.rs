//! [`DataModel`]: how simulated readings are drawn from the true directions (the paper's Model I
//! and Model II).

use super::direction::AzEl;
use super::noise::{check_kappa, check_sigma};
use liebayes_densities::{Density, VonMisesFisher};
use liebayes_manifolds::S2;
use liebayes_operators::OperatorError;
use nalgebra::Vector3;
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};

/// The distribution of a reading given the true direction (a unit vector in the anchor's axes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DataModel {
    /// Model I: normal errors in azimuth and elevation, `(az₀ + σ_az n₁, el₀ + σ_el n₂)`, reduced
    /// to one representation ([`AzEl::canonical`]: flipped over a pole).
    NormalWithFlip {
        /// σ_az (rad).
        sigma_az: f64,
        /// σ_el (rad).
        sigma_el: f64,
    },
    /// Model II: the reading's unit vector drawn from `VMF(true direction, κ)`.
    VonMisesFisher {
        /// κ.
        kappa: f64,
    },
}

impl DataModel {
    /// Checks the parameters (σ in [`SIGMA_RANGE`](super::SIGMA_RANGE), κ in
    /// [`KAPPA_RANGE`](super::KAPPA_RANGE)).
    ///
    /// # Errors
    /// As [`check_sigma`] and [`check_kappa`].
    pub fn validate(&self) -> Result<(), OperatorError> {
        match *self {
            DataModel::NormalWithFlip { sigma_az, sigma_el } => {
                check_sigma("data azimuth standard deviation sigma_az (rad)", sigma_az)?;
                check_sigma("data elevation standard deviation sigma_el (rad)", sigma_el)?;
            }
            DataModel::VonMisesFisher { kappa } => {
                check_kappa(kappa)?;
            }
        }
        Ok(())
    }

    /// `"Model I"` or `"Model II"`.
    pub fn name(&self) -> &'static str {
        match self {
            DataModel::NormalWithFlip { .. } => "Model I",
            DataModel::VonMisesFisher { .. } => "Model II",
        }
    }

    /// A reading of the true unit direction `direction` (anchor axes), canonical: Model I adds
    /// `σ n` (n standard normal) to its azimuth and elevation and reduces the result, Model II draws
    /// a unit vector from `VMF(direction, κ)`.
    ///
    /// The fields are public, so they are checked here ([`validate`](Self::validate)) rather than
    /// trusted: a NaN σ would give NaN readings, and a κ outside [`KAPPA_RANGE`](super::KAPPA_RANGE)
    /// has no von Mises-Fisher distribution to draw from. The direction is checked too: a reading
    /// is drawn about a unit vector.
    ///
    /// # Errors
    /// As [`validate`](Self::validate); [`OperatorError::Manifold`] for a direction that is not
    /// finite or not of unit norm (normalise it first, e.g. with `S2::from_vector_normalizing`).
    pub fn sample<R: Rng + ?Sized>(
        &self,
        direction: &Vector3<f64>,
        rng: &mut R,
    ) -> Result<AzEl, OperatorError> {
        self.validate()?;
        let direction = S2::new(*direction).map_err(|source| OperatorError::Manifold {
            what: "the true direction of a reading (a unit vector in the anchor's axes)",
            source,
        })?;
        Ok(match *self {
            DataModel::NormalWithFlip { sigma_az, sigma_el } => {
                let truth = angles_of(direction.as_vector())?;
                let (n1, n2): (f64, f64) = (StandardNormal.sample(rng), StandardNormal.sample(rng));
                AzEl::new(
                    truth.azimuth + sigma_az * n1,
                    truth.elevation + sigma_el * n2,
                )
                .canonical()
            }
            DataModel::VonMisesFisher { kappa } => {
                // κ was validated (KAPPA_RANGE lies inside the family's range); the family's own
                // check is passed on all the same, never replaced by another distribution.
                let vmf = VonMisesFisher::new(direction, kappa)?;
                angles_of(Density::sample(&vmf, rng).as_vector())?
            }
        })
    }
}

/// The angles of a unit vector (never `None` for one: the error is kept rather than assumed away).
pub(crate) fn angles_of(u: &Vector3<f64>) -> Result<AzEl, OperatorError> {
    AzEl::of_vector(u).ok_or(OperatorError::NonFinite {
        what: "a unit direction whose angles are taken (it is zero or not finite)",
        value: u.amax(),
    })
}
