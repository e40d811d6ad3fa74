//! The rotation nearest to a 3×3 matrix (the orthogonal polar factor with determinant +1), by a
//! one-sided Jacobi SVD that works for entries of any finite size.
//!
//! One-sided Jacobi (Hestenes) rotates pairs of columns of `W = M` until they are orthogonal:
//! `M V = W = U Σ` with V a product of plane rotations. It never squares an entry (norms and cosines
//! are computed from scaled vectors), so entries from the subnormal range to the largest finite value
//! can sit side by side, and it computes the singular directions of a matrix with columns of very
//! different sizes, `M = B D` with B well conditioned, to their own relative accuracy (Demmel and
//! Veselić, "Jacobi's method is more accurate than QR", 1992). A matrix whose rows vary more than its
//! columns is transposed first (`polar(Mᵀ) = polar(M)ᵀ`).
//!
//! From the two largest singular pairs `(u_a, v_a)`, `(u_b, v_b)` the rotation is
//! `Q = u_a v_aᵀ + u_b v_bᵀ + (u_a × u_b)(v_a × v_b)ᵀ`: the polar factor `U Vᵀ` when `det M > 0`, with
//! the third direction fixed by orientation, so the result is a rotation even when the smallest
//! singular value is below the rounding of the largest (Kabsch's determinant correction).

use crate::constants::POLAR_MAX_SWEEPS;
use crate::error::ManifoldError;
use crate::real::{Real, stable_norm};
use nalgebra::{Matrix3, Vector3};

/// The rotation nearest to the finite matrix `m` in the Frobenius norm.
///
/// # Errors
/// [`ManifoldError::NotProperRotation`] when `det m <= 0` (the sign taken from the factorisation,
/// reported as the determinant of `m` scaled to largest singular value 1);
/// [`ManifoldError::PolarNotConverged`] if the Jacobi sweeps reach their bound.
pub(crate) fn nearest_rotation<T: Real>(m: &Matrix3<T>) -> Result<Matrix3<T>, ManifoldError> {
    // The polar factor does not change under positive scaling. Scaling the largest entry to an
    // eighth of the largest finite value gives the small entries of a badly scaled matrix (even
    // subnormal ones) all the headroom there is, while the column norms and the sums of two of them
    // stay finite. Tiny matrices are lifted by √MAX first, at most three times (from the smallest
    // subnormal), so that the final factor does not overflow.
    let mut m = *m;
    if m.amax() == T::zero() {
        return Err(ManifoldError::NotProperRotation { det: 0.0 });
    }
    for _ in 0..3 {
        if m.amax() >= T::one() {
            break;
        }
        m *= T::max_finite().sqrt();
    }
    m *= T::max_finite() * T::lit(0.125) / m.amax();
    let (column_spread, row_spread) = (spread(&m), spread(&m.transpose()));
    let transposed = row_spread > column_spread;
    let w = if transposed { m.transpose() } else { m };
    let (w, v) = orthogonalize_columns(w)?;

    let sigma = Vector3::from_fn(|i, _| stable_norm(&w.column(i).into_owned()));
    let (a, b, c) = order(&sigma);
    let u_a = unit(&w.column(a).into_owned());
    // A column of subnormal size carries fewer significant bits, so its direction is orthogonal to
    // u_a only to its own precision (about 1e-11 for entries near 1e-312); projecting it off u_a
    // once, now that both are of order one, makes Q orthogonal to rounding.
    let u_b = unit(&w.column(b).into_owned());
    let u_b = unit(&(u_b - u_a * u_a.dot(&u_b)));
    let u_c = u_a.cross(&u_b);
    let (v_a, v_b) = (v.column(a).into_owned(), v.column(b).into_owned());
    let v_c = v_a.cross(&v_b);
    // det M = det W det Vᵀ, and det W = σ_a σ_b σ_c · sign(u_c · w_c) for orthogonal columns; V is a
    // product of rotations, but a, b, c need not be in cyclic order.
    let cyclic = if (a + 1) % 3 == b {
        T::one()
    } else {
        -T::one()
    };
    let orientation = if sigma[c] > T::zero() {
        cyclic * u_c.dot(&unit(&w.column(c).into_owned()))
    } else {
        T::zero()
    };
    if orientation <= T::zero() {
        let det = if orientation < T::zero() {
            -(sigma[b] / sigma[a]) * (sigma[c] / sigma[a])
        } else {
            T::zero()
        };
        return Err(ManifoldError::NotProperRotation { det: det.to_f64() });
    }
    let q = u_a * v_a.transpose() + u_b * v_b.transpose() + u_c * v_c.transpose();
    Ok(if transposed { q.transpose() } else { q })
}

