//! [`HeatKernelSo3`]: the isotropic diffusion ("heat kernel") distribution on SO(3).

use crate::error::{DensityError, finite};
use crate::quadrature;
use crate::traits::{
    Convolve, Density, Entropy, KlDivergence, Rotate, distribution_through_density,
};
use liebayes_manifolds::{LieGroup, So3};
use nalgebra::{Matrix3, Vector3};
use rand::Rng;
use rand_distr::StandardNormal;
use std::f64::consts::PI;

/// Below this variance the density uses the Poisson-summed (small-time) form, above it the character
/// series (both are exact; each converges fast on its side: 8e-14 was measured with this switch).
const POISSON_LIMIT: f64 = 1.0;

/// Below this variance the angle CDF integrates the angle density numerically; above it, it sums the
/// closed-form series (which needs about √(80/s) terms).
const CDF_SERIES_LIMIT: f64 = 0.05;

/// The smallest accepted variance: the log density, down to `−π²/(2s)` at the half turn, stays finite
/// (it is −4.9e300 there).
const MIN_VARIANCE: f64 = 1e-300;

/// Bound on the terms of the character series (it needs about √(80/s) ≤ 9 terms for s ≥ 1 and the CDF
/// series about 40 for s ≥ 0.05).
const MAX_SERIES_TERMS: u32 = 1000;

/// Proposals of the small-variance sampler before it falls back to inverting the CDF (it accepts about
/// 67 % of them, so the fallback has probability below 1e-90).
const MAX_PROPOSALS: usize = 200;

/// The isotropic heat kernel on SO(3), `LD(c, s I)` in the attitude application's notation: the distribution of
/// `c · exp(ω)` for Brownian motion run for "time" s in the tangent space, that is per-axis tangent
/// variance `s = σ²` (rad²). Its density with respect to the **normalised Haar measure** depends only on
/// the rotation angle t of `c⁻¹ R`:
///
/// `f(t) = Σ_(l≥0) (2l+1) e^(−l(l+1)s/2) sin((l+½)t) / sin(t/2)`
///
/// (the degree-l Fourier coefficient is `e^(−l(l+1)s/2)`), and the angle itself has density
/// `f(t) (1 − cos t)/π` on [0, π]. For s < 1 the density is evaluated by its Poisson-summed form
///
/// `f(t) = √(2π) s^(−3/2) e^(s/8) / sin(t/2) · Σ_m (−1)^m (t + 2πm) e^(−(t + 2πm)²/(2s))`,
///
/// entirely in logarithms, so `log_pdf` stays finite where the density underflows (s = 1e-4 at t = π:
/// ln f ≈ −49 000). Range: s from 1e-300 to f64::MAX, all angles including 0 and π.
/// Convolution is closed: `LD(c₁, s₁) * LD(c₂, s₂) = LD(c₁ c₂, s₁ + s₂)`.
/// See `docs/densities/heat_kernel_so3.md`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeatKernelSo3 {
    mean: So3<f64>,
    s: f64,
}

impl HeatKernelSo3 {
    /// The heat kernel centred at `mean` with per-axis variance `variance = s = σ²` (rad²),
    /// s ∈ [1e-300, f64::MAX].
    ///
    /// # Errors
    /// [`DensityError::NonFinite`] or [`DensityError::OutOfRange`] unless `1e-300 ≤ s < ∞` (below,
    /// the log density at the half turn, −π²/(2s), overflows).
    ///
    /// # Example
    /// ```
    /// use liebayes_densities::{Convolve, HeatKernelSo3};
    /// use liebayes_manifolds::{LieGroup, So3};
    /// let p = HeatKernelSo3::new(So3::identity(), 0.04).unwrap();
    /// // E[R] = e^(−s) R(mean), so tr E[R] = 3 e^(−s).
    /// assert!((p.first_moment().trace() - 3.0 * (-0.04_f64).exp()).abs() < 1e-14);
    /// // Diffusions compose: the variances add.
    /// assert!((p.convolve(&p).unwrap().variance() - 0.08).abs() < 1e-15);
    /// ```
    pub fn new(mean: So3<f64>, variance: f64) -> Result<Self, DensityError> {
        let s = variance;
        finite("variance s", s)?;
        if s < MIN_VARIANCE {
            return Err(DensityError::OutOfRange {
                what: "variance s",
                value: s,
                range: "[1e-300, f64::MAX]",
            });
        }
        Ok(Self { mean, s })
    }

