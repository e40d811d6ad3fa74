//! Quadrature rules on the spaces of the densities, for checking normalisers, moments and divergences
//! independently of a family's closed forms: each rule returns nodes and weights `(xᵢ, wᵢ)` with
//! `∫ f dμ ≈ Σ wᵢ f(xᵢ)` against the base measure it names, placed where a density of the given
//! location and width has its mass.
//!
//! | space | rule | base measure |
//! |---|---|---|
//! | SO(2) | [`circle`]: the periodic trapezoid rule | dθ (total 2π) |
//! | S² | [`sphere`]: the crate's [`SphereRule`](crate::quadrature::SphereRule), Gauss-Legendre in a geometric map of `t = 1 − a · x` × trapezoid in azimuth | surface measure (total 4π) |
//! | SO(3) | [`so3`]: exponential coordinates `c · exp(L r n)`, Gauss-Legendre in r on panels × Gauss-Legendre-trapezoid on the directions n | normalised Haar measure |
//! | SU(2) = S³ | [`s3`]: Hopf coordinates in an orthonormal frame, `u = (√(1 − |y|²) e^(iα), y)`, trapezoid or sinh-mapped Gauss-Legendre in α × whitened polar or iterated Gauss-Legendre on the disk `|y| ≤ 1` | uniform probability measure |
//! | Rⁿ | [`rn`]: Gauss-Hermite in the eigen-coordinates of a covariance | Lebesgue |
//! | any manifold | [`tangent`]: the Rⁿ rule mapped by `μ ⊞ δ` | Lebesgue in the tangent coordinates at μ |
//!
//! **Accuracy.** For the densities they are placed for (a peak of the given width at the given
//! location, or any smoother integrand) the rules reach the relative accuracy
//! [`QUADRATURE`](super::laws::QUADRATURE); this module's tests check it on closed forms (the
//! normalisers of the von Mises, von Mises-Fisher, heat kernel and Gaussian families, computed
//! from their definitions and not from the crate). The Gauss-Legendre and Gauss-Hermite nodes are
//! the ones the crate's own normalisers use; their exactness for polynomials is tested where they are
//! computed.
//!
//! **Sizes.** Every rule bounds its node count ([`MAX_NODES`]); a width below what the bound
//! resolves gives a coarser rule, which the laws then report as a failed normalisation rather than
//! allocate without limit.

use crate::eigen::bounded_eigen;
use crate::quadrature::{hermite_rule, legendre_rule};
use liebayes_manifolds::{LieGroup, Manifold, S2, So2, So3, Su2, Tangent};
use nalgebra::{DMatrix, Matrix3, Matrix4, Quaternion, SMatrix, SVector, Vector3};
use std::f64::consts::PI;

/// The most nodes any rule here makes.
pub const MAX_NODES: usize = 1 << 22;

/// Gauss-Legendre points per panel of the radial and polar rules.
const PANEL_POINTS: usize = 16;

/// Polar (Gauss-Legendre in cos ϑ) and azimuthal (trapezoid) points of the direction rule on S² used
/// by [`so3`]: exact for spherical polynomials of degree 31.
const POLAR_POINTS: usize = 16;
const AZIMUTH_POINTS: usize = 32;

/// Azimuthal points of [`sphere`].
const SPHERE_AZIMUTH_POINTS: usize = 64;

/// Colatitude points of [`sphere`].
pub const SPHERE_COLATITUDE_POINTS: usize = 128;

/// The radius, in units of the spread L, beyond which [`so3`] stops (and the whitened disk of [`s3`]): the densities they are
/// placed for are below e^(−72) of their peak there.
const WHITENED_RADIUS: f64 = 12.0;

/// The n-point Gauss-Legendre rule on [−1, 1] (exact for polynomials of degree 2n − 1). n is
/// capped at [`MAX_LEGENDRE_NODES`](crate::quadrature::MAX_LEGENDRE_NODES) (8192), beyond which the
/// rule's O(n²) Newton iterations take minutes.
pub fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    legendre_rule(n.min(crate::quadrature::MAX_LEGENDRE_NODES))
}

/// The n-point Gauss-Hermite rule for the standard normal, `E[f(u)] ≈ Σ wᵢ f(uᵢ)`, Σ wᵢ = 1 (exact
/// for polynomials of degree 2n − 1; empty for n = 0, as [`gauss_legendre`] is). n is capped at
/// [`MAX_HERMITE_NODES`], beyond which the eigenproblem is slow and the outer weights underflow.
pub fn gauss_hermite(n: usize) -> Vec<(f64, f64)> {
    if n == 0 {
        return Vec::new();
    }
    hermite_rule(n.min(MAX_HERMITE_NODES))
}