/// `max |column| / min |column|` (infinite when a column is zero).
fn spread<T: Real>(m: &Matrix3<T>) -> T {
    let norms = Vector3::from_fn(|i, _| stable_norm(&m.column(i).into_owned()));
    norms.max() / norms.min()
}

/// The indices of the largest, middle and smallest of three values.
fn order<T: Real>(sigma: &Vector3<T>) -> (usize, usize, usize) {
    let c = sigma.imin();
    let (p, q) = ((c + 1) % 3, (c + 2) % 3);
    if sigma[p] >= sigma[q] {
        (p, q, c)
    } else {
        (q, p, c)
    }
}

/// `x / |x|` for any non-zero finite `x` (scaled first, so subnormal vectors normalise too).
fn unit<T: Real>(x: &Vector3<T>) -> Vector3<T> {
    let scale = x.amax();
    if scale == T::zero() {
        return *x;
    }
    let scaled = x / scale;
    scaled / scaled.norm()
}

/// One-sided Jacobi: plane rotations `J` applied to pairs of columns, `W ← W J`, `V ← V J`, until
/// every pair is orthogonal to a few epsilons (cosine of the angle between them) or a rotation no
/// longer changes the columns.
///
/// A column in the span of another (a singular matrix) is cancelled by a factor of about eps per
/// sweep, its residue being rounding parallel to the other column, until it is zero or subnormal;
/// that takes at most the exponent range over the digits, about 40 sweeps in f64.
fn orthogonalize_columns<T: Real>(
    mut w: Matrix3<T>,
) -> Result<(Matrix3<T>, Matrix3<T>), ManifoldError> {
    let mut v = Matrix3::<T>::identity();
    let tolerance = T::lit(4.0) * T::default_epsilon();
    for _ in 0..POLAR_MAX_SWEEPS {
        let mut rotated = false;
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            let (wp, wq) = (w.column(p).into_owned(), w.column(q).into_owned());
            let (alpha, beta) = (stable_norm(&wp), stable_norm(&wq));
            if alpha == T::zero() || beta == T::zero() {
                continue;
            }
            let (up, uq) = (wp / alpha, wq / beta);
            let gamma = up.dot(&uq);
            // A subnormal column has fewer significant bits: each entry is rounded to
            // eps · MIN_POSITIVE, so its direction is known only to about that over |w|, with a
            // margin of 16 for the three entries of both columns and their rotation.
            let precision = T::one() + T::lit(16.0) * T::min_positive() / alpha.min(beta);
            if gamma.abs() <= tolerance * precision {
                continue;
            }
            let r = Rotation::new(alpha, beta, gamma);
            // The columns move by (sin φ) β û_q and (sin φ) α û_p, computed without forming sin φ
            // alone, which underflows when the norms differ by more than the exponent range.
            let new_p = wp * r.cos - uq * r.sin_beta;
            let new_q = up * r.sin_alpha + wq * r.cos;
            if new_p == wp && new_q == wq {
                continue;
            }
            rotated = true;
            w.set_column(p, &new_p);
            w.set_column(q, &new_q);
            let (vp, vq) = (v.column(p).into_owned(), v.column(q).into_owned());
            v.set_column(p, &(vp * r.cos - vq * r.sin));
            v.set_column(q, &(vp * r.sin + vq * r.cos));
        }
        if !rotated {
            return Ok((w, v));
        }
    }
    Err(ManifoldError::PolarNotConverged {
        sweeps: POLAR_MAX_SWEEPS,
    })
}