    /// The centre c: the mode and the mean rotation (the Fréchet mean, as the kernel is isotropic).
    pub fn mean(&self) -> So3<f64> {
        self.mean
    }

    /// The per-axis tangent variance s = σ².
    pub fn variance(&self) -> f64 {
        self.s
    }

    /// The degree-l Fourier coefficient (normalised character expectation) `E[χ_l(c⁻¹R)]/(2l+1) =
    /// e^(−l(l+1)s/2)`.
    pub fn fourier_coefficient(&self, l: u32) -> f64 {
        let l = f64::from(l);
        (-l * (l + 1.0) * self.s / 2.0).exp()
    }

    /// The first moment of the rotation matrix, `E[R] = e^(−s) C`, with C the centre's matrix
    /// (E[tr R] = 3 e^(−s) about the centre).
    pub fn first_moment(&self) -> Matrix3<f64> {
        self.mean.to_matrix() * (-self.s).exp()
    }

    /// `ln f(t)` for the rotation angle t ∈ [0, π] of `c⁻¹ R`.
    ///
    /// # Errors
    /// [`DensityError::NonFinite`] or [`DensityError::OutOfRange`] unless `0 ≤ t ≤ π`.
    pub fn log_density_of_angle(&self, t: f64) -> Result<f64, DensityError> {
        Ok(self.log_f(check_angle(t)?))
    }

    /// The density of the rotation angle, `f(t) (1 − cos t)/π` on [0, π].
    ///
    /// # Errors
    /// [`DensityError::NonFinite`] or [`DensityError::OutOfRange`] unless `0 ≤ t ≤ π`.
    pub fn angle_pdf(&self, t: f64) -> Result<f64, DensityError> {
        Ok(self.pdf_of_angle(check_angle(t)?))
    }

    /// The CDF of the rotation angle, `∫_0^t f(u)(1 − cos u)/π du`, for t ∈ [0, π].
    ///
    /// # Errors
    /// [`DensityError::NonFinite`] or [`DensityError::OutOfRange`] unless `0 ≤ t ≤ π`.
    pub fn angle_cdf(&self, t: f64) -> Result<f64, DensityError> {
        Ok(self.cdf_of_angle(check_angle(t)?))
    }

    /// `ln f(t)` for t ∈ [0, π].
    fn log_f(&self, t: f64) -> f64 {
        if self.s < POISSON_LIMIT {
            log_density_poisson(self.s, t)
        } else {
            density_series(self.s, t).ln()
        }
    }

    /// [`Self::angle_pdf`] for t ∈ [0, π].
    fn pdf_of_angle(&self, t: f64) -> f64 {
        (self.log_f(t) + log_angle_factor(t)).exp()
    }

    /// [`Self::angle_cdf`] for t ∈ [0, π].
    fn cdf_of_angle(&self, t: f64) -> f64 {
        if self.s >= CDF_SERIES_LIMIT {
            return cdf_series(self.s, t).clamp(0.0, 1.0);
        }
        self.integrate_over_angle(t, |u| self.pdf_of_angle(u))
            .clamp(0.0, 1.0)
    }
}

/// Checks a rotation angle against [0, π].
fn check_angle(t: f64) -> Result<f64, DensityError> {
    finite("rotation angle t", t)?;
    if !(0.0..=PI).contains(&t) {
        return Err(DensityError::OutOfRange {
            what: "rotation angle t",
            value: t,
            range: "[0, pi]",
        });
    }
    Ok(t.abs())
}

impl Convolve for HeatKernelSo3 {
    /// `LD(c₁, s₁) * LD(c₂, s₂) = LD(c₁ c₂, s₁ + s₂)`: exact, the kernel being bi-invariant.
    fn convolve(&self, other: &Self) -> Result<Self, DensityError> {
        Self::new(self.mean.compose(&other.mean), self.s + other.s)
    }
}