/// The most nodes [`gauss_hermite`] gives.
pub const MAX_HERMITE_NODES: usize = 200;

/// Nodes and weights on [0, length] for integrands peaked at 0 with width about `width`:
/// Gauss-Legendre with `points` nodes on the panels [0, w], [w, 2w], [2w, 4w], … clipped at
/// `length` (at most 64 panels).
pub fn peaked(width: f64, length: f64, points: usize) -> Vec<(f64, f64)> {
    let rule = gauss_legendre(points);
    let mut nodes = Vec::new();
    let (mut a, mut b) = (0.0, width.max(f64::MIN_POSITIVE).min(length));
    for _ in 0..64 {
        let (mid, half) = (0.5 * (a + b), 0.5 * (b - a));
        nodes.extend(rule.iter().map(|(x, w)| (mid + half * x, w * half)));
        if b >= length {
            break;
        }
        a = b;
        b = (2.0 * b).min(length);
    }
    if b < length {
        // 64 doublings from a width of 1e-300 still fall short of π only for widths below 2e-19
        // times MIN_POSITIVE; one last panel covers the rest.
        let (mid, half) = (0.5 * (b + length), 0.5 * (length - b));
        nodes.extend(rule.iter().map(|(x, w)| (mid + half * x, w * half)));
    }
    nodes
}

/// The circle: the periodic trapezoid rule on `16 + ⌈9/width⌉` equally spaced angles (at most
/// [`MAX_NODES`]), against dθ. For a von Mises of concentration κ (width 1/√κ) the aliasing error is
/// `2 A_N(κ) ≈ 2 e^(−N²/(2κ)) < 1e-17`; every integrand whose Fourier coefficients decay at least as
/// fast is integrated as accurately.
pub fn circle(width: f64) -> Vec<(So2<f64>, f64)> {
    let extra = (9.0 / width.max(1e-300)).ceil().min(MAX_NODES as f64);
    // extra is a non-negative integer below MAX_NODES.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let n = (16 + extra as usize).min(MAX_NODES);
    let h = 2.0 * PI / n as f64;
    (0..n)
        .map(|i| (So2::from_angle_unchecked(-PI + h * i as f64), h))
        .collect()
}

/// The sphere S², against its surface measure, about `axis`: the crate's
/// [`SphereRule`](crate::quadrature::SphereRule) with [`SPHERE_COLATITUDE_POINTS`] colatitude
/// and 64 longitude nodes, its angle chosen so that `1 − cos(angle) = width` in `t = 1 − axis · x`
/// (for a von Mises-Fisher of concentration κ about the axis, whose density is `∝ e^(−κ t)`,
/// `width = 1/(1 + κ)`). Widths are clamped to the rule's range of angles; a NaN width is the
/// widest.
///
/// # Panics
/// Never: the node counts are constants within the rule's range and the angle is clamped to it.
pub fn sphere(axis: &S2<f64>, width: f64) -> Vec<(S2<f64>, f64)> {
    let (low, high) = crate::quadrature::SPHERE_WIDTH_RANGE;
    let width = if width.is_nan() { 2.0 } else { width };
    // 1 − cos(angle) = width, without cancellation: angle = 2 asin(√(width/2)).
    let angle = (2.0 * (0.5 * width.clamp(0.0, 2.0)).sqrt().asin()).clamp(low, high);
    let rule =
        crate::quadrature::SphereRule::new(SPHERE_COLATITUDE_POINTS, SPHERE_AZIMUTH_POINTS, angle)
            .expect("node counts and angle within the rule's ranges");
    let mut nodes = Vec::with_capacity(SPHERE_COLATITUDE_POINTS * SPHERE_AZIMUTH_POINTS);
    rule.for_each_node(axis, |x, w| {
        nodes.push((S2::new_unchecked(x.normalize()), w));
    });
    nodes
}

/// `(sin(θ/2)/(θ/2))²`, 1 at θ = 0.
fn half_angle_sinc_squared(theta: f64) -> f64 {
    if theta < 1e-8 {
        1.0
    } else {
        let s = (0.5 * theta).sin() / (0.5 * theta);
        s * s
    }
}

