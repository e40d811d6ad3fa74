//! Property-testing a density family of your own with the crate's law suite.
//!
//! The family here is the wrapped Cauchy distribution on the circle,
//! `p(θ) = (1 − ρ²) / (2π (1 + ρ² − 2ρ cos(θ − μ)))` with `ρ ∈ [0, 1)` (Mardia and Jupp,
//! *Directional Statistics*, §3.5.7), written against the crate's [`Density`], [`Entropy`] and
//! [`Rotate`] traits. Implementing [`DensitySubject`] (where to integrate, which statistics the
//! sampler is checked on) is all it takes to run every law in one line with `density_laws!`:
//! normalisation, mode, closed-form moments and sampler moments against quadrature, entropy, and
//! rotation. Dropping the factor 2 in the sampler, or writing `1 + ρ` for `1 + ρ²` in the density,
//! fails within a few cases.
//!
//! Run: `cargo test -p liebayes-densities --example property_test_a_density` (plain `cargo test`
//! runs it too).

use liebayes_densities::testing::{DensitySubject, manifold_neighbours, quadrature};
use liebayes_densities::{Density, DensityError, Entropy, Rotate, density_laws};
#[cfg(test)]
use liebayes_manifolds::testing::strategies as ms;
use liebayes_manifolds::{LieGroup, So2};
#[cfg(test)]
use proptest::prelude::*;
use rand::Rng;
use std::f64::consts::PI;

/// The wrapped Cauchy distribution with location μ and concentration ρ ∈ [0, 1).
#[derive(Clone, Debug)]
pub struct WrappedCauchy {
    mean: So2<f64>,
    rho: f64,
}

impl WrappedCauchy {
    /// `μ` and `ρ`; `None` unless `0 ≤ ρ < 1`.
    pub fn new(mean: So2<f64>, rho: f64) -> Option<Self> {
        (0.0..1.0).contains(&rho).then_some(Self { mean, rho })
    }
}

impl Density for WrappedCauchy {
    type Point = So2<f64>;

    fn log_pdf(&self, x: &So2<f64>) -> f64 {
        let d = self.mean.inverse().compose(x);
        let (c, s) = (d.cos(), d.sin());
        let r = self.rho;
        // 1 + ρ² − 2ρc = (1 − ρ)² + 2ρ(1 − c), and 1 − c = s²/(1 + c) near the mode (c > 0), so
        // neither difference cancels: the log density keeps its relative accuracy at any ρ < 1.
        let one_minus_c = if c > 0.0 { s * s / (1.0 + c) } else { 1.0 - c };
        let denominator = (1.0 - r).powi(2) + 2.0 * r * one_minus_c;
        (1.0 - r * r).ln() - denominator.ln() - self.log_normalizer()
    }

    fn log_normalizer(&self) -> f64 {
        (2.0 * PI).ln()
    }

    /// θ = μ + 2 atan(((1 − ρ)/(1 + ρ)) tan(π(U − ½))), the wrapped image of a Cauchy draw.
    fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> So2<f64> {
        let u: f64 = rng.random();
        let t = ((1.0 - self.rho) / (1.0 + self.rho)) * (PI * (u - 0.5)).tan();
        self.mean
            .compose(&So2::from_angle_unchecked(2.0 * t.atan()))
    }

    fn mode(&self) -> Option<So2<f64>> {
        (self.rho > 0.0).then_some(self.mean)
    }
}

impl Entropy for WrappedCauchy {
    /// `ln(2π (1 − ρ²))`.
    fn entropy(&self) -> f64 {
        (2.0 * PI * (1.0 - self.rho * self.rho)).ln()
    }
}

impl Rotate<So2<f64>> for WrappedCauchy {
    fn rotated(&self, g: &So2<f64>) -> Result<Self, DensityError> {
        Ok(Self {
            mean: g.compose(&self.mean),
            rho: self.rho,
        })
    }

    fn act(g: &So2<f64>, x: &So2<f64>) -> So2<f64> {
        g.compose(x)
    }
}

impl DensitySubject for WrappedCauchy {
    /// The Fourier coefficients decay as ρⁿ: the trapezoid rule on `16 + 40/(1 − ρ)` angles leaves
    /// an aliasing error `2ρ^N < 1e-17`.
    fn quadrature(&self) -> Vec<(So2<f64>, f64)> {
        quadrature::circle((1.0 - self.rho) / 4.5)
    }

    fn neighbours(&self, x: &So2<f64>) -> Vec<So2<f64>> {
        manifold_neighbours(x, 1.0 - self.rho)
    }

    /// `(cos θ, sin θ)`.
    fn statistics(&self, x: &So2<f64>) -> Vec<f64> {
        vec![x.cos(), x.sin()]
    }

    /// `E[e^{iθ}] = ρ e^{iμ}`.
    fn exact_moments(&self) -> Vec<f64> {
        vec![self.rho * self.mean.cos(), self.rho * self.mean.sin()]
    }

    /// The slope of ln p in θ, at most `2ρ/(1 − ρ)²·(1 − ρ)`, about `1/(1 − ρ)`, plus ln 2π.
    fn log_scale(&self) -> f64 {
        1.0 / (1.0 - self.rho) + self.log_normalizer()
    }
}

/// ρ from 0 to 0.99, log-uniform in 1 − ρ, and exactly 0.
#[cfg(test)]
fn wrapped_cauchy() -> impl Strategy<Value = WrappedCauchy> {
    let rho = prop_oneof![Just(0.0), (-2.0..0.0_f64).prop_map(|e| 1.0 - 10f64.powf(e))];
    (ms::so2::<f64>(), rho).prop_map(|(mean, rho)| WrappedCauchy { mean, rho })
}

density_laws!(
    wrapped_cauchy_laws,
    wrapped_cauchy(),
    entropy,
    rotated(ms::so2::<f64>())
);

fn main() {
    let p = WrappedCauchy::new(So2::from_angle_unchecked(1.0), 0.7).expect("0 <= rho < 1");
    println!(
        "wrapped Cauchy: H = {:.6}, run `cargo test --example property_test_a_density` for its laws",
        p.entropy()
    );
}
