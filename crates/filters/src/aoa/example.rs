//! [`UpdateExample`]: the paper's Sec. 4.2 single measurement update, every filter beside the exact
//! posterior of its model.

use super::anchor::Anchor;
use super::direction::AzEl;
use super::filter::{
    Prior, angle_ekf, angle_particle_filter, angle_ukf, vmf_ekf, vmf_iterated_ekf,
    vmf_particle_filter, vmf_ukf,
};
use super::model::{AngleNoise, AzElModel, Position, UnitVectorModel, WorldDirections};
use super::process::RandomWalk;
use super::quadrature::exact_posterior;
use liebayes_densities::quadrature::SphereRule;
use liebayes_experiments::RecursiveFilter;
use liebayes_operators::OperatorError;
use liebayes_operators::particle::Likelihood;
use nalgebra::Vector3;
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

/// One prior, one anchor at the origin (world axes), one reading: the paper's example has the prior
/// `N((0.3, −0.3, −2), 0.75² I)`, σ = 5° (κ = 1/σ² = 131.3) and the reading `az = −π` with
/// `el = −9π/20` (corrected: 9° from the south pole, as the text describes) or the printed
/// `el = −19π/20` (literal: outside [−π/2, π/2], meaningful only through equation (3)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UpdateExample {
    /// The prior.
    pub prior: Prior,
    /// The anchor.
    pub anchor: Anchor,
    /// The angle standard deviation σ (rad) of the azimuth-elevation filters.
    pub sigma: f64,
    /// The concentration κ of the von Mises-Fisher filters.
    pub kappa: f64,
    /// The reading.
    pub reading: AzEl,
}

/// One filter's update in the example.
#[derive(Clone, Debug, PartialEq)]
pub struct UpdateRow {
    /// `exact VMF`, `EKF-AE`, `PF-VMF`, …
    pub filter: String,
    /// The posterior mean (m).
    pub mean: Vector3<f64>,
    /// `|mean − exact mean|` (m) against the exact posterior of the filter's own model (`None` for
    /// the exact rows).
    pub from_exact: Option<f64>,
    /// The angle (deg) between the posterior mean seen from the anchor and the measured direction.
    pub bearing_deg: f64,
}

impl UpdateExample {
    /// The paper's example, with the corrected (`true`) or the literal elevation.
    ///
    /// # Errors
    /// None in practice (the constructors' checks of the paper's constants).
    pub fn paper(corrected: bool) -> Result<Self, OperatorError> {
        let sigma = 5f64.to_radians();
        let elevation = if corrected {
            -9.0 * PI / 20.0
        } else {
            -19.0 * PI / 20.0
        };
        Ok(Self {
            prior: Prior::new(Vector3::new(0.3, -0.3, -2.0), 0.75)?,
            anchor: Anchor::at(Vector3::zeros())?,
            sigma,
            kappa: 1.0 / (sigma * sigma),
            reading: AzEl::new(-PI, elevation),
        })
    }

    /// Whether the reading is canonical (elevation in [−π/2, π/2]): the azimuth-elevation filters
    /// only take those.
    pub fn angles_apply(&self) -> bool {
        self.reading.check_canonical().is_ok()
    }

    /// Every filter's update beside the exact posteriors (quadrature): EKF, UKF and a particle
    /// filter of `particles` particles (drawn with `rng`) for each model, and the iterated EKF for
    /// the VMF model; the angle models only for a canonical reading.
    ///
    /// # Errors
    /// The models' and filters' errors (σ, κ out of range, a particle count of 0 or above the
    /// limit); the quadrature's.
    pub fn run(&self, particles: usize, rng: &ChaCha8Rng) -> Result<Vec<UpdateRow>, OperatorError> {
        let anchors = [self.anchor];
        let walk = RandomWalk::new(0.0, 0.0)?;
        let z = [self.reading];
        let u = self.reading.unit_vector();
        let s = *self.anchor.position();
        let bearing = |m: &Vector3<f64>| (m - s).angle(&u).to_degrees();
        let row = |filter: &str, mean: Vector3<f64>, exact: Option<&Vector3<f64>>| UpdateRow {
            filter: filter.to_owned(),
            mean,
            from_exact: exact.map(|e| (mean - e).norm()),
            bearing_deg: bearing(&mean),
        };
        let gaussian = self.prior.gaussian()?;
        let vmf = UnitVectorModel::new(anchors, self.kappa)?;
        let world = WorldDirections([u]);
        let exact = exact_posterior(
            &gaussian,
            &self.anchor,
            &u,
            |w| vmf.log_likelihood(&Position::new_unchecked(s + w), &world),
            &SphereRule::with_width(1.0 / self.kappa.sqrt())?,
        )?
        .mean;
        let mut rows = vec![row("exact VMF", exact, None)];
        let mut ekf = vmf_ekf::<1, 3>(vmf, walk, &self.prior)?;
        ekf.update(&z)?;
        rows.push(row("EKF-VMF", ekf.estimate()?.mean, Some(&exact)));
        let mut ukf = vmf_ukf::<1, 3>(vmf, walk, &self.prior)?;
        ukf.update(&z)?;
        rows.push(row("UKF-VMF", ukf.estimate()?.mean, Some(&exact)));
        let mut iterated = vmf_iterated_ekf::<1, 3>(vmf, walk, &self.prior)?;
        iterated.update(&z)?;
        rows.push(row("IEKF-VMF", iterated.estimate()?.mean, Some(&exact)));
        let mut pf = vmf_particle_filter(vmf, walk, &self.prior, particles, rng.clone())?;
        pf.update(&z)?;
        rows.push(row("PF-VMF", pf.estimate()?.mean, Some(&exact)));
        if !self.angles_apply() {
            return Ok(rows);
        }
        let noise = AngleNoise::Fixed {
            sigma_az: self.sigma,
            sigma_el: self.sigma,
        };
        let ae = AzElModel::new(anchors, noise)?;
        // Near a pole the angle likelihood is concentrated about the pole, not the reading: the
        // rule is centred there.
        let pole = Vector3::new(0.0, 0.0, self.reading.elevation.signum());
        let exact = exact_posterior(
            &gaussian,
            &self.anchor,
            &pole,
            |w| ae.log_likelihood(&Position::new_unchecked(s + w), &z),
            &SphereRule::new(256, 512, self.sigma)?,
        )?
        .mean;
        rows.push(row("exact AE", exact, None));
        let mut ekf = angle_ekf::<1, 2>(ae.clone(), walk, &self.prior)?;
        ekf.update(&z)?;
        rows.push(row("EKF-AE", ekf.estimate()?.mean, Some(&exact)));
        let mut ukf = angle_ukf::<1, 2>(ae.clone(), walk, &self.prior)?;
        ukf.update(&z)?;
        rows.push(row("UKF-AE", ukf.estimate()?.mean, Some(&exact)));
        let mut pf = angle_particle_filter(ae, walk, &self.prior, particles, rng.clone())?;
        pf.update(&z)?;
        rows.push(row("PF-AE", pf.estimate()?.mean, Some(&exact)));
        Ok(rows)
    }
}