/// The ball `|ξ| ≤ π` of exponential coordinates about `center`, `x = c · exp(L r n)`, with the
/// weights `|det L| r² dr dn · (sin(θ/2)/(θ/2))² / (8π²)` (θ = |L r n|) of the normalised Haar measure
/// of SO(3) (the uniform measure of a hemisphere of S³ times 2).
fn ball<G: LieGroup<3, Scalar = f64>>(center: &G, spread: &Matrix3<f64>) -> Vec<(G, f64)> {
    let determinant = spread.determinant().abs();
    let polar = gauss_legendre(POLAR_POINTS);
    let h = 2.0 * PI / AZIMUTH_POINTS as f64;
    let mut nodes = Vec::new();
    for &(c, wc) in &polar {
        let sine = (1.0 - c * c).max(0.0).sqrt();
        for k in 0..AZIMUTH_POINTS {
            let (s, co) = (h * k as f64).sin_cos();
            let n = Vector3::new(sine * co, sine * s, c);
            let direction = spread * n;
            let length = direction.norm();
            if length == 0.0 {
                continue;
            }
            let r_max = (PI / length).min(WHITENED_RADIUS);
            for (r, wr) in peaked(1.0, r_max, PANEL_POINTS) {
                let xi: Tangent<f64, 3> = direction * r;
                let theta = length * r;
                let weight = wc * h * wr * determinant * r * r * half_angle_sinc_squared(theta)
                    / (8.0 * PI * PI);
                nodes.push((center.compose(&G::exp(&xi)), weight));
            }
        }
    }
    nodes
}

/// SO(3), against its normalised Haar measure, in exponential coordinates about `center` scaled by
/// `spread` L (a density concentrated like `c · exp(ξ)`, `ξ ~ N(0, L Lᵀ)`; use a spread of at most
/// about 1 in every direction for diffuse densities): `x = c · exp(L r n)` for `|L r n| ≤ π` and
/// `r ≤ 12`, with Gauss-Legendre in r on the panels [0, 1], [1, 2], [2, 4], … and a 16 × 32
/// Gauss-Legendre-trapezoid rule on the directions n ∈ S², each node weighted by
/// `|det L| r² (sin(θ/2)/(θ/2))² / (8π²)`, θ = |L r n|.
pub fn so3(center: &So3<f64>, spread: &Matrix3<f64>) -> Vec<(So3<f64>, f64)> {
    ball(center, spread)
}

/// Nodes and weights on [−half, half] for integrands peaked at 0 with width about `width`: the
/// substitution `x = width · sinh(t)`, which makes a Gaussian peak of that width and its tails smooth
/// in t, with `points` Gauss-Legendre nodes on each of the t-panels [0, 1], [1, 2], [2, 3] and
/// [3, asinh(half/width)] (fewer where the range ends earlier), mirrored.
pub fn peaked_symmetric(width: f64, half: f64, points: usize) -> Vec<(f64, f64)> {
    let width = width.max(f64::MIN_POSITIVE);
    let end = (half / width).asinh();
    let rule = gauss_legendre(points);
    let mut nodes = Vec::new();
    let mut start = 0.0;
    for stop in [1.0, 2.0, 3.0, f64::INFINITY] {
        let stop = if stop > end { end } else { stop };
        let (mid, radius) = (0.5 * (start + stop), 0.5 * (stop - start));
        for (x, w) in &rule {
            let t = mid + radius * x;
            let weight = w * radius * width * t.cosh();
            let value = width * t.sinh();
            nodes.push((value, weight));
            nodes.push((-value, weight));
        }
        if stop >= end {
            break;
        }
        start = stop;
    }
    nodes
}

/// Gauss-Legendre points per panel of the iterated disk rule of [`s3`], finest first: it takes the
/// first whose nodes, times the angles', are at most [`MAX_NODES`]. Twelve serve every width down
/// to about 2e-4 (a Bingham of spread 1e4); a narrower third width beside two diffuse ones (16.9 M
/// nodes at widths (0.1000001, 0.1000001, 0)) takes fewer, at most 2 · 65 + 8 t-nodes × 2 × 16
/// v-nodes × 192 angles = 0.85 M with 2.
const DISK_PANEL_POINTS: [usize; 5] = [12, 8, 6, 4, 2];

/// Widths at and above which [`s3`] integrates a coordinate without concentrating its nodes.
const DIFFUSE_WIDTH: f64 = 0.1;

/// Polar points of the whitened disk rule of [`s3`].
const DISK_ANGLES: usize = 32;

