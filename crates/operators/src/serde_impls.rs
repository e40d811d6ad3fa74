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
//!
//! A zero weight, `ln w = −∞`, is written as a missing value (`null` in JSON, which has no
//! infinities), and read back as a zero weight. Matrices are nalgebra's serde form: their entries in column-major order. Particle and grid
//! states are read back through [`ParticleSet::from_log_weighted_samples`] and
//! [`CircularGrid::from_log_weights`], which normalise the log weights again: a round trip keeps
//! the points and payloads exactly and each log weight to within a few ulp of the normaliser
//! `ln Σ wᵢ` (which is 0 up to rounding). The Gaussians the Kalman filters step are the densities
//! crate's, with its own `serde` feature.

use crate::grid::CircularGrid;
use crate::kalman::{LinearMeasurement, LinearProcess};
use crate::particle::ParticleSet;
use nalgebra::SMatrix;
use serde::de::Error as _;
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