impl Rotate<So3<f64>> for HeatKernelSo3 {
    /// Centre `g c`, the same variance.
    fn rotated(&self, g: &So3<f64>) -> Result<Self, DensityError> {
        Ok(Self {
            mean: g.compose(&self.mean),
            s: self.s,
        })
    }

    /// `g R`.
    fn act(g: &So3<f64>, x: &So3<f64>) -> So3<f64> {
        g.compose(x)
    }
}

distribution_through_density!(HeatKernelSo3);

/// `Σ_l (2l+1) e^(−l(l+1)s/2) U_(2l)(cos(t/2))` with the Chebyshev recurrence
/// `U_(n+1) = 2c U_n − U_(n−1)` (so `sin((l+½)t)/sin(t/2)` is exact at t = 0 and t = π), until the
/// weights fall below 1e-18 of the sum.
fn density_series(s: f64, t: f64) -> f64 {
    let c2 = 2.0 * (t / 2.0).cos();
    let (mut u_prev, mut u) = (0.0, 1.0); // U_(−1), U_0
    let mut sum = 1.0;
    for l in 1..=MAX_SERIES_TERMS {
        let lf = f64::from(l);
        // advance two steps: U_(2l−1), U_(2l)
        for _ in 0..2 {
            let next = c2 * u - u_prev;
            u_prev = u;
            u = next;
        }
        let weight = (2.0 * lf + 1.0) * (-lf * (lf + 1.0) * s / 2.0).exp();
        sum += weight * u;
        if weight * (2.0 * lf + 1.0) < 1e-18 * sum.abs() {
            break;
        }
    }
    sum
}

/// `sinh(x)/x`, with its Taylor series below 1e-3.
fn sinhc(x: f64) -> f64 {
    if x.abs() < 1e-3 {
        let x2 = x * x;
        1.0 + x2 / 6.0 * (1.0 + x2 / 20.0)
    } else {
        x.sinh() / x
    }
}

/// `ln f(t)` by the Poisson-summed form, written so that nothing cancels at t = 0 or overflows at
/// t = π:
///
/// `ln f = ½ ln 2π − (3/2) ln s + s/8 + ln(t / sin(t/2)) − t²/(2s) + ln(S(t)/t)`,
///
/// `S(t)/t = 1 + Σ_(m=1..3) (−1)^m [E₊ + E₋ − (a/t)(E₊ − E₋)]`, `a = 2πm`,
/// `E± = e^(±a t/s − a²/(2s)) = e^(a (±t − a/2)/s)` (the second form never subtracts infinities when s
/// is tiny), with `(a/t)(E₊ − E₋) = e^(ln(2a²/s) − a²/2s) sinhc(a t/s)` for small a t/s. Images beyond
/// |m| = 3 weigh less than e^(−18π²/s) ≈ 1e-77 at s = 1.
fn log_density_poisson(s: f64, t: f64) -> f64 {
    let mut ratio = 1.0; // S(t)/t
    for m in 1..=3 {
        let a = 2.0 * PI * f64::from(m);
        let x = a * t / s;
        let e_plus = (a * (t - 0.5 * a) / s).exp();
        let e_minus = (-a * (t + 0.5 * a) / s).exp();
        let sinh_part = if x < 1.0 {
            ((2.0 * a * a).ln() - s.ln() - a * (0.5 * a / s)).exp() * sinhc(x)
        } else {
            a / t * (e_plus - e_minus)
        };
        let sign = if m % 2 == 0 { 1.0 } else { -1.0 };
        ratio += sign * (e_plus + e_minus - sinh_part);
    }
    // t / sin(t/2): 2 (1 + t²/24 + 7t⁴/5760) near 0.
    let t_over_sin = if t < 1e-4 {
        let t2 = t * t;
        2.0 * (1.0 + t2 / 24.0 + 7.0 * t2 * t2 / 5760.0)
    } else {
        t / (t / 2.0).sin()
    };
    0.5 * (2.0 * PI).ln() - 1.5 * s.ln() + s / 8.0 + t_over_sin.ln() - t * t / (2.0 * s)
        + ratio.ln()
}

