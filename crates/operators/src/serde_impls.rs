//! serde support (feature `serde`): the filter states and models of this crate, read back through
//! their validated constructors, so a saved state can never come back invalid (a NaN weight, a
//! covariance that is not positive semi-definite, fewer weights than particles).
//!
//! | type | written as |
//! |---|---|
//! | [`ParticleSet<X>`] | `{"particles": [X, …], "log_weights": [ln w₁, …]}` (normalised) |
//! | [`CircularGrid<X>`] | `{"log_weights": [ln w₁, …], "cells": [X, …]}` (cell j at angle 2πj/n) |
//! | [`LinearProcess<N>`] | `{"transition": F, "noise": Q}` |
//! | [`LinearMeasurement<N, M>`] | `{"matrix": H, "noise": R}` |
//! | [`Resampling`](crate::particle::Resampling) | `"Multinomial"`, `"Stratified"`, `"Systematic"` or `"Residual"` |
//! | [`Prediction<X, D>`] | `{"density": N(μ′, P′), "cross_covariance": C, "noise": Ω}` |
//! | [`RtsSmoother<X, D>`] | `{"filtered": [N(μ_f, P_f), …], "transitions": [Prediction, …]}` |
//! | [`FixedLagSmoother<X, D>`] | `{"lag": L, "epoch": k, "filtered": [… the window …], "transitions": […]}` |
//!
//! A zero weight, `ln w = −∞`, is written as a missing value (`null` in JSON, which has no
//! infinities), and read back as a zero weight. Matrices are nalgebra's serde form: their entries in column-major order. Particle and grid
//! states are read back through [`ParticleSet::from_log_weighted_samples`] and
//! [`CircularGrid::from_log_weights`], which normalise the log weights again: a round trip keeps
//! the points and payloads exactly and each log weight to within a few ulp of the normaliser
//! `ln Σ wᵢ` (which is 0 up to rounding). The Gaussians the Kalman filters step are the densities
//! crate's, with its own `serde` feature: a Gaussian is written as its mean and covariance and read
//! back through its constructor, which factors the covariance again, deterministically. So the
//! smoothers, read back through [`RtsSmoother::from_records`] and
//! [`FixedLagSmoother::from_records`] (which check the record's shape and that every
//! cross-covariance and noise is finite), continue a checkpointed run bit for bit.

use crate::fixed_lag::FixedLagSmoother;
use crate::grid::CircularGrid;
use crate::kalman::{LinearMeasurement, LinearProcess};
use crate::particle::ParticleSet;
use crate::smoother::{Prediction, RtsSmoother};
use liebayes_densities::ManifoldGaussian;
use liebayes_manifolds::Manifold;
use nalgebra::SMatrix;
use serde::de::{DeserializeOwned, Error as _};
use serde::ser::SerializeStruct;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// Log weights as written: −∞ (a zero weight) as a missing value.
struct LogWeights<'a>(&'a [f64]);

impl Serialize for LogWeights<'_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.collect_seq(
            self.0
                .iter()
                .map(|&l| (l != f64::NEG_INFINITY).then_some(l)),
        )
    }
}

/// Log weights as read: a missing value is a zero weight.
fn from_optional(log_weights: &[Option<f64>]) -> Vec<f64> {
    log_weights
        .iter()
        .map(|l| l.unwrap_or(f64::NEG_INFINITY))
        .collect()
}

impl<X: Clone + Serialize> Serialize for ParticleSet<X> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut state = serializer.serialize_struct("ParticleSet", 2)?;
        state.serialize_field("particles", self.particles())?;
        state.serialize_field("log_weights", &LogWeights(self.log_weights()))?;
        state.end()
    }
}

/// The serialized fields of a [`ParticleSet`].
#[derive(Deserialize)]
#[serde(rename = "ParticleSet", deny_unknown_fields)]
struct ParticleFields<X> {
    particles: Vec<X>,
    log_weights: Vec<Option<f64>>,
}

impl<'de, X: Clone + Deserialize<'de>> Deserialize<'de> for ParticleSet<X> {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let fields = ParticleFields::<X>::deserialize(deserializer)?;
        ParticleSet::from_log_weighted_samples(
            fields.particles,
            &from_optional(&fields.log_weights),
        )
        .map_err(D::Error::custom)
    }
}

impl<X: Serialize> Serialize for CircularGrid<X> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut state = serializer.serialize_struct("CircularGrid", 2)?;
        state.serialize_field("log_weights", &LogWeights(self.log_weights()))?;
        state.serialize_field("cells", self.cells())?;
        state.end()
    }
}

/// The serialized fields of a [`CircularGrid`].
#[derive(Deserialize)]
#[serde(rename = "CircularGrid", deny_unknown_fields)]
struct GridFields<X> {
    log_weights: Vec<Option<f64>>,
    cells: Vec<X>,
}

impl<'de, X: Deserialize<'de>> Deserialize<'de> for CircularGrid<X> {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let fields = GridFields::<X>::deserialize(deserializer)?;
        CircularGrid::from_log_weights(&from_optional(&fields.log_weights), fields.cells)
            .map_err(D::Error::custom)
    }
}

impl<const N: usize> Serialize for LinearProcess<N> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut state = serializer.serialize_struct("LinearProcess", 2)?;
        state.serialize_field("transition", self.transition())?;
        state.serialize_field("noise", self.noise())?;
        state.end()
    }
}

/// The serialized fields of a [`LinearProcess`].
#[derive(Deserialize)]
#[serde(rename = "LinearProcess", deny_unknown_fields)]
struct ProcessFields<const N: usize> {
    transition: SMatrix<f64, N, N>,
    noise: SMatrix<f64, N, N>,
}

