//! The measurement models of N anchors' readings, each usable by the particle filter (as a
//! [`Likelihood`]) and by the EKF and the UKF (as a [`MeasurementModel`] of the stacked readings),
//! and the [`Conversion`]s from the readings `[AzEl; N]` to what each step takes.
//!
//! * [`UnitVectorModel`]: von Mises-Fisher noise on each reading's unit vector. The particle filter
//!   weighs `κ Σⱼ uⱼᵀ Rⱼ dⱼ` (Algorithm 1), written `κ Σⱼ vⱼ · dⱼ` with `vⱼ = Rⱼᵀ uⱼ` rotated into
//!   world axes once per update ([`WorldDirections`]); the Kalman filters use the Gaussian
//!   approximation of equation (9), `u ~ N(R d, I/κ)` stacked over the anchors (M = 3N), with
//!   Algorithm 2's Jacobian.
//! * [`AzElModel`]: the normal azimuth-elevation model, with fixed σ (AE-nominal, AE-fitted) or σ
//!   taken from [`AdaptiveSigmas`] at the predicted elevation (AE-adaptive); the Kalman filters
//!   stack `[az₁, el₁, …]` (M = 2N) with the azimuth residual wrapped.

use super::anchor::{Anchor, unit_direction};
use super::direction::AzEl;
use super::noise::{AdaptiveSigmas, AngleSigmas, check_kappa, check_sigma};
use liebayes_densities::special::vmf_log_normalizer;
use liebayes_manifolds::wrap_angle;
use liebayes_manifolds::{Rn, So3};
use liebayes_operators::particle::Likelihood;
use liebayes_operators::{Conversion, MeasurementModel, OperatorError};
use nalgebra::{Matrix3, RowVector3, SMatrix, SVector, Vector3};

/// The state of every angle-of-arrival filter: the position θ ∈ R³ (world axes, m).
pub type Position = Rn<f64, 3>;

/// The readings of N anchors, one azimuth-elevation pair each, in the anchors' order.
pub type Readings<const N: usize> = [AzEl; N];

/// The readings' unit vectors rotated into world axes, `vⱼ = Rⱼᵀ u(azⱼ, elⱼ)`: the particle
/// filter's measurement under [`UnitVectorModel`] (by rotation invariance,
/// `uⱼᵀ Rⱼ dⱼ = vⱼᵀ dⱼ`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorldDirections<const N: usize>(pub [Vector3<f64>; N]);

/// Von Mises-Fisher noise on the unit vector of each of N anchors' readings, concentration κ.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UnitVectorModel<const N: usize> {
    anchors: [Anchor; N],
    kappa: f64,
    log_normalizer: f64,
}

impl<const N: usize> UnitVectorModel<N> {
    /// The model of `anchors` with concentration κ in [`KAPPA_RANGE`](super::KAPPA_RANGE).
    ///
    /// # Errors
    /// As [`check_kappa`].
    pub fn new(anchors: [Anchor; N], kappa: f64) -> Result<Self, OperatorError> {
        let kappa = check_kappa(kappa)?;
        Ok(Self {
            anchors,
            kappa,
            log_normalizer: vmf_log_normalizer(kappa).map_err(|_| OperatorError::OutOfRange {
                what: "von Mises-Fisher concentration kappa",
                value: kappa,
                range: "[1e-12, 1e12]",
            })?,
        })
    }

    /// The anchors.
    pub fn anchors(&self) -> &[Anchor; N] {
        &self.anchors
    }

    /// κ.
    pub fn kappa(&self) -> f64 {
        self.kappa
    }

    /// The conversion of readings for the particle filter.
    pub fn in_world_axes(&self) -> InWorldAxes<N> {
        InWorldAxes(self.anchors.map(|a| *a.rotation_matrix()))
    }
}

/// `ln p(u₁…u_N | θ) = N ln C(κ) + κ Σⱼ vⱼ · dⱼ(θ)`, `C(κ) = κ/(4π sinh κ)`: the exact von
/// Mises-Fisher likelihood (a density on the product of spheres), with `dⱼ` the unit direction
/// from anchor j (taken without overflow at any distance); −∞ at an anchor.
impl<const N: usize> Likelihood<Position> for UnitVectorModel<N> {
    type Measurement = WorldDirections<N>;