/// The plane rotation by φ that makes two columns of norms α, β and cosine γ orthogonal:
/// `w_p ← cos φ w_p − sin φ w_q`, `w_q ← sin φ w_p + cos φ w_q`.
struct Rotation<T> {
    cos: T,
    sin: T,
    /// `sin φ · α`.
    sin_alpha: T,
    /// `sin φ · β`.
    sin_beta: T,
}

impl<T: Real> Rotation<T> {
    /// `t = tan φ` is the root of `t² + 2ζ t − 1 = 0` of smaller magnitude, `ζ = (β² − α²) / (2γαβ)`:
    /// `t = sign(ζ) / (|ζ| + √(1 + ζ²))`. With ρ = min(α, β) / max(α, β), `1/|ζ| = 2|γ|ρ / (1 − ρ²)`
    /// is used where it is small (columns of very different sizes), and `t · max(α, β)` is computed
    /// from `ρ · max(α, β) = min(α, β)`, so nothing overflows or underflows that matters.
    fn new(alpha: T, beta: T, gamma: T) -> Self {
        let (small, large) = (alpha.min(beta), alpha.max(beta));
        let rho = small / large;
        let twice_gamma = gamma.abs() + gamma.abs();
        let one_minus_rho2 = T::one() - rho * rho;
        let inverse_zeta = twice_gamma * rho / one_minus_rho2;
        let (t, t_large) = if inverse_zeta > T::one() {
            let zeta = T::one() / inverse_zeta;
            let t = T::one() / (zeta + T::one().hypot(zeta));
            (t, t * large)
        } else {
            let denominator = T::one() + T::one().hypot(inverse_zeta);
            // `small` enters last: 2γ · small first would be a subnormal product with a few
            // significant bits when both columns are subnormal and nearly orthogonal, and the
            // rotation then misses by more than it corrects (the sweeps never end).
            (
                inverse_zeta / denominator,
                twice_gamma / one_minus_rho2 / denominator * small,
            )
        };
        let sign = if (beta >= alpha) == (gamma > T::zero()) {
            T::one()
        } else {
            -T::one()
        };
        let cos = T::one() / T::one().hypot(t);
        let (sin_large, sin_small) = (sign * cos * t_large, sign * cos * t * small);
        let (sin_alpha, sin_beta) = if alpha >= beta {
            (sin_large, sin_small)
        } else {
            (sin_small, sin_large)
        };
        Self {
            cos,
            sin: sign * cos * t,
            sin_alpha,
            sin_beta,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rotation makes the two columns orthogonal, also for very different norms.
    #[test]
    fn rotation_orthogonalizes_a_pair() {
        for (alpha, beta, gamma) in [
            (1.0, 1.0, 0.3),
            (1.0, 2.0, -0.7),
            (3.0, 1e-3, 0.999),
            (1e-200, 1.0, 0.5),
            (1.0, 1e-300, -0.5),
        ] {
            let r = Rotation::new(alpha, beta, gamma);
            // With unit columns û_p, û_q at cosine γ: ⟨cos α û_p − sin β û_q, sin α û_p + cos β û_q⟩.
            let inner = r.cos * r.sin_alpha * alpha - r.cos * r.sin_beta * beta
                + (r.cos * r.cos * alpha * beta - r.sin_alpha * r.sin_beta) * gamma;
            assert!(
                f64::abs(inner) <= 4.0 * f64::EPSILON * alpha * beta,
                "{alpha} {beta} {gamma}: {inner:e}"
            );
            assert!((r.cos.hypot(r.sin) - 1.0).abs() <= f64::EPSILON);
            assert!(
                (r.sin_alpha - r.sin * alpha).abs()
                    <= 1e-300 + 2.0 * f64::EPSILON * r.sin_alpha.abs()
            );
        }
    }
}
