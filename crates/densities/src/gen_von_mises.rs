//! [`GenVonMises2`]: the generalised von Mises distribution with first and second harmonics.

use crate::error::{DensityError, finite};
use crate::special;
use crate::traits::{Density, Entropy, KlDivergence, Product};
use liebayes_manifolds::So2;
use nalgebra::Vector2;
use rand::Rng;
use std::f64::consts::PI;

/// The generalised von Mises distribution of order 2 on the circle:
///
/// `p(θ) = exp(η₁ · u(θ) + η₂ · u(2θ)) / Z`, `u(θ) = (cos θ, sin θ)`,
///
/// with respect to dθ (total mass 2π). κ₁ = |η₁|, κ₂ = |η₂|. It contains the von Mises (η₂ = 0) and is
/// the family in which seed 000 asserts that the azimuth posterior stays von Mises: that claim is checked
/// by measuring η₂, not assumed.
///
/// **Normaliser**: the periodic trapezoid rule in log-sum-exp form on `N = 32 + 12 √(κ₁ + 4κ₂)` points,
/// exponentially accurate for this analytic periodic integrand. Checked in the tests against the
/// Jacobi-Anger series `Z = 2π Σ_k I₂ₖ(κ₁) I_k(κ₂) cos(2k(μ₁ − μ₂))`.
#[derive(Clone, Debug, PartialEq)]
pub struct GenVonMises2 {
    eta1: Vector2<f64>,
    eta2: Vector2<f64>,
    log_normalizer: f64,
}

impl GenVonMises2 {
    /// The distribution with first- and second-harmonic natural parameters η₁, η₂.
    ///
    /// # Errors
    /// [`DensityError::NonFinite`] for NaN or infinite components.
    pub fn new(eta1: Vector2<f64>, eta2: Vector2<f64>) -> Result<Self, DensityError> {
        for &v in eta1.iter().chain(eta2.iter()) {
            finite("harmonic parameter", v)?;
        }
        let log_normalizer = log_normalizer(&eta1, &eta2);
        Ok(Self {
            eta1,
            eta2,
            log_normalizer,
        })
    }

    /// The first-harmonic parameter η₁.
    pub fn eta1(&self) -> &Vector2<f64> {
        &self.eta1
    }

    /// The second-harmonic parameter η₂.
    pub fn eta2(&self) -> &Vector2<f64> {
        &self.eta2
    }

    /// The first and second trigonometric moments `(E u(θ), E u(2θ))`, `u(θ) = (cos θ, sin θ)`, by
    /// the periodic trapezoid rule on the normaliser's points (exponentially accurate, as the
    /// normaliser).
    pub fn trigonometric_moments(&self) -> (Vector2<f64>, Vector2<f64>) {
        let n = points(&self.eta1, &self.eta2);
        let h = 2.0 * PI / n as f64;
        (0..n).fold((Vector2::zeros(), Vector2::zeros()), |(m1, m2), i| {
            let t = h * i as f64;
            let w = (self.exponent(t) - self.log_normalizer).exp() * h;
            let (s, c) = t.sin_cos();
            let (s2, c2) = (2.0 * t).sin_cos();
            (m1 + Vector2::new(c, s) * w, m2 + Vector2::new(c2, s2) * w)
        })
    }

    fn exponent(&self, angle: f64) -> f64 {
        let (s, c) = angle.sin_cos();
        let (s2, c2) = (2.0 * angle).sin_cos();
        self.eta1.x * c + self.eta1.y * s + self.eta2.x * c2 + self.eta2.y * s2
    }
}

/// Trapezoid points for the normaliser: the integrand's Fourier coefficients decay like those of a von
/// Mises of concentration at most κ₁ + 4κ₂, whose aliasing error 2 A_N is below 1e-16 for N ≥ 9√κ.
fn points(eta1: &Vector2<f64>, eta2: &Vector2<f64>) -> usize {
    let kappa = eta1.norm() + 4.0 * eta2.norm();
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let extra = (12.0 * kappa.sqrt()).ceil().min(1e8) as usize;
    32 + extra
}

fn log_normalizer(eta1: &Vector2<f64>, eta2: &Vector2<f64>) -> f64 {
    let n = points(eta1, eta2);
    let h = 2.0 * PI / n as f64;
    let exponent = |t: f64| {
        let (s, c) = t.sin_cos();
        let (s2, c2) = (2.0 * t).sin_cos();
        eta1.x * c + eta1.y * s + eta2.x * c2 + eta2.y * s2
    };
    let max = (0..n)
        .map(|i| exponent(h * i as f64))
        .fold(f64::NEG_INFINITY, f64::max);
    let sum: f64 = (0..n).map(|i| (exponent(h * i as f64) - max).exp()).sum();
    max + (sum * h).ln()
}

