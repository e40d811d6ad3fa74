//! proptest strategies for the densities (feature `proptest`), drawn over the whole parameter range
//! with its edges on purpose: κ = 0, 1e-300, tiny, moderate, large and 1e6.

use crate::{VonMises, VonMisesFisher};
use liebayes_manifolds::testing::strategies as manifold;
use proptest::prelude::*;

/// Concentrations: exactly 0 and 1e-300, log-uniform over [1e-8, 1e6] in three bands, and 1e6.
pub fn concentration() -> impl Strategy<Value = f64> {
    prop_oneof![
        1 => Just(0.0),
        1 => Just(1e-300),
        2 => (-8.0..-1.0_f64).prop_map(|e| 10f64.powf(e)),
        4 => (-1.0..2.0_f64).prop_map(|e| 10f64.powf(e)),
        2 => (2.0..6.0_f64).prop_map(|e| 10f64.powf(e)),
        1 => Just(1e6),
    ]
}

/// Von Mises distributions: any mean direction (including ±π), any concentration.
///
/// # Panics
/// Never: the drawn parameters are valid.
pub fn von_mises() -> impl Strategy<Value = VonMises> {
    (manifold::so2::<f64>(), concentration()).prop_map(|(mean, kappa)| {
        VonMises::from_mean_concentration(mean, kappa).expect("strategy parameters are valid")
    })
}

/// Von Mises-Fisher distributions: any mean direction (including the poles), any concentration.
///
/// # Panics
/// Never: the drawn parameters are valid.
pub fn von_mises_fisher() -> impl Strategy<Value = VonMisesFisher> {
    (manifold::s2::<f64>(), concentration()).prop_map(|(mean, kappa)| {
        VonMisesFisher::new(mean, kappa).expect("strategy parameters are valid")
    })
}