/// S³ (the unit quaternions, SU(2)), against its uniform probability measure, for integrands
/// concentrated about `±v₀` with standard deviations `widths[k]` of the coordinates `vₖ · q`, in the
/// orthonormal frame `[v₀ v₁ v₂ v₃]` (the columns of `frame`, quaternion coordinates (w, x, y, z)),
/// as a Bingham density is.
///
/// With the widest of the three axes paired with v₀ and the other two as a disk, Hopf coordinates
/// `q = √(1 − |y|²) (cos α v₀ + sin α vₐ) + y_b v_b + y_c v_c`, α ∈ [−π, π), |y| ≤ 1, carry the flat
/// measure `dα d²y / (2π²)`. In α: the trapezoid rule on `16 + ⌈9/wₐ⌉` angles when `wₐ ≥ 0.1`, else
/// [`peaked_symmetric`] about α = 0 and α = π (the two antipodal peaks). On the disk: when
/// `w_b ≤ 0.1`, whitened polar coordinates `y = (w_b ρ cos γ, w_c ρ sin γ)`, ρ ≤ min(12, edge) on the
/// panels of [`peaked`] × 32 angles γ; otherwise `y_b = sin θ` (|θ| ≤ π/4: the panels of [`peaked`]
/// from the peak at θ = 0, of width w_b; π/4 ≤ |θ| ≤ π/2: those from the ends ±π/2, of width w_c,
/// where the inner integral saturates) and `y_c = cos θ · v`
/// ([`peaked_symmetric`] of width `w_c / cos θ` on [−1, 1]), `d²y = cos²θ dθ dv`. Every circle of maxima (repeated largest eigenvalues) lies along α, so it is
/// integrated by the trapezoid rule exactly.
///
/// At most [`MAX_NODES`] nodes for any widths (NaN, 0 and subnormal ones included): where 12 points
/// per panel of the iterated disk would exceed it (a third width below about 2e-4 beside two above
/// 0.1), the disk takes fewer points per panel (down to 2), a coarser rule.
pub fn s3(frame: &Matrix4<f64>, widths: &[f64; 3]) -> Vec<(Su2<f64>, f64)> {
    let mut order = [1usize, 2, 3];
    order.sort_by(|&i, &j| widths[j - 1].total_cmp(&widths[i - 1]));
    let [a, b, c] = order;
    let (wa, wb, wc) = (widths[a - 1], widths[b - 1], widths[c - 1]);
    let column = |k: usize| frame.column(k).into_owned();
    let (v0, va, vb, vc) = (column(0), column(a), column(b), column(c));

    // (cos α, sin α, weight); the peak at π as (−cos x, −sin x), so that small offsets keep their
    // digits.
    let angles: Vec<(f64, f64, f64)> = if wa >= DIFFUSE_WIDTH {
        circle(wa)
            .into_iter()
            .map(|(x, w)| (x.cos(), x.sin(), w))
            .collect()
    } else {
        let half = peaked_symmetric(wa, 0.5 * PI, 12);
        half.iter()
            .flat_map(|&(x, w)| {
                let (s, c) = x.sin_cos();
                [(c, s, w), (-c, -s, w)]
            })
            .collect()
    };
    let disk = DISK_PANEL_POINTS
        .iter()
        .map(|&points| disk_rule(wb, wc, points))
        .find(|disk| angles.len() * disk.len() <= MAX_NODES)
        .unwrap_or_default();
    let mut nodes = Vec::with_capacity(angles.len() * disk.len());
    for &(co, s, w_alpha) in &angles {
        for &((yb, yc), w_disk) in &disk {
            let radial = (1.0 - yb * yb - yc * yc).max(0.0).sqrt();
            let q = v0 * (radial * co) + va * (radial * s) + vb * yb + vc * yc;
            let q = Quaternion::new(q[0], q[1], q[2], q[3]).normalize();
            nodes.push((
                Su2::from_quaternion_unchecked(q),
                w_alpha * w_disk / (2.0 * PI * PI),
            ));
        }
    }
    nodes
}

/// The disk `|y| ≤ 1` of [`s3`]'s Hopf coordinates for the widths `w_b ≥ w_c` of its two axes, as
/// `((y_b, y_c), weight)` against `d²y`: whitened polar coordinates when `w_b ≤ 0.1`, else the
/// iterated rule in `y_b = sin θ`, `y_c = cos θ · v` with `points` Gauss-Legendre nodes per panel.
fn disk_rule(wb: f64, wc: f64, points: usize) -> Vec<((f64, f64), f64)> {
    if wb <= DIFFUSE_WIDTH {
        let h = 2.0 * PI / DISK_ANGLES as f64;
        let mut nodes = Vec::new();
        for k in 0..DISK_ANGLES {
            let (s, co) = (h * k as f64).sin_cos();
            let edge = 1.0 / (wb * co).hypot(wc * s);
            for (rho, wr) in peaked(1.0, edge.min(WHITENED_RADIUS), 10) {
                nodes.push(((wb * rho * co, wc * rho * s), wb * wc * rho * wr * h));
            }
        }
        nodes
    } else {
        // θ on [0, π/4] from the peak at 0 (width w_b), and on [π/4, π/2] from the end, where cos θ
        // falls below w_c and the v-integral saturates; mirrored.
        let quarter = 0.25 * PI;
        let inner = peaked(wb.min(1.0), quarter, points);
        let outer = peaked(wc.min(1.0), quarter, points)
            .into_iter()
            .map(|(tau, w)| (0.5 * PI - tau, w));
        let mut nodes = Vec::new();
        for (t, wt) in inner.into_iter().chain(outer) {
            for theta in [t, -t] {
                let (s, co) = theta.sin_cos();
                for (v, wv) in peaked_symmetric((wc / co).min(1.0), 1.0, points) {
                    nodes.push(((s, co * v), co * co * wt * wv));
                }
            }
        }
        nodes
    }
}