impl Density for GenVonMises2 {
    type Point = So2<f64>;

    /// `η₁ · u(θ) + η₂ · u(2θ) − ln Z`.
    fn log_pdf(&self, x: &So2<f64>) -> f64 {
        self.exponent(x.angle()) - self.log_normalizer
    }

    /// `ln Z` by the trapezoid rule (see the type docs).
    fn log_normalizer(&self) -> f64 {
        self.log_normalizer
    }

    /// One exact draw; see [`GenVonMises2Sampler`], which this builds and uses once. For many draws
    /// from one distribution, build the sampler with [`GenVonMises2::sampler`] and keep it: where the
    /// grid envelope is needed that is the difference between a grid pass per draw and a binary search.
    fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> So2<f64> {
        rand::distr::Distribution::sample(&self.sampler(), rng)
    }

    /// The global maximum of the exponent: every local maximum of a grid (an order-2 trigonometric
    /// polynomial has at most two) refined by Newton's method, the best kept; `None` for the uniform
    /// distribution.
    fn mode(&self) -> Option<So2<f64>> {
        if self.eta1.norm() + self.eta2.norm() == 0.0 {
            return None;
        }
        let n = points(&self.eta1, &self.eta2);
        let h = 2.0 * PI / n as f64;
        let value = |i: usize| self.exponent(h * (i % n) as f64);
        (0..n)
            .filter(|&i| value(i) >= value(i + n - 1) && value(i) >= value(i + 1))
            .map(|i| self.refine_maximum(h * i as f64))
            .max_by(|a, b| self.exponent(*a).total_cmp(&self.exponent(*b)))
            .map(So2::from_angle_unchecked)
    }
}

impl GenVonMises2 {
    /// The exact sampler with its envelope chosen and built (see [`GenVonMises2Sampler`]).
    pub fn sampler(&self) -> GenVonMises2Sampler {
        let (k1, k2) = (self.eta1.norm(), self.eta2.norm());
        let first = self.log_normalizer - (2.0 * PI).ln() - special::log_i0(k1) - k2;
        let second = self.log_normalizer - (2.0 * PI).ln() - special::log_i0(k2) - k1;
        let envelope = if first.max(second) < 0.01_f64.ln() {
            Envelope::Grid(GridEnvelope::new(self, k1 + 2.0 * k2))
        } else if first >= second {
            Envelope::FirstHarmonic
        } else {
            Envelope::SecondHarmonic
        };
        GenVonMises2Sampler {
            density: self.clone(),
            envelope,
        }
    }
}

/// Exact rejection sampling of a [`GenVonMises2`] from the better of three envelopes, chosen once:
///
/// * the von Mises of η₁, accepting with `exp(η₂ · u(2θ) − κ₂)`, acceptance rate
///   `Z / (2π I₀(κ₁) e^κ₂)`;
/// * the bimodal von Mises of η₂ on the doubled angle, accepting with `exp(η₁ · u(θ) − κ₁)`, rate
///   `Z / (2π I₀(κ₂) e^κ₁)`;
/// * when both rates fall below 1 % (strong harmonics whose modes disagree): a piecewise-constant
///   envelope on `8L + 64` cells (at most 2¹⁶) for `L = κ₁ + 2κ₂ ≥ max |f′|`, cell i carrying
///   `exp(f(cᵢ) + L h/2)`, an upper bound of `exp(f)` on the cell, so the envelope exceeds the density
///   by at most e^(π/8) where it is not capped. A draw picks a cell by binary search in the cumulative
///   masses.
///
/// Implements [`rand::distr::Distribution`].
#[derive(Clone, Debug)]
pub struct GenVonMises2Sampler {
    density: GenVonMises2,
    envelope: Envelope,
}

#[derive(Clone, Debug)]
enum Envelope {
    FirstHarmonic,
    SecondHarmonic,
    Grid(GridEnvelope),
}

/// The piecewise-constant envelope: cell width, the bound `L h/2`, the exponent at every cell centre and
/// the cumulative masses `Σ exp(f(cⱼ) − max f)`.
#[derive(Clone, Debug)]
struct GridEnvelope {
    h: f64,
    bound: f64,
    exponents: Vec<f64>,
    cumulative: Vec<f64>,
}

impl GridEnvelope {
    fn new(p: &GenVonMises2, lipschitz: f64) -> Self {
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let cells = ((8.0 * lipschitz).ceil().min(65_472.0) as usize) + 64;
        let h = 2.0 * PI / cells as f64;
        let exponents: Vec<f64> = (0..cells)
            .map(|i| p.exponent((i as f64 + 0.5) * h))
            .collect();
        let max = exponents.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let cumulative = exponents
            .iter()
            .scan(0.0, |total, e| {
                *total += (e - max).exp();
                Some(*total)
            })
            .collect();
        Self {
            h,
            bound: lipschitz * h / 2.0,
            exponents,
            cumulative,
        }
    }