/// The angle CDF by its series: `(1/π)[(t − sin t) + Σ_(l≥1) (2l+1) e^(−l(l+1)s/2)
/// (sin(lt)/l − sin((l+1)t)/(l+1))]`, from `(1 − cos u) sin((l+½)u)/sin(u/2) = cos(lu) − cos((l+1)u)`.
fn cdf_series(s: f64, t: f64) -> f64 {
    let mut sum = t - t.sin();
    for l in 1..=MAX_SERIES_TERMS {
        let lf = f64::from(l);
        let weight = (2.0 * lf + 1.0) * (-lf * (lf + 1.0) * s / 2.0).exp();
        sum += weight * ((lf * t).sin() / lf - ((lf + 1.0) * t).sin() / (lf + 1.0));
        if weight < 1e-18 {
            break;
        }
    }
    sum / PI
}

impl Density for HeatKernelSo3 {
    type Point = So3<f64>;

    /// `ln f(angle(c⁻¹ R))`, with respect to the normalised Haar measure.
    fn log_pdf(&self, x: &So3<f64>) -> f64 {
        self.log_f(self.mean.inverse().compose(x).angle())
    }

    /// 0: the series and its Poisson form are normalised (the degree-0 coefficient is 1).
    fn log_normalizer(&self) -> f64 {
        0.0
    }

    /// For s < 1, rejection from the Brownian increment itself: propose `c · exp(ξ)`, ξ ~ N(0, s I),
    /// whose angle |ξ| has the Maxwell density m(t) = √(2/π) t² e^(−t²/2s) s^(−3/2). By the Poisson form
    /// the angle density over m is `e^(s/8) (S(t)/t) (2 sin(t/2)/t)`, at most 1.39 e^(s/8) for s < 1 (the tests
    /// measure it on a fine grid), bounded here by `1.5 e^(s/8)`,
    /// so a draw is accepted with probability `h(t) / (1.5 e^(s/8) m(t))` (about 67 %). The bound is
    /// checked at every draw; were it ever exceeded, or were 200 proposals in a row rejected
    /// (probability below 1e-90), that draw falls back to inversion, so the sampler stays exact either
    /// way. For s ≥ 1, and as that fallback, the angle comes from inverting its CDF (Newton safeguarded
    /// by bisection, at most 100 steps) with a uniform axis.
    fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> So3<f64> {
        if self.s < POISSON_LIMIT {
            let log_bound = self.s / 8.0 + 1.5_f64.ln();
            let log_maxwell_constant = 0.5 * (2.0 / PI).ln() - 1.5 * self.s.ln();
            for _ in 0..MAX_PROPOSALS {
                let xi =
                    Vector3::from_fn(|_, _| rng.sample::<f64, _>(StandardNormal)) * self.s.sqrt();
                let t = xi.norm();
                if t == 0.0 || t > PI {
                    continue; // the proposal is the Maxwell law truncated to (0, π]
                }
                let log_angle_density = self.log_f(t) + log_angle_factor(t);
                let log_maxwell = log_maxwell_constant + 2.0 * t.ln() - t * t / (2.0 * self.s);
                let log_ratio = log_angle_density - log_maxwell - log_bound;
                if log_ratio > 0.0 {
                    break; // bound violated: never observed, but exactness first
                }
                if rng.random::<f64>().ln() < log_ratio {
                    return self.mean.compose(&So3::exp(&xi));
                }
            }
        }
        let t = self.invert_angle_cdf(rng.random());
        let z: f64 = rng.random_range(-1.0..=1.0);
        let phi: f64 = rng.random_range(0.0..2.0 * PI);
        let r = (1.0 - z * z).max(0.0).sqrt();
        let axis = Vector3::new(r * phi.cos(), r * phi.sin(), z);
        self.mean.compose(&So3::exp(&(axis * t)))
    }

    /// The centre.
    fn mode(&self) -> Option<So3<f64>> {
        Some(self.mean)
    }
}