/// Rⁿ, against the Lebesgue measure: the product Gauss-Hermite rule with `points` nodes per axis in
/// the eigen-coordinates of `covariance` (by its symmetric eigendecomposition, not a Cholesky factor),
/// `x = μ + E diag(√λ) z`, weights `Π w(zᵢ) · (2π)^(N/2) √det Σ · e^(|z|²/2)`. Exact for a Gaussian of
/// that mean and covariance times any polynomial of degree at most `2 points − 1`. At most
/// [`MAX_NODES`] nodes (fewer points per axis in high dimension).
///
/// The eigendecomposition takes at most 1000 iterations; where it does not converge, or meets a
/// non-finite entry, the rule has no nodes (an integral of 0, which the laws report as a failed
/// normalisation).
///
/// # Panics
/// Never: the eigenvalues of a symmetric matrix are real (negative ones are treated as 0).
pub fn rn<const N: usize>(
    mean: &SVector<f64, N>,
    covariance: &SMatrix<f64, N, N>,
    points: usize,
) -> Vec<(SVector<f64, N>, f64)> {
    tangent_nodes(covariance, points)
        .into_iter()
        .map(|(delta, w)| (mean + delta, w))
        .collect()
}

/// Any manifold, against the Lebesgue measure in the tangent coordinates at `mean` (the base measure
/// of [`ManifoldGaussian`](crate::ManifoldGaussian)): the nodes of [`rn`] for the tangent vectors,
/// mapped by `μ ⊞ δ` (none where [`rn`]'s eigendecomposition fails).
pub fn tangent<X: Manifold<D, Scalar = f64>, const D: usize>(
    mean: &X,
    covariance: &SMatrix<f64, D, D>,
    points: usize,
) -> Vec<(X, f64)> {
    tangent_nodes(covariance, points)
        .into_iter()
        .map(|(delta, w)| (mean.retract(&delta), w))
        .collect()
}

/// The Gauss-Hermite product rule for vectors of covariance Σ about 0, against Lebesgue.
fn tangent_nodes<const N: usize>(
    covariance: &SMatrix<f64, N, N>,
    points: usize,
) -> Vec<(SVector<f64, N>, f64)> {
    if N == 0 {
        // R⁰ is one point, of measure 1 (and nalgebra's eigensolver asserts on an empty matrix).
        return vec![(SVector::zeros(), 1.0)];
    }
    // Points per axis: at most the Hermite rule's nodes, and so that points^N ≤ MAX_NODES (at
    // most 199 steps down).
    let mut per_axis = points.clamp(1, MAX_HERMITE_NODES);
    let exponent = u32::try_from(N).unwrap_or(u32::MAX);
    // Ends: 1^N = 1 ≤ MAX_NODES.
    while per_axis > 1
        && per_axis
            .checked_pow(exponent)
            .is_none_or(|count| count > MAX_NODES)
    {
        per_axis -= 1;
    }
    let rule = gauss_hermite(per_axis);
    // A dynamic copy: nalgebra's symmetric eigensolver has no const-generic form.
    let Some(eigen) = bounded_eigen(DMatrix::from_column_slice(N, N, covariance.as_slice())) else {
        return Vec::new();
    };
    let vectors = SMatrix::<f64, N, N>::from_column_slice(eigen.eigenvectors.as_slice());
    let scale = SVector::<f64, N>::from_fn(|i, _| eigen.eigenvalues[i].max(0.0).sqrt());
    let log_volume = 0.5 * N as f64 * (2.0 * PI).ln() + scale.iter().map(|s| s.ln()).sum::<f64>();
    let count = per_axis.checked_pow(exponent).unwrap_or(MAX_NODES);
    (0..count)
        .map(|index| {
            let mut rest = index;
            let mut z = SVector::<f64, N>::zeros();
            let mut log_weight = log_volume;
            for i in 0..N {
                let (u, w) = rule[rest % per_axis];
                rest /= per_axis;
                z[i] = u;
                log_weight += w.ln() + 0.5 * u * u;
            }
            (vectors * z.component_mul(&scale), log_weight.exp())
        })
        .collect()
}