    fn log_likelihood(&self, x: &Position, z: &WorldDirections<N>) -> f64 {
        let theta = x.coords();
        let mut sum = 0.0;
        for (anchor, v) in self.anchors.iter().zip(&z.0) {
            let Some(d) = unit_direction(&(theta - anchor.position())) else {
                return f64::NEG_INFINITY;
            };
            sum += v.dot(&d);
        }
        N as f64 * self.log_normalizer + self.kappa * sum
    }
}

/// Equation (9) stacked: `z = [R₁ d₁; …; R_N d_N] + n`, `n ~ N(0, I/κ)`, M = 3N, with
/// Algorithm 2's Jacobian `Rⱼ (I − dⱼ dⱼᵀ)/|θ − sⱼ|`. NaN at an anchor (the step then fails). Each
/// reading is a point of S², so the NIS has 2N degrees of freedom, not M = 3N.
impl<const N: usize, const M: usize> MeasurementModel<Position, 3, M> for UnitVectorModel<N> {
    fn predict(&self, x: &Position) -> SVector<f64, M> {
        const {
            assert!(M == 3 * N, "a unit-vector model of N anchors has M = 3N");
        };
        let mut z = SVector::<f64, M>::from_element(f64::NAN);
        for (j, anchor) in self.anchors.iter().enumerate() {
            if let Some((d, _)) = anchor.direction(x.coords()) {
                z.fixed_rows_mut::<3>(3 * j).copy_from(&d);
            }
        }
        z
    }

    fn noise(&self, _: &Position) -> SMatrix<f64, M, M> {
        SMatrix::<f64, M, M>::identity() / self.kappa
    }

    fn jacobian(&self, x: &Position) -> SMatrix<f64, M, 3> {
        let mut h = SMatrix::<f64, M, 3>::zeros();
        for (j, anchor) in self.anchors.iter().enumerate() {
            // NaN where it has none (at an anchor): the filters refuse such a Jacobian.
            let block = anchor
                .direction_jacobian(x.coords())
                .unwrap_or_else(|| Matrix3::from_element(f64::NAN));
            h.fixed_view_mut::<3, 3>(3 * j, 0).copy_from(&block);
        }
        h
    }

    /// 2N: the N readings are points of the sphere S² (a unit vector's 3 coordinates carry 2).
    fn dof(&self) -> usize {
        2 * N
    }
}

/// How an [`AzElModel`] sets its standard deviations.
#[derive(Clone, Debug, PartialEq)]
pub enum AngleNoise {
    /// The same σ_az, σ_el (rad) at every direction (AE-nominal, AE-fitted).
    Fixed {
        /// σ_az (rad).
        sigma_az: f64,
        /// σ_el (rad).
        sigma_el: f64,
    },
    /// σ_az, σ_el from the table at the predicted elevation (AE-adaptive).
    Adaptive(AdaptiveSigmas),
}

impl AngleNoise {
    /// `(σ_az, σ_el)` at elevation el (`None` for the adaptive table at a NaN elevation).
    fn at(&self, el: f64) -> Option<(f64, f64)> {
        match self {
            AngleNoise::Fixed { sigma_az, sigma_el } => Some((*sigma_az, *sigma_el)),
            AngleNoise::Adaptive(table) => table.at(el),
        }
    }
}

/// The normal azimuth-elevation model of N anchors' readings (equation (4) in each anchor's axes).
#[derive(Clone, Debug, PartialEq)]
pub struct AzElModel<const N: usize> {
    anchors: [Anchor; N],
    noise: AngleNoise,
    /// The constants of fixed σ, computed once.
    fixed: Option<AngleSigmas>,
}

impl<const N: usize> AzElModel<N> {
    /// The model of `anchors` with `noise`.
    ///
    /// # Errors
    /// A fixed σ outside [`SIGMA_RANGE`](super::SIGMA_RANGE) (as [`check_sigma`]).
    pub fn new(anchors: [Anchor; N], noise: AngleNoise) -> Result<Self, OperatorError> {
        let fixed = match noise {
            AngleNoise::Fixed { sigma_az, sigma_el } => {
                check_sigma("azimuth standard deviation sigma_az (rad)", sigma_az)?;
                check_sigma("elevation standard deviation sigma_el (rad)", sigma_el)?;
                Some(AngleSigmas::new(sigma_az, sigma_el))
            }
            AngleNoise::Adaptive(_) => None,
        };
        Ok(Self {
            anchors,
            noise,
            fixed,
        })
    }

    /// The anchors.
    pub fn anchors(&self) -> &[Anchor; N] {
        &self.anchors
    }