impl<'de, const N: usize> Deserialize<'de> for LinearProcess<N> {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let fields = ProcessFields::<N>::deserialize(deserializer)?;
        LinearProcess::new(fields.transition, fields.noise).map_err(D::Error::custom)
    }
}

impl<const N: usize, const M: usize> Serialize for LinearMeasurement<N, M> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut state = serializer.serialize_struct("LinearMeasurement", 2)?;
        state.serialize_field("matrix", self.matrix())?;
        state.serialize_field("noise", self.noise())?;
        state.end()
    }
}

/// The serialized fields of a [`LinearMeasurement`].
#[derive(Deserialize)]
#[serde(rename = "LinearMeasurement", deny_unknown_fields)]
struct MeasurementFields<const N: usize, const M: usize> {
    matrix: SMatrix<f64, M, N>,
    noise: SMatrix<f64, M, M>,
}

impl<'de, const N: usize, const M: usize> Deserialize<'de> for LinearMeasurement<N, M> {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let fields = MeasurementFields::<N, M>::deserialize(deserializer)?;
        LinearMeasurement::new(fields.matrix, fields.noise).map_err(D::Error::custom)
    }
}

impl<X: Manifold<D, Scalar = f64> + Serialize + DeserializeOwned, const D: usize> Serialize
    for Prediction<X, D>
{
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut state = serializer.serialize_struct("Prediction", 3)?;
        state.serialize_field("density", &self.density)?;
        state.serialize_field("cross_covariance", &self.cross_covariance)?;
        state.serialize_field("noise", &self.noise)?;
        state.end()
    }
}

/// The serialized fields of a [`Prediction`].
#[derive(Deserialize)]
#[serde(rename = "Prediction", deny_unknown_fields)]
#[serde(bound(deserialize = "X: Manifold<D, Scalar = f64> + Serialize + DeserializeOwned"))]
struct PredictionFields<X, const D: usize> {
    density: ManifoldGaussian<X, D>,
    cross_covariance: SMatrix<f64, D, D>,
    noise: SMatrix<f64, D, D>,
}

impl<'de, X, const D: usize> Deserialize<'de> for Prediction<X, D>
where
    X: Manifold<D, Scalar = f64> + Serialize + DeserializeOwned,
{
    fn deserialize<De: Deserializer<'de>>(deserializer: De) -> Result<Self, De::Error> {
        let fields = PredictionFields::<X, D>::deserialize(deserializer)?;
        for (name, matrix) in [
            ("cross_covariance", &fields.cross_covariance),
            ("noise", &fields.noise),
        ] {
            if let Some(value) = matrix.iter().find(|v| !v.is_finite()) {
                return Err(De::Error::custom(format!(
                    "{name}: entry {value} is not finite"
                )));
            }
        }
        Ok(Prediction {
            density: fields.density,
            cross_covariance: fields.cross_covariance,
            noise: fields.noise,
        })
    }
}

impl<X: Manifold<D, Scalar = f64> + Serialize + DeserializeOwned, const D: usize> Serialize
    for RtsSmoother<X, D>
{
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut state = serializer.serialize_struct("RtsSmoother", 2)?;
        state.serialize_field("filtered", self.filtered())?;
        state.serialize_field("transitions", self.transitions())?;
        state.end()
    }
}

/// The serialized fields of an [`RtsSmoother`].
#[derive(Deserialize)]
#[serde(rename = "RtsSmoother", deny_unknown_fields)]
#[serde(bound(deserialize = "X: Manifold<D, Scalar = f64> + Serialize + DeserializeOwned"))]
struct RtsFields<X, const D: usize> {
    filtered: Vec<ManifoldGaussian<X, D>>,
    transitions: Vec<Prediction<X, D>>,
}

impl<'de, X, const D: usize> Deserialize<'de> for RtsSmoother<X, D>
where
    X: Manifold<D, Scalar = f64> + Serialize + DeserializeOwned,
{
    fn deserialize<De: Deserializer<'de>>(deserializer: De) -> Result<Self, De::Error> {
        let fields = RtsFields::<X, D>::deserialize(deserializer)?;
        RtsSmoother::from_records(fields.filtered, fields.transitions).map_err(De::Error::custom)
    }
}

impl<X: Manifold<D, Scalar = f64> + Serialize + DeserializeOwned, const D: usize> Serialize
    for FixedLagSmoother<X, D>
{
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut state = serializer.serialize_struct("FixedLagSmoother", 4)?;
        state.serialize_field("lag", &self.lag())?;
        state.serialize_field("epoch", &self.epoch())?;
        state.serialize_field("filtered", self.window_filtered())?;
        state.serialize_field("transitions", self.window_transitions())?;
        state.end()
    }
}

/// The serialized fields of a [`FixedLagSmoother`].
#[derive(Deserialize)]
#[serde(rename = "FixedLagSmoother", deny_unknown_fields)]
#[serde(bound(deserialize = "X: Manifold<D, Scalar = f64> + Serialize + DeserializeOwned"))]
struct FixedLagFields<X, const D: usize> {
    lag: usize,
    epoch: u64,
    filtered: Vec<ManifoldGaussian<X, D>>,
    transitions: Vec<Prediction<X, D>>,
}

impl<'de, X, const D: usize> Deserialize<'de> for FixedLagSmoother<X, D>
where
    X: Manifold<D, Scalar = f64> + Serialize + DeserializeOwned,
{
    fn deserialize<De: Deserializer<'de>>(deserializer: De) -> Result<Self, De::Error> {
        let f = FixedLagFields::<X, D>::deserialize(deserializer)?;
        FixedLagSmoother::from_records(f.lag, f.epoch, f.filtered, f.transitions)
            .map_err(De::Error::custom)
    }
}
