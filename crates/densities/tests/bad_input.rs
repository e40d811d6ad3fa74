//! Bad input, on purpose: every public constructor, special function, log density, sampler, product,
//! convolution, entropy, KL divergence and moment of the families (TangentGaussian and the moment
//! matching aside) called with arguments drawn from NaN, ±∞, ±f64::MAX, ±MIN_POSITIVE, subnormals, ±0,
//! 1e±300 and ordinary numbers. Each call runs on its own thread under a time limit and must return an
//! error or a finite result (samples on their manifold, densities with finite normalisers).
//!
//! Sized for CI (64 cases per family); `LIEBAYES_FUZZ_CASES=20000 cargo test --release -p
//! liebayes-densities --test bad_input` is the long run (figures in docs/reliability.md).

mod common;

use common::fuzz::{self, Valid, call, check, checked, magnitude, value};
use liebayes_densities::manifolds::{LieGroup, S2, So2, So3, Su2};
use liebayes_densities::{
    Bingham, Convolve, Density, Entropy, Gaussian, GenVonMises2, HeatKernelSo3, KlDivergence,
    Product, Rotate, VonMises, VonMisesFisher, special,
};
use nalgebra::{Matrix2, Matrix3, Matrix4, Quaternion, Vector2, Vector3, Vector4};
use proptest::prelude::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Distance from the unit norm accepted for a sample.
const ON_MANIFOLD: f64 = 1e-12;

fn unit(norm_squared: f64, what: &str) -> Result<(), String> {
    if (norm_squared - 1.0).abs() <= ON_MANIFOLD {
        Ok(())
    } else {
        Err(format!(
            "{what} off its manifold: squared norm {norm_squared}"
        ))
    }
}

/// Points on a manifold, as a wrapper (the harness's trait is local, the point types are not).
struct Point<T>(T);

impl Valid for Point<So2<f64>> {
    fn valid(&self) -> Result<(), String> {
        unit(self.0.cos().powi(2) + self.0.sin().powi(2), "SO(2) point")
    }
}

impl Valid for Point<S2<f64>> {
    fn valid(&self) -> Result<(), String> {
        unit(self.0.as_vector().norm_squared(), "S2 point")
    }
}

impl Valid for Point<Su2<f64>> {
    fn valid(&self) -> Result<(), String> {
        unit(
            self.0.to_quaternion_wxyz().iter().map(|v| v * v).sum(),
            "SU(2) point",
        )
    }
}

impl Valid for Point<So3<f64>> {
    fn valid(&self) -> Result<(), String> {
        unit(
            self.0.to_quaternion_wxyz().iter().map(|v| v * v).sum(),
            "SO(3) point",
        )
    }
}

/// A density is valid when its normaliser is finite.
struct Dens<T>(T);

impl<T: Density> Valid for Dens<T> {
    fn valid(&self) -> Result<(), String> {
        self.0.log_normalizer().valid()
    }
}

/// A rotation from a rotation vector, or the identity where it is not one. (The manifolds crate's
/// `So3::from_rotation_vector` returns a NaN quaternion for vectors whose norm overflows, such as
/// (f64::MAX, f64::MAX, f64::MAX); that is outside this crate and reported separately.)
fn so3(v: Vector3<f64>) -> So3<f64> {
    So3::from_rotation_vector(&v)
        .ok()
        .filter(|r| Point(*r).valid().is_ok())
        .unwrap_or_else(So3::identity)
}

fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