    /// The noise setting.
    pub fn noise_model(&self) -> &AngleNoise {
        &self.noise
    }

    /// The predicted reading of anchor j at θ: the angles of `R (θ − s)` (of the anchor's unit
    /// direction where that offset overflows); `None` at the anchor (or for a non-finite θ).
    fn predicted(anchor: &Anchor, theta: &Vector3<f64>) -> Option<AzEl> {
        anchor
            .local_offset(theta)
            .and_then(|p| AzEl::of_vector(&p))
            .or_else(|| {
                anchor
                    .direction(theta)
                    .and_then(|(d, _)| AzEl::of_vector(&d))
            })
    }
}

/// `Σⱼ ln p(yⱼ | θ)` with [`az_el_log_density`](super::az_el_log_density) at each anchor's predicted direction; −∞ at an
/// anchor or for an elevation outside [−π/2, π/2].
impl<const N: usize> Likelihood<Position> for AzElModel<N> {
    type Measurement = Readings<N>;

    fn log_likelihood(&self, x: &Position, z: &Readings<N>) -> f64 {
        let mut sum = 0.0;
        for (anchor, y) in self.anchors.iter().zip(z) {
            let Some(predicted) = Self::predicted(anchor, x.coords()) else {
                return f64::NEG_INFINITY;
            };
            let sigmas = if let Some(fixed) = self.fixed {
                fixed
            } else {
                let Some((sigma_az, sigma_el)) = self.noise.at(predicted.elevation) else {
                    return f64::NEG_INFINITY;
                };
                AngleSigmas::new(sigma_az, sigma_el)
            };
            sum += sigmas.log_density(y, &predicted);
        }
        sum
    }
}

/// Equation (4) stacked: `z = [az₁, el₁, …, az_N, el_N] + n`, M = 2N, `n ~ N(0, diag(σ_az², σ_el²,
/// …))` with σ at the predicted elevation for the adaptive model, the azimuth residual wrapped to
/// [−π, π). The Jacobian of `(az, el)` of `p = R (θ − s)`: `∂az/∂θ = (−p_y, p_x, 0) R / ρ²`,
/// `∂el/∂θ = (−p_x p_z/ρ, −p_y p_z/ρ, ρ) R / |p|²`, `ρ = √(p_x² + p_y²)`; unbounded at a pole (ρ = 0,
/// where the model is singular), NaN at an anchor.
impl<const N: usize, const M: usize> MeasurementModel<Position, 3, M> for AzElModel<N> {
    fn predict(&self, x: &Position) -> SVector<f64, M> {
        const {
            assert!(
                M == 2 * N,
                "an azimuth-elevation model of N anchors has M = 2N"
            );
        };
        let mut z = SVector::<f64, M>::from_element(f64::NAN);
        for (j, anchor) in self.anchors.iter().enumerate() {
            if let Some(y) = Self::predicted(anchor, x.coords()) {
                z[2 * j] = y.azimuth;
                z[2 * j + 1] = y.elevation;
            }
        }
        z
    }

    fn noise(&self, x: &Position) -> SMatrix<f64, M, M> {
        let mut r = SMatrix::<f64, M, M>::zeros();
        for (j, anchor) in self.anchors.iter().enumerate() {
            // NaN at an anchor, where nothing is predicted: the filters refuse such a noise.
            let (sigma_az, sigma_el) = Self::predicted(anchor, x.coords())
                .and_then(|y| self.noise.at(y.elevation))
                .unwrap_or((f64::NAN, f64::NAN));
            r[(2 * j, 2 * j)] = sigma_az * sigma_az;
            r[(2 * j + 1, 2 * j + 1)] = sigma_el * sigma_el;
        }
        r
    }

    fn residual(&self, z: &SVector<f64, M>, predicted: &SVector<f64, M>) -> SVector<f64, M> {
        let mut r = z - predicted;
        for j in 0..N {
            r[2 * j] = wrap_angle(r[2 * j]);
        }
        r
    }