impl HeatKernelSo3 {
    /// `∫₀^min(upto, 12√s, π) f(t) dt` for integrands carrying the angle density: 20-point
    /// Gauss-Legendre on panels of width √s/2 (at least 4). The angle density is below e^(−70) past
    /// 12√s, so the rest is negligible.
    fn integrate_over_angle(&self, upto: f64, f: impl Fn(f64) -> f64) -> f64 {
        let root = self.s.sqrt();
        let end = upto.min(12.0 * root).min(PI);
        // end ≤ 12 √s, so at most 24 panels.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let panels = (2.0 * end / root).ceil().max(4.0) as usize;
        quadrature::integrate(f, 0.0, end, panels)
    }

    /// The angle t with `angle_cdf(t) = u`: Newton's method safeguarded by bisection on [0, π].
    fn invert_angle_cdf(&self, u: f64) -> f64 {
        let (mut lo, mut hi) = (0.0, PI);
        let mut t = (3.0 * self.s).sqrt().min(PI / 2.0);
        for _ in 0..100 {
            let residual = self.cdf_of_angle(t) - u;
            if residual > 0.0 {
                hi = t;
            } else {
                lo = t;
            }
            let pdf = self.pdf_of_angle(t);
            let newton = t - residual / pdf;
            let next = if pdf > 0.0 && newton > lo && newton < hi {
                newton
            } else {
                0.5 * (lo + hi)
            };
            if (next - t).abs() <= 1e-14 * (1.0 + t) {
                return next;
            }
            t = next;
        }
        t
    }
}

impl Entropy for HeatKernelSo3 {
    /// `−∫ f ln f dHaar = −∫_0^π f(t) ln f(t) (1 − cos t)/π dt`, by Gauss-Legendre quadrature on panels
    /// of width √s/2 (no closed form exists).
    fn entropy(&self) -> f64 {
        -self.integrate_over_angle(PI, |t| self.pdf_of_angle(t) * self.log_f(t))
    }
}