/// The calls every density supports: log density at each point, normaliser, three samples, mode.
fn density_calls<D>(name: &'static str, p: &D, points: &[D::Point], check_point: fn(&D::Point))
where
    D: Density + Clone + Send + 'static,
    D::Point: Clone + Send + 'static,
{
    for x in points {
        let (q, x) = (p.clone(), x.clone());
        check(name, &call(name, move || q.log_pdf(&x)));
    }
    let q = p.clone();
    check(name, &call(name, move || q.log_normalizer()));
    let q = p.clone();
    let samples = call(name, move || {
        let mut r = rng(7);
        [q.sample(&mut r), q.sample(&mut r), q.sample(&mut r)]
    });
    samples.iter().for_each(check_point);
    let q = p.clone();
    if let Some(mode) = call(name, move || q.mode()) {
        check_point(&mode);
    }
}

fn so2(angle: f64) -> Option<So2<f64>> {
    So2::from_angle(angle).ok()
}

fn so2_points(angles: &[f64]) -> Vec<So2<f64>> {
    let mut points: Vec<So2<f64>> = angles.iter().filter_map(|&a| so2(a)).collect();
    points.extend([0.0, std::f64::consts::PI, 1e-300].map(So2::from_angle_unchecked));
    points
}

fn check_so2(x: &So2<f64>) {
    check("SO(2) sample", &Point(*x));
}

fn check_s2(x: &S2<f64>) {
    check("S2 sample", &Point(*x));
}

fn check_su2(x: &Su2<f64>) {
    check("SU(2) sample", &Point(*x));
}

fn check_so3(x: &So3<f64>) {
    check("SO(3) sample", &Point(*x));
}

#[test]
fn special_functions() {
    fuzz::run(
        "special functions",
        (value(), value(), any::<u32>(), 0..200_000_u32),
        |(k, r, n, small_n)| {
            type F = fn(f64) -> Result<f64, liebayes_densities::DensityError>;
            let functions: [(&str, F); 10] = [
                ("log_i0", special::log_i0),
                ("log_i0_scaled", special::log_i0_scaled),
                ("a1", special::a1),
                ("one_minus_a1", special::one_minus_a1),
                ("a2", special::a2),
                ("a1_derivative", special::a1_derivative),
                ("a1_inverse", special::a1_inverse),
                ("vmf_mean_resultant", special::vmf_mean_resultant),
                (
                    "vmf_mean_resultant_inverse",
                    special::vmf_mean_resultant_inverse,
                ),
                ("vmf_log_normalizer", special::vmf_log_normalizer),
            ];
            for (name, f) in functions {
                for x in [k, r] {
                    checked(name, call(name, move || f(x)));
                }
            }
            // ln I₁(0) = −∞ exactly, the one documented infinity.
            match call("log_i1", move || special::log_i1(k)) {
                Ok(v) if k == 0.0 => assert_eq!(v, f64::NEG_INFINITY),
                result => drop(checked("log_i1", result)),
            }
            for order in [n, small_n, 0, 1, special::MAX_ORDER] {
                checked(
                    "bessel_ratio",
                    call("bessel_ratio", move || special::bessel_ratio(order, k)),
                );
            }
            checked(
                "scaled_i0_i1",
                call("scaled_i0_i1", move || special::scaled_i0_i1(k)),
            );
        },
    );
}

#[test]
fn von_mises() {
    fuzz::run(
        "VonMises",
        (
            proptest::array::uniform4(value()),
            proptest::array::uniform4(value()),
            any::<u32>(),
        ),
        |(a, b, n)| {
            let candidates = [
                call("VonMises::from_natural", move || {
                    VonMises::from_natural(Vector2::new(a[0], a[1]))
                }),
                call("VonMises::new", move || {
                    So2::from_angle(a[2])
                        .map_err(Into::into)
                        .and_then(|m| VonMises::new(m, a[3]))
                }),
                call("VonMises::from_first_moment", move || {
                    VonMises::from_first_moment(Vector2::new(b[0], b[1]))
                }),
                Ok(VonMises::uniform()),
            ];
            let other = VonMises::from_natural(Vector2::new(b[2], b[3]))
                .unwrap_or_else(|_| VonMises::uniform());
            let points = so2_points(&[b[0], b[3]]);
            for p in candidates
                .into_iter()
                .filter_map(|c| checked("VonMises", c.map(Dens)))
            {
                let p = p.0;
                density_calls("VonMises", &p, &points, check_so2);
                let q = other;
                checked(
                    "VonMises::product",
                    call("product", move || p.product(&q).map(Dens)),
                );
                checked(
                    "log_product_integral",
                    call("lpi", move || p.log_product_integral(&q)),
                );
                check("entropy", &call("entropy", move || p.entropy()));
                check("kl_divergence", &call("kl", move || p.kl_divergence(&q)));
                check("kl_divergence", &call("kl", move || q.kl_divergence(&p)));
                for order in [n, 1, 2, special::MAX_ORDER] {
                    checked(
                        "trigonometric_moment",
                        call("moment", move || p.trigonometric_moment(order)),
                    );
                }
                check(
                    "mean_resultant_length",
                    &call("A", move || p.mean_resultant_length()),
                );
                check(
                    "circular_variance",
                    &call("1 - A", move || p.circular_variance()),
                );
                let c = call("convolve_moment_matched", move || {
                    p.convolve_moment_matched(&q)
                });
                check("convolve_moment_matched", &Dens(c));
            }
        },
    );
}

#[test]
fn gen_von_mises() {
    fuzz::run(
        "GenVonMises2",
        (
            proptest::array::uniform4(value()),
            proptest::array::uniform4(value()),
        ),
        |(a, b)| {
            let made = call("GenVonMises2::new", move || {
                GenVonMises2::from_natural(Vector2::new(a[0], a[1]), Vector2::new(a[2], a[3]))
                    .map(Dens)
            });
            let Some(Dens(p)) = checked("GenVonMises2::new", made) else {
                return;
            };
            let other =
                GenVonMises2::from_natural(Vector2::new(b[0], b[1]), Vector2::new(b[2], b[3]))
                    .unwrap_or_else(|_| {
                        GenVonMises2::from_natural(Vector2::zeros(), Vector2::zeros()).unwrap()
                    });
            density_calls("GenVonMises2", &p, &so2_points(&[b[0], b[2]]), check_so2);
            let (q, r) = (p.clone(), other.clone());
            let kept = call("GenVonMises2::sampler", move || {
                let sampler = q.sampler();
                let mut g = rng(3);
                [0; 3].map(|_| rand::distr::Distribution::sample(&sampler, &mut g))
            });
            kept.iter().for_each(check_so2);
            let q = p.clone();
            checked("product", call("product", move || q.product(&r).map(Dens)));
            let (q, r) = (p.clone(), other.clone());
            checked(
                "log_product_integral",
                call("lpi", move || q.log_product_integral(&r)),
            );
            let (q, r) = (p.clone(), other.clone());
            let e = q.clone();
            check("entropy", &call("entropy", move || e.entropy()));
            check("kl", &call("kl", move || q.kl_divergence(&r)));
            let q = p.clone();
            check(
                "moments",
                &call("moments", move || q.trigonometric_moments()),
            );
        },
    );
}

#[test]
fn von_mises_fisher() {
    fuzz::run(
        "VonMisesFisher",
        (
            proptest::array::uniform4(value()),
            proptest::array::uniform4(value()),
        ),
        |(a, b)| {
            let candidates = [
                call("VonMisesFisher::new", move || {
                    S2::from_vector_normalizing(&Vector3::new(a[0], a[1], a[2]))
                        .map_err(Into::into)
                        .and_then(|m| VonMisesFisher::new(m, a[3]))
                }),
                call("VonMisesFisher::from_natural", move || {
                    VonMisesFisher::from_natural(Vector3::new(b[0], b[1], b[2]))
                }),
                call("VonMisesFisher::from_first_moment", move || {
                    VonMisesFisher::from_first_moment(Vector3::new(b[0], b[1], b[2]))
                }),
                Ok(VonMisesFisher::uniform()),
            ];
            let other = VonMisesFisher::from_natural(Vector3::new(b[3], a[0], b[1]))
                .unwrap_or_else(|_| VonMisesFisher::uniform());
            let mut points: Vec<S2<f64>> =
                [Vector3::new(a[1], b[2], b[3]), Vector3::z(), -Vector3::z()]
                    .iter()
                    .filter_map(|v| S2::from_vector_normalizing(v).ok())
                    .collect();
            points.push(S2::new_unchecked(Vector3::x()));
            let rotation = so3(Vector3::new(b[0], a[2], 0.5));
            for p in candidates
                .into_iter()
                .filter_map(|c| checked("VonMisesFisher", c.map(Dens)))
            {
                let p = p.0;
                density_calls("VonMisesFisher", &p, &points, check_s2);
                let q = other;
                checked("product", call("product", move || p.product(&q).map(Dens)));
                checked("lpi", call("lpi", move || p.log_product_integral(&q)));
                check("entropy", &call("entropy", move || p.entropy()));
                check("kl", &call("kl", move || p.kl_divergence(&q)));
                check("kl", &call("kl", move || q.kl_divergence(&p)));
                check("mean_vector", &call("mean", move || p.first_moment()));
                checked(
                    "rotated",
                    call("rotated", move || p.rotated(&rotation).map(Dens)),
                );
            }
            assert_eq!(
                VonMisesFisher::new(S2::new_unchecked(Vector3::x()), 0.0),
                Ok(VonMisesFisher::uniform())
            );
        },
    );
}

/// A unit quaternion from four numbers, or the identity where they do not normalise.
fn su2(v: [f64; 4]) -> Su2<f64> {
    Su2::from_quaternion_normalizing(Quaternion::new(v[0], v[1], v[2], v[3]))
        .unwrap_or_else(|_| Su2::identity())
}

/// Left times right multiplication: an orthogonal 4×4 matrix from two unit quaternions.
fn so4(a: Su2<f64>, b: Su2<f64>) -> Matrix4<f64> {
    let [w1, x1, y1, z1] = a.to_quaternion_wxyz();
    let [w2, x2, y2, z2] = b.to_quaternion_wxyz();
    let left = Matrix4::new(
        w1, -x1, -y1, -z1, x1, w1, -z1, y1, y1, z1, w1, -x1, z1, -y1, x1, w1,
    );
    let right = Matrix4::new(
        w2, -x2, -y2, -z2, x2, w2, z2, -y2, y2, -z2, w2, x2, z2, y2, -x2, w2,
    );
    left * right
}

#[test]
fn bingham() {
    fuzz::run(
        "Bingham",
        (
            proptest::array::uniform10(value()),
            proptest::array::uniform4(value()),
            proptest::array::uniform4(-1.0..1.0_f64),
            proptest::array::uniform4(-1.0..1.0_f64),
        ),
        |(m, z, qa, qb)| {
            let symmetric = Matrix4::new(
                m[0], m[4], m[5], m[6], m[4], m[1], m[7], m[8], m[5], m[7], m[2], m[9], m[6], m[8],
                m[9], m[3],
            );
            let orientation = so4(su2(qa), su2(qb));
            let candidates = [
                call("Bingham::from_natural", move || {
                    Bingham::from_natural(symmetric)
                }),
                call("Bingham::new", move || {
                    Bingham::new(orientation, Vector4::from(z))
                }),
                call("Bingham::from_second_moment", move || {
                    Bingham::from_second_moment(symmetric)
                }),
                call("Bingham::from_second_moment", move || {
                    Bingham::from_second_moment(
                        orientation
                            * Matrix4::from_diagonal(&Vector4::from(z).abs())
                            * orientation.transpose(),
                    )
                }),
            ];
            checked(
                "bingham_log_normalizer_and_moments",
                call("normaliser", move || {
                    special::bingham_log_normalizer_and_moments(&z)
                }),
            );
            let other =
                Bingham::from_natural(Matrix4::from_diagonal(&Vector4::new(0.0, -1.0, -2.0, -3.0)))
                    .expect("valid");
            let points = [
                su2(qa),
                su2(qb),
                su2([1.0, 0.0, 0.0, 0.0]),
                su2([0.0, 0.0, 0.0, 1.0]),
            ];
            let g = su2(qb);
            for p in candidates
                .into_iter()
                .filter_map(|c| checked("Bingham", c.map(Dens)))
            {
                let p = p.0;
                density_calls("Bingham", &p, &points, check_su2);
                let (q, r) = (p.clone(), other.clone());
                checked("product", call("product", move || q.product(&r).map(Dens)));
                let (q, r) = (p.clone(), other.clone());
                checked(
                    "log_product_integral",
                    call("lpi", move || q.log_product_integral(&r)),
                );
                let (q, r) = (p.clone(), other.clone());
                let e = q.clone();
                check("entropy", &call("entropy", move || e.entropy()));
                check("kl", &call("kl", move || q.kl_divergence(&r)));
                let (q, r) = (p.clone(), other.clone());
                check("kl", &call("kl", move || r.kl_divergence(&q)));
                let q = p.clone();
                check("moments", &call("moments", move || q.second_moment()));
                let q = p.clone();
                checked("rotated", call("rotated", move || q.rotated(&g).map(Dens)));
            }
        },
    );
}

#[test]
fn heat_kernel() {
    fuzz::run(
        "HeatKernelSo3",
        (
            value(),
            value(),
            proptest::array::uniform3(value()),
            any::<u32>(),
        ),
        |(s, t, v, l)| {
            let centre = so3(Vector3::from(v));
            let made = call("HeatKernelSo3::new", move || {
                HeatKernelSo3::new(centre, s).map(Dens)
            });
            let Some(Dens(p)) = checked("HeatKernelSo3::new", made) else {
                return;
            };
            let other = HeatKernelSo3::new(So3::identity(), 0.1).expect("valid");
            let points = [
                centre,
                So3::identity(),
                So3::from_rotation_vector(&Vector3::new(0.0, 0.0, std::f64::consts::PI))
                    .expect("finite"),
            ];
            density_calls("HeatKernelSo3", &p, &points, check_so3);
            checked(
                "log_density_of_angle",
                call("angle", move || p.log_density_of_angle(t)),
            );
            checked("angle_pdf", call("angle pdf", move || p.angle_pdf(t)));
            checked("angle_cdf", call("angle cdf", move || p.angle_cdf(t)));
            for angle in [0.0, 1e-300, 1.0, std::f64::consts::PI] {
                check(
                    "log_density_of_angle",
                    &call("angle", move || p.log_density_of_angle(angle).unwrap()),
                );
                check(
                    "angle_cdf",
                    &call("angle cdf", move || p.angle_cdf(angle).unwrap()),
                );
            }
            check(
                "fourier_coefficient",
                &call("fourier", move || p.fourier_coefficient(l)),
            );
            check("mean_matrix", &call("mean", move || p.first_moment()));
            checked(
                "convolve",
                call("convolve", move || p.convolve(&other).map(Dens)),
            );
            checked(
                "convolve",
                call("convolve", move || p.convolve(&p).map(Dens)),
            );
            check("entropy", &call("entropy", move || p.entropy()));
            check("kl", &call("kl", move || p.kl_divergence(&other)));
            check("kl", &call("kl", move || other.kl_divergence(&p)));
        },
    );
}

/// The Gaussian's log density may be −∞ where the Mahalanobis distance overflows (documented), never
/// NaN or +∞.
fn check_gaussian_log_pdf(value: f64) {
    assert!(
        !value.is_nan() && value != f64::INFINITY,
        "Gaussian log_pdf {value}"
    );
}

#[test]
fn gaussian() {
    fuzz::run(
        "Gaussian",
        (
            proptest::array::uniform3(value()),
            proptest::array::uniform3(magnitude()),
            proptest::array::uniform3(-1.0..1.0_f64),
            proptest::array::uniform3(value()),
            proptest::array::uniform4(value()),
        ),
        |(mean, scales, correlation, x, raw)| {
            // Σ = D C D with D = diag(scales) and C a correlation-like matrix; and a raw 2×2.
            let c = Matrix3::new(
                1.0,
                correlation[0],
                correlation[1],
                correlation[0],
                1.0,
                correlation[2],
                correlation[1],
                correlation[2],
                1.0,
            );
            let d = Matrix3::from_diagonal(&Vector3::from(scales));
            let covariance = d * c * d;
            let mean = Vector3::from(mean);
            let candidates = [
                call("Gaussian::new", move || Gaussian::new(mean, covariance)),
                call("Gaussian::from_natural", move || {
                    Gaussian::from_natural(mean, covariance)
                }),
            ];
            let raw = Matrix2::new(raw[0], raw[1], raw[2], raw[3]);
            checked(
                "Gaussian<2>::new",
                call("Gaussian<2>", move || {
                    Gaussian::new(Vector2::new(raw[(0, 1)], 1.0), raw).map(Dens)
                }),
            );
            let other = Gaussian::new(Vector3::new(1.0, 2.0, 3.0), Matrix3::identity() * 2.0)
                .expect("valid");
            let x = Vector3::from(x).map(|v| if v.is_finite() { v } else { 0.0 });
            for p in candidates
                .into_iter()
                .filter_map(|c| checked("Gaussian", c.map(Dens)))
            {
                let p = p.0;
                for point in [x, *p.mean(), Vector3::zeros()] {
                    let q = p.clone();
                    check_gaussian_log_pdf(call("log_pdf", move || q.log_pdf(&point)));
                }
                let q = p.clone();
                check(
                    "log_normalizer",
                    &call("normaliser", move || q.log_normalizer()),
                );
                let q = p.clone();
                check("sample", &call("sample", move || q.sample(&mut rng(5))));
                let (q, r) = (p.clone(), other.clone());
                checked("product", call("product", move || q.product(&r).map(Dens)));
                let (q, r) = (p.clone(), other.clone());
                checked(
                    "convolve",
                    call("convolve", move || q.convolve(&r).map(Dens)),
                );
                let (q, r) = (p.clone(), other.clone());
                checked("lpi", call("lpi", move || q.log_product_integral(&r)));
                let (q, r) = (p.clone(), other.clone());
                let e = q.clone();
                check("entropy", &call("entropy", move || e.entropy()));
                check("kl", &call("kl", move || q.kl_divergence(&r)));
                let (q, r) = (p.clone(), other.clone());
                check("kl", &call("kl", move || r.kl_divergence(&q)));
                let q = p.clone();
                check("information", &call("information", move || q.natural().1));
            }
        },
    );
}

/// A first moment whose squared norm is subnormal (|m| = 1.8e-161) gives a mean on the sphere: its
/// length was the square root of a subnormal, 0.1 % short (found by a long run of this harness).
#[test]
fn a_first_moment_of_subnormal_squared_norm_gives_a_unit_mean() {
    let m = Vector3::new(
        f64::MIN_POSITIVE,
        1.776_620_520_857_379_1e-161,
        f64::MIN_POSITIVE,
    );
    let p = VonMisesFisher::from_first_moment(m).unwrap();
    let mean = p.mean().unwrap();
    assert!((mean.as_vector().norm_squared() - 1.0).abs() <= 4.0 * f64::EPSILON);
    assert!(p.concentration() > 0.0 && p.concentration() < 1e-159);
}

/// A world-frame Gaussian on SE(3) moved by a pose whose translation is near overflow: Ad(g) is
/// huge, and `Ad(g) P Ad(g)ᵀ` leaves the Gaussians' range. It is an error, not a density with
/// infinite covariance; a translation in range gives a valid density.
#[test]
fn a_gaussian_moved_by_a_huge_translation_is_an_error() {
    use liebayes_densities::ManifoldGaussian;
    use liebayes_densities::manifolds::{Left, Se3};
    let p =
        ManifoldGaussian::new(Left::new(Se3::identity()), nalgebra::Matrix6::identity()).unwrap();
    let pose = |t: f64| {
        let rotation = so3(Vector3::new(0.3, -0.2, 0.1));
        Left::new(Se3::new(rotation, Vector3::new(t, -t, 0.5 * t)).unwrap())
    };
    for t in [1e60, 1e200, f64::MAX] {
        assert!(p.rotated(&pose(t)).is_err(), "translation {t:e}");
    }
    let moved = p.rotated(&pose(1e3)).unwrap();
    assert!(moved.covariance().iter().all(|v| v.is_finite()));
    assert!(moved.log_pdf(moved.mean()).is_finite());
}