    fn jacobian(&self, x: &Position) -> SMatrix<f64, M, 3> {
        let mut h = SMatrix::<f64, M, 3>::from_element(f64::NAN);
        for (j, anchor) in self.anchors.iter().enumerate() {
            let Some(p) = anchor.local_offset(x.coords()) else {
                continue;
            };
            let rho2 = p.x * p.x + p.y * p.y;
            let (rho, r2) = (rho2.sqrt(), rho2 + p.z * p.z);
            if r2.is_nan() || r2 <= 0.0 {
                continue;
            }
            let rotation: &Matrix3<f64> = anchor.rotation_matrix();
            let daz = RowVector3::new(-p.y, p.x, 0.0) / rho2 * rotation;
            let del = RowVector3::new(-p.x * p.z / rho, -p.y * p.z / rho, rho) / r2 * rotation;
            h.set_row(2 * j, &daz);
            h.set_row(2 * j + 1, &del);
        }
        h
    }
}

/// Readings to stacked unit vectors `[u₁; …; u_N]` (M = 3N), for the Kalman filters of
/// [`UnitVectorModel`]. Any finite angles (equation (3) is defined for all of them).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StackedUnitVectors<const N: usize, const M: usize>;

/// Readings to `[v₁ … v_N]`, `vⱼ = Rⱼᵀ u(azⱼ, elⱼ)`, for the particle filter of
/// [`UnitVectorModel`] (holds the anchors' rotations; see [`UnitVectorModel::in_world_axes`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InWorldAxes<const N: usize>(pub [Matrix3<f64>; N]);

/// Readings to stacked angles `[az₁, el₁, …]` (M = 2N), for the Kalman filters of [`AzElModel`];
/// each reading checked canonical (elevation in [−π/2, π/2]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StackedAngles<const N: usize, const M: usize>;

/// Readings checked canonical and passed on, for the particle filter of [`AzElModel`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CheckedReadings<const N: usize>;

/// `[f(y₁); …; f(y_N)]`, M = PER × N values.
fn stacked<const N: usize, const M: usize, const PER: usize>(
    readings: &Readings<N>,
    each: impl Fn(&AzEl) -> Result<SVector<f64, PER>, OperatorError>,
) -> Result<SVector<f64, M>, OperatorError> {
    const {
        assert!(
            M == PER * N,
            "the stacked measurement has PER values per anchor"
        );
    };
    let mut z = SVector::<f64, M>::zeros();
    for (j, y) in readings.iter().enumerate() {
        z.fixed_rows_mut::<PER>(PER * j).copy_from(&each(y)?);
    }
    Ok(z)
}

impl<const N: usize, const M: usize> Conversion for StackedUnitVectors<N, M> {
    type Reading = Readings<N>;
    type Measurement = SVector<f64, M>;

    /// # Errors
    /// [`OperatorError::NonFinite`] for a non-finite angle.
    fn convert(&self, readings: &Readings<N>) -> Result<SVector<f64, M>, OperatorError> {
        stacked::<N, M, 3>(readings, |y| {
            y.check_finite()?;
            Ok(y.unit_vector())
        })
    }
}

impl<const N: usize> Conversion for InWorldAxes<N> {
    type Reading = Readings<N>;
    type Measurement = WorldDirections<N>;

    /// # Errors
    /// [`OperatorError::NonFinite`] for a non-finite angle, [`OperatorError::Manifold`] for a
    /// matrix (a public field) that is not a rotation.
    fn convert(&self, readings: &Readings<N>) -> Result<WorldDirections<N>, OperatorError> {
        for y in readings {
            y.check_finite()?;
        }
        for m in &self.0 {
            So3::from_matrix(m).map_err(|source| OperatorError::Manifold {
                what: "an anchor's rotation matrix in InWorldAxes",
                source,
            })?;
        }
        Ok(WorldDirections(std::array::from_fn(|j| {
            self.0[j].transpose() * readings[j].unit_vector()
        })))
    }
}

impl<const N: usize, const M: usize> Conversion for StackedAngles<N, M> {
    type Reading = Readings<N>;
    type Measurement = SVector<f64, M>;

    /// # Errors
    /// As [`AzEl::check_canonical`].
    fn convert(&self, readings: &Readings<N>) -> Result<SVector<f64, M>, OperatorError> {
        stacked::<N, M, 2>(readings, |y| {
            y.check_canonical()?;
            Ok(nalgebra::Vector2::new(wrap_angle(y.azimuth), y.elevation))
        })
    }
}

impl<const N: usize> Conversion for CheckedReadings<N> {
    type Reading = Readings<N>;
    type Measurement = Readings<N>;

    /// # Errors
    /// As [`AzEl::check_canonical`].
    fn convert(&self, readings: &Readings<N>) -> Result<Readings<N>, OperatorError> {
        for y in readings {
            y.check_canonical()?;
        }
        Ok(*readings)
    }
}