    fn draw<R: Rng + ?Sized>(&self, p: &GenVonMises2, rng: &mut R) -> f64 {
        let cells = self.cumulative.len();
        let total = self.cumulative[cells - 1];
        loop {
            let target = rng.random::<f64>() * total;
            let i = self
                .cumulative
                .partition_point(|&c| c < target)
                .min(cells - 1);
            let angle = (i as f64 + rng.random::<f64>()) * self.h;
            if rng.random::<f64>().ln() < p.exponent(angle) - self.exponents[i] - self.bound {
                return angle;
            }
        }
    }
}

impl rand::distr::Distribution<So2<f64>> for GenVonMises2Sampler {
    fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> So2<f64> {
        let p = &self.density;
        let (k1, k2) = (p.eta1.norm(), p.eta2.norm());
        let angle = match &self.envelope {
            Envelope::Grid(grid) => grid.draw(p, rng),
            Envelope::FirstHarmonic => loop {
                let a = von_mises_angle(&p.eta1, rng);
                let (s2, c2) = (2.0 * a).sin_cos();
                if rng.random::<f64>().ln() < p.eta2.x * c2 + p.eta2.y * s2 - k2 {
                    break a;
                }
            },
            Envelope::SecondHarmonic => loop {
                let half = von_mises_angle(&p.eta2, rng) / 2.0;
                let a = if rng.random::<bool>() {
                    half
                } else {
                    half + PI
                };
                let (s, c) = a.sin_cos();
                if rng.random::<f64>().ln() < p.eta1.x * c + p.eta1.y * s - k1 {
                    break a;
                }
            },
        };
        So2::from_angle_unchecked(angle)
    }
}

/// One angle from the von Mises with natural parameter η.
fn von_mises_angle<R: Rng + ?Sized>(eta: &Vector2<f64>, rng: &mut R) -> f64 {
    crate::VonMises::new(*eta).map_or(0.0, |p| p.sample(rng).angle())
}

impl GenVonMises2 {
    /// Newton's method on the exponent's derivative from `start`, stopping where the curvature is not
    /// negative.
    fn refine_maximum(&self, start: f64) -> f64 {
        let mut best = start;
        for _ in 0..50 {
            let (s, c) = best.sin_cos();
            let (s2, c2) = (2.0 * best).sin_cos();
            let d1 = -self.eta1.x * s + self.eta1.y * c - 2.0 * self.eta2.x * s2
                + 2.0 * self.eta2.y * c2;
            let d2 = -self.eta1.x * c
                - self.eta1.y * s
                - 4.0 * self.eta2.x * c2
                - 4.0 * self.eta2.y * s2;
            if d2 >= 0.0 {
                break;
            }
            let step = d1 / d2;
            best -= step;
            if step.abs() < 1e-15 {
                break;
            }
        }
        best
    }
}

impl Product for GenVonMises2 {
    /// Natural parameters add (exact).
    fn product(&self, other: &Self) -> Result<Self, DensityError> {
        Self::new(self.eta1 + other.eta1, self.eta2 + other.eta2)
    }

    /// `ln Z(η₁ + η₁′, η₂ + η₂′) − ln Z − ln Z′`.
    fn log_product_integral(&self, other: &Self) -> f64 {
        log_normalizer(&(self.eta1 + other.eta1), &(self.eta2 + other.eta2))
            - self.log_normalizer
            - other.log_normalizer
    }
}

/// `∫ f(θ) dθ` over the circle by the trapezoid rule on `n` points.
fn trapezoid(n: usize, f: impl Fn(f64) -> f64) -> f64 {
    let h = 2.0 * PI / n as f64;
    (0..n).map(|i| f(h * i as f64)).sum::<f64>() * h
}

impl Entropy for GenVonMises2 {
    /// `−∫ p ln p dθ` by the trapezoid rule on the normaliser's grid (no closed form).
    fn entropy(&self) -> f64 {
        let n = points(&self.eta1, &self.eta2);
        -trapezoid(n, |t| {
            let l = self.exponent(t) - self.log_normalizer;
            l.exp() * l
        })
    }
}

impl KlDivergence for GenVonMises2 {
    /// `∫ p ln(p/q) dθ` by the trapezoid rule on the finer of the two normalisers' grids.
    fn kl_divergence(&self, other: &Self) -> f64 {
        let n = points(&self.eta1, &self.eta2).max(points(&other.eta1, &other.eta2));
        trapezoid(n, |t| {
            let lp = self.exponent(t) - self.log_normalizer;
            let lq = other.exponent(t) - other.log_normalizer;
            lp.exp() * (lp - lq)
        })
    }
}