impl KlDivergence for HeatKernelSo3 {
    /// `∫ f₁ ln(f₁/f₂) dHaar` by quadrature (no closed form). Writing `R = c₁ g`, g with angle t and
    /// uniform axis n, the angle of `c₂⁻¹ R = d g` (`d = c₂⁻¹ c₁ = exp(δ m)`) has
    /// `cos(t′/2) = |cos(δ/2) cos(t/2) − sin(δ/2) sin(t/2) (m · n)|`, so the integral is two-dimensional:
    /// `∫₀^π angle_pdf₁(t) ∫₋₁¹ ½ [ln f₁(t) − ln f₂(t′(t, c))] dc dt`, by 20-point Gauss-Legendre on panels
    /// of width √s₁/2 in t (up to 12√s₁) and panels in c = m · n on each side of the kink
    /// `c = cot(δ/2) cot(t/2)` where R crosses the cut locus of c₂ (t′ = π), wherever it lies in
    /// (−1, 1), graded from the width over which ln f₂ turns there: without the split a concentrated
    /// q (s₂ = 1e-6, whose ln f₂ reaches −5e6 there) lost three digits, and two ungraded panels per
    /// side lost 4e-8 relative for s₁ = 10, s₂ = 0.0145, δ = 0.95.
    ///
    /// In t the integrand is smooth except where the cut locus enters, at `t = π − δ` and at π:
    /// there ln f₂ turns over an angle of about `s₂/π` (its two nearest images meet), so the t-panels
    /// start that fine at π − δ and π and grow fourfold up to `√s₁/2` (uniform panels of that width only lost 5e-10 relative for s₁ = 1, s₂ = 2.5e-4).
    fn kl_divergence(&self, other: &Self) -> f64 {
        let d = other.mean.inverse().compose(&self.mean);
        let delta = d.angle();
        let (sd, cd) = (delta / 2.0).sin_cos();
        let root = self.s.sqrt();
        let end = (12.0 * root).min(PI);
        let (fine, coarse) = (other.s / (4.0 * PI), 0.5 * root);
        let factor = root.min(1.0);
        let split = PI - delta;
        // (start, stop, grade at start, grade at stop): towards π − δ and π, never towards 0.
        let at_pi = end >= PI;
        let pieces: &[(f64, f64, bool, bool)] = if split > 0.0 && split < end {
            &[(0.0, split, false, true), (split, end, true, at_pi)]
        } else {
            &[(0.0, end, false, at_pi)]
        };
        let outer = |t: f64| {
            let (st, ct) = (t / 2.0).sin_cos();
            let log_p = self.log_f(t);
            let integrand = |c: f64| {
                let w = (cd * ct - sd * st * c).abs().min(1.0);
                let t_other = 2.0 * w.acos();
                0.5 * (log_p - other.log_f(t_other))
            };
            // The cut locus of q's centre, where t′ = π and |·| has a kink (and ln f₂ its largest
            // curvature): the panels meet there.
            let kink = if sd * st > 0.0 {
                cd * ct / (sd * st)
            } else {
                f64::INFINITY
            };
            let inner = if kink.abs() < 1.0 {
                // ln f₂ turns over an angle of s₂/π at the kink, `dt′ ≈ 2 sin(δ/2) sin(t/2) dc`.
                let fine = other.s / (2.0 * PI * sd * st);
                graded_integral(&integrand, -1.0, kink, [false, true], fine, 0.5)
                    + graded_integral(&integrand, kink, 1.0, [true, false], fine, 0.5)
            } else {
                quadrature::integrate(integrand, -1.0, 1.0, 4)
            };
            // The angle's density times min(√s₁, 1) is of order 1 at most (its peak is about
            // 0.6/√s₁ for a small s₁, and (1 − cos t)/π for a large one), so the product with the
            // inner integral (about δ²/(2 s₂)) overflows only where the divergence itself does (it
            // did at s₁ = s₂ = 1e-250, and with √s₁ itself at s₁ = 1e20, s₂ = 1e-300); the factor
            // is divided out at the end.
            (self.pdf_of_angle(t) * factor) * inner
        };
        let scaled: f64 = pieces
            .iter()
            .map(|&(a, b, from_a, from_b)| {
                graded_integral(&outer, a, b, [from_a, from_b], fine, coarse)
            })
            .sum();
        scaled / factor
    }
}

/// `ln(2 sin²(t/2) / π)`, the logarithm of the Haar measure's factor on the rotation angle t ∈ [0, π],
/// taken as `2 ln sin(t/2) + ln(2/π)` so that it stays exact where sin²(t/2) would underflow (down to
/// the smallest positive t; −∞ at t = 0 only).
fn log_angle_factor(t: f64) -> f64 {
    2.0 * (t / 2.0).sin().ln() + (2.0 / PI).ln()
}

/// `∫_a^b f` by 20-point Gauss-Legendre on panels graded towards the ends flagged in `graded`
/// (`[at a, at b]`): from width `fine` (at least `coarse · 1e-8`: a feature narrower than that
/// carries a negligible share of the integrand's mass) growing fourfold, at most 14 times, until they
/// reach `coarse`; then panels of about `coarse` between (at most 64: the callers' ranges are at most
/// 24 coarse widths).
fn graded_integral(
    f: &impl Fn(f64) -> f64,
    a: f64,
    b: f64,
    graded: [bool; 2],
    fine: f64,
    coarse: f64,
) -> f64 {
    let (mut lo, mut hi, mut width) = (a, b, fine.max(coarse * 1e-8));
    let mut total = 0.0;
    for _ in 0..14 {
        if width >= coarse || hi - lo <= 8.0 * width {
            break;
        }
        if graded[0] {
            total += quadrature::integrate(f, lo, lo + width, 1);
            lo += width;
        }
        if graded[1] {
            total += quadrature::integrate(f, hi - width, hi, 1);
            hi -= width;
        }
        width *= 4.0;
    }
    // (hi − lo)/coarse is at most 24 here, a non-negative integer after ceil.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let panels = ((hi - lo) / coarse).ceil().clamp(1.0, 64.0) as usize;
    total + quadrature::integrate(f, lo, hi, panels)
}