/// `ln Σ wᵢ e^(fᵢ)` over the nodes, by log-sum-exp (no underflow however small the integrand).
pub fn log_integral<X>(nodes: &[(X, f64)], log_f: impl Fn(&X) -> f64) -> f64 {
    let values: Vec<f64> = nodes.iter().map(|(x, w)| w.ln() + log_f(x)).collect();
    let max = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if max == f64::NEG_INFINITY {
        return max;
    }
    max + values.iter().map(|v| (v - max).exp()).sum::<f64>().ln()
}

/// `Σ wᵢ f(xᵢ)`.
pub fn integral<X>(nodes: &[(X, f64)], f: impl Fn(&X) -> f64) -> f64 {
    nodes.iter().map(|(x, w)| w * f(x)).sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix2, Vector2};

    fn relative(got: f64, expected: f64) -> f64 {
        (got - expected).abs() / expected.abs().max(1e-300)
    }

    /// Degenerate arguments the helpers panicked on: `gauss_hermite(0)` and the zero-dimensional
    /// rules hit nalgebra's assert on an empty eigenproblem, and a NaN sphere width reached an
    /// `expect`. Zero nodes, R⁰'s one point, and the widest sphere rule.
    #[test]
    fn degenerate_rules_do_not_panic() {
        assert!(gauss_hermite(0).is_empty());
        let point = rn::<0>(&nalgebra::SVector::zeros(), &nalgebra::SMatrix::zeros(), 8);
        assert_eq!(point.len(), 1);
        assert!((point[0].1 - 1.0).abs() < f64::EPSILON);
        let axis = S2::new_unchecked(nalgebra::Vector3::z());
        let nan = sphere(&axis, f64::NAN);
        let widest = sphere(&axis, 2.0);
        assert_eq!(nan.len(), widest.len());
        let area: f64 = nan.iter().map(|(_, w)| w).sum();
        assert!(relative(area, 4.0 * PI) < 1e-12, "{area}");
    }

    /// ∫ e^(κ cos θ) dθ = 2π I₀(κ), with I₀ from its power series (κ ≤ 30) here, independent of the
    /// crate's Bessel functions.
    #[test]
    fn circle_integrates_von_mises_kernels() {
        for kappa in [0.0_f64, 1e-3, 1.0, 7.5, 30.0] {
            let q: f64 = (1..200)
                .scan(1.0, |term, k| {
                    *term *= (kappa * kappa / 4.0) / f64::from(k * k);
                    Some(*term)
                })
                .sum();
            let expected = 2.0 * PI * (1.0 + q);
            let nodes = circle(1.0 / (1.0 + kappa).sqrt());
            let got = integral(&nodes, |x| (kappa * x.cos()).exp());
            assert!(
                relative(got, expected) < 1e-14,
                "κ {kappa}: {got} vs {expected}"
            );
        }
        // Concentrated: the mass of e^(κ (cos θ − 1)) is √(2π/κ) (1 + 1/(8κ) + 9/(128κ²) + …).
        let kappa = 1e6_f64;
        // κ (cos θ − 1) as −2κ sin²(θ/2), which keeps its digits near θ = 0.
        let got = integral(&circle(1.0 / kappa.sqrt()), |x| {
            (-2.0 * kappa * (0.5 * x.angle()).sin().powi(2)).exp()
        });
        let expected =
            (2.0 * PI / kappa).sqrt() * (1.0 + 1.0 / (8.0 * kappa) + 9.0 / (128.0 * kappa * kappa));
        assert!(relative(got, expected) < 1e-13, "{got} vs {expected}");
    }

    /// ∫ e^(κ (a · x − 1)) dS = 2π (1 − e^(−2κ))/κ.
    #[test]
    fn sphere_integrates_von_mises_fisher_kernels() {
        let axis = S2::new(Vector3::new(0.3, -0.4, 0.5).normalize()).unwrap();
        for kappa in [0.0_f64, 1e-8, 0.5, 30.0, 1e6] {
            let expected = if kappa == 0.0 {
                4.0 * PI
            } else {
                -2.0 * PI * (-2.0 * kappa).exp_m1() / kappa
            };
            let got = integral(&sphere(&axis, 1.0 / (1.0 + kappa)), |x| {
                (-0.5 * kappa * (x.as_vector() - axis.as_vector()).norm_squared()).exp()
            });
            assert!(
                relative(got, expected) < 1e-13,
                "κ {kappa}: {got} vs {expected}"
            );
        }
        // A smooth non-isotropic integrand: ∫ x₁² dS = 4π/3 whatever the axis.
        let got = integral(&sphere(&axis, 1.0), |x| x.as_vector().x.powi(2));
        assert!(relative(got, 4.0 * PI / 3.0) < 1e-14);
    }

    /// Haar: ∫ 1 = 1 and the first character integrates to 0 (∫ (1 + 2 cos θ) = 0, θ the angle) for a
    /// spread that reaches the whole ball; an anisotropic kernel `e^(−|L⁻¹ξ|²/2)` in exponential
    /// coordinates against a tensor Gauss-Legendre rule over the box of 12 standard deviations (inside
    /// the ball); and the isotropic kernel `e^(−θ²/(2s))` against Simpson's rule on its angle density.
    #[test]
    fn so3_integrates_haar_measure_and_characters() {
        let center = So3::exp(&Vector3::new(0.4, -2.0, 1.1));
        for spread in [Matrix3::identity(), Matrix3::identity() * 0.5] {
            let nodes = so3(&center, &spread);
            let total = integral(&nodes, |_| 1.0);
            assert!((total - 1.0).abs() < 1e-13, "{spread}: ∫1 = {total}");
            let character = integral(&nodes, |x| {
                1.0 + 2.0 * center.inverse().compose(x).angle().cos()
            });
            assert!(character.abs() < 1e-13, "{spread}: ∫χ₁ = {character}");
        }
        let (s, c) = 0.9_f64.sin_cos();
        let rotation = Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0);
        let spread = rotation * Matrix3::from_diagonal(&Vector3::new(0.2, 0.05, 0.01));
        let inverse = spread.try_inverse().unwrap();
        let kernel = |xi: &Vector3<f64>| (-0.5 * (inverse * xi).norm_squared()).exp();
        let haar = |xi: &Vector3<f64>| half_angle_sinc_squared(xi.norm()) / (8.0 * PI * PI);
        let rule = gauss_legendre(20);
        let axis: Vec<(f64, f64)> = (0..6)
            .flat_map(|panel| {
                let (a, b) = (
                    -12.0 + 4.0 * f64::from(panel),
                    -8.0 + 4.0 * f64::from(panel),
                );
                rule.iter()
                    .map(move |(x, w)| (0.5 * (a + b) + 0.5 * (b - a) * x, 0.5 * (b - a) * w))
            })
            .collect();
        let mut tensor = 0.0;
        for (u, wu) in &axis {
            for (v, wv) in &axis {
                for (w, ww) in &axis {
                    let xi = spread * Vector3::new(*u, *v, *w);
                    tensor += wu * wv * ww * kernel(&xi) * haar(&xi);
                }
            }
        }
        tensor *= spread.determinant().abs();
        let got = integral(&so3(&center, &spread), |x| {
            kernel(&center.inverse().compose(x).log())
        });
        assert!(
            relative(got, tensor) < 1e-12,
            "anisotropic: {got} vs {tensor}"
        );
        for s in [1e-6, 1e-3, 0.1] {
            let n = 200_000;
            let h = PI / f64::from(n);
            let f = |t: f64| (-t * t / (2.0 * s)).exp() * (1.0 - t.cos()) / PI;
            let simpson = (0..=n)
                .map(|i| {
                    let weight = if i == 0 || i == n {
                        1.0
                    } else if i % 2 == 1 {
                        4.0
                    } else {
                        2.0
                    };
                    weight * f(h * f64::from(i))
                })
                .sum::<f64>()
                * h
                / 3.0;
            let nodes = so3(&center, &(Matrix3::identity() * s.sqrt()));
            let got = integral(&nodes, |x| {
                let t = center.inverse().compose(x).angle();
                (-t * t / (2.0 * s)).exp()
            });
            assert!(relative(got, simpson) < 1e-10, "s {s}: {got} vs {simpson}");
        }
    }

    /// `(2/π) ∫ g(sin θ, cos θ) cos²θ dθ` over [−π/2, π/2] (the expectation of g(x, √(1 − x²)) for one
    /// coordinate x of a uniform point of S³, whose density is `(2/π) √(1 − x²)`), by Gauss-Legendre on
    /// 4000 panels.
    fn one_coordinate(g: impl Fn(f64, f64) -> f64) -> f64 {
        let rule = gauss_legendre(20);
        let panels = 4000;
        let h = PI / f64::from(panels);
        (0..panels)
            .map(|k| {
                let mid = -0.5 * PI + h * (f64::from(k) + 0.5);
                rule.iter()
                    .map(|(x, w)| {
                        let theta = mid + 0.5 * h * x;
                        0.5 * h * w * g(theta.sin(), theta.cos()) * theta.cos().powi(2)
                    })
                    .sum::<f64>()
            })
            .sum::<f64>()
            * 2.0
            / PI
    }

    /// S³: ∫ 1 = 1 and `E[u₀²] = 1/4` (uniform), `E[e^(−a u₃²)]` with one axis concentrated (and the
    /// others diffuse, the disk in its iterated form), `E[e^(−a (u₁² + u₂² + u₃²))]` with all three
    /// concentrated (α peaked, the whitened disk), and the circle of maxima `E[e^(−a (u₂² + u₃²))] =
    /// (1 − e^(−a))/a`, in a rotated frame.
    #[test]
    fn s3_integrates_bingham_kernels() {
        let (s, c) = 0.3_f64.sin_cos();
        let frame = Matrix4::new(
            c, -s, 0.0, 0.0, s, c, 0.0, 0.0, 0.0, 0.0, c, s, 0.0, 0.0, -s, c,
        );
        let coordinate = |x: &Su2<f64>, k: usize| {
            let [w, a, b, d] = x.to_quaternion_wxyz();
            frame.column(k).dot(&nalgebra::Vector4::new(w, a, b, d))
        };
        let uniform = s3(&frame, &[10.0, 10.0, 10.0]);
        let total = integral(&uniform, |_| 1.0);
        assert!((total - 1.0).abs() < 1e-13, "∫1 = {total}");
        assert!((integral(&uniform, |x| coordinate(x, 0).powi(2)) - 0.25).abs() < 1e-13);
        for a in [1.0_f64, 60.0, 1e4, 1e6] {
            let width = 1.0 / (2.0 * a).sqrt();
            let nodes = s3(&frame, &[10.0, 10.0, width]);
            let got = integral(&nodes, |x| (-a * coordinate(x, 3).powi(2)).exp());
            let expected = one_coordinate(|u, _| (-a * u * u).exp());
            assert!(
                relative(got, expected) < 1e-11,
                "one axis, a {a}: {got} vs {expected}"
            );
            let nodes = s3(&frame, &[width, width, width]);
            // 1 − u₀² as u₁² + u₂² + u₃², and cos²θ, which keep their digits near the peak.
            let got = integral(&nodes, |x| {
                (-a * (1..4).map(|k| coordinate(x, k).powi(2)).sum::<f64>()).exp()
            });
            let expected = one_coordinate(|_, c| (-a * c * c).exp());
            assert!(
                relative(got, expected) < 1e-11,
                "three axes, a {a}: {got} vs {expected}"
            );
            let nodes = s3(&frame, &[10.0, width, width]);
            let got = integral(&nodes, |x| {
                (-a * (coordinate(x, 2).powi(2) + coordinate(x, 3).powi(2))).exp()
            });
            let expected = -(-a).exp_m1() / a;
            assert!(
                relative(got, expected) < 1e-11,
                "circle, a {a}: {got} vs {expected}"
            );
        }
    }

    /// The Gauss-Hermite rule integrates a Gaussian density to 1 and its second moments exactly, in
    /// a rotated frame with condition number 400 (the density itself evaluated through the inverse).
    #[test]
    fn rn_integrates_gaussians() {
        let (s, c) = 0.7_f64.sin_cos();
        let rotation = Matrix2::new(c, -s, s, c);
        let covariance = rotation * Matrix2::new(4.0, 0.0, 0.0, 0.01) * rotation.transpose();
        let mean = Vector2::new(3.0, -1.0);
        let nodes = rn(&mean, &covariance, 6);
        let inverse = covariance.try_inverse().unwrap();
        let log_norm = (2.0 * PI).ln() + 0.5 * covariance.determinant().ln();
        let density = |x: &Vector2<f64>| {
            let d = x - mean;
            (-0.5 * d.dot(&(inverse * d)) - log_norm).exp()
        };
        let total = integral(&nodes, density);
        assert!((total - 1.0).abs() < 1e-13, "∫ p = {total}");
        let second = integral(&nodes, |x| density(x) * (x - mean).x * (x - mean).y);
        assert!(relative(second, covariance[(0, 1)]) < 1e-12, "{second}");
    }
}
