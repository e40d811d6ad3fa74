//! Log densities, entropies and KL divergences against 50-digit values (`tests/data/`, made by
//! `tools/reference_densities.py`), at concentrations up to 1e6, variances from 1e-300 to 1e300.
//!
//! Errors are measured in ulps of the **sum of the magnitudes of the terms** a value is made of (for
//! the von Mises log density `|κ (cos d − 1)| + ln 2π + |ln I₀(κ) − κ|`): that is the accuracy a sum of
//! correctly rounded terms has, and it is what the old forms missed by hundreds of ulps (their terms
//! were of size κ: 164 ulps for the von Mises at κ = 800). Where the value does not cancel, it is the
//! plain relative error. One bound serves every family, 3 ulps; the measured worst case is 2.3 ulps
//! (GenVonMises2), and each test prints its own.

use liebayes_densities::manifolds::{LieGroup, S2, So2, So3, Su2};
use liebayes_densities::{
    Bingham, Density, Entropy, Gaussian, GenVonMises2, HeatKernelSo3, KlDivergence, VonMises,
    VonMisesFisher, special,
};
use liebayes_reference::Value;
use nalgebra::{Matrix3, Matrix4, Vector2, Vector3, Vector4};
use std::f64::consts::PI;

fn data() -> Value {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/density_reference.json"
    );
    std::fs::read_to_string(path)
        .expect("tests/data/density_reference.json is part of the repository")
        .parse()
        .expect("valid JSON")
}

/// A number stored as its shortest round-tripping decimal string.
fn num(v: &Value) -> f64 {
    v.as_str()
        .expect("numbers are stored as strings")
        .parse()
        .expect("an f64")
}

fn nums(v: &Value) -> Vec<f64> {
    v.as_array().expect("an array").iter().map(num).collect()
}

fn rows<'a>(data: &'a Value, key: &str) -> &'a Vec<Value> {
    data[key].as_array().expect("a table")
}

/// Tracks the worst error in ulps of a scale; [`Ulps::finish`] asserts the bound on every value.
struct Ulps {
    what: &'static str,
    bound: f64,
    worst: f64,
    count: usize,
    failures: Vec<String>,
}

impl Ulps {
    fn new(what: &'static str, bound: f64) -> Self {
        Self {
            what,
            bound,
            worst: 0.0,
            count: 0,
            failures: Vec::new(),
        }
    }

    fn check(&mut self, got: f64, expected: f64, scale: f64, case: &str) {
        let ulps = (got - expected).abs() / (f64::EPSILON * scale.max(expected.abs()));
        if ulps.is_nan() || ulps > self.bound {
            self.failures.push(format!(
                "{case}: got {got:e}, expected {expected:e}: {ulps:.1} ulps"
            ));
        }
        self.worst = self.worst.max(ulps);
        self.count += 1;
    }

    fn finish(self) {
        eprintln!(
            "{}: {} values, worst {:.2} ulps (bound {})",
            self.what, self.count, self.worst, self.bound
        );
        assert!(
            self.failures.is_empty(),
            "{}: {} values beyond {} ulps:\n{}",
            self.what,
            self.failures.len(),
            self.bound,
            self.failures.join("\n")
        );
    }
}

fn log_scaled_i0(kappa: f64) -> f64 {
    special::log_i0_scaled(kappa).expect("valid kappa")
}

#[test]
fn von_mises() {
    let data = data();
    let mut log_pdf = Ulps::new("von Mises log_pdf", 3.0);
    for row in rows(&data, "von_mises") {
        let (kappa, d) = (num(&row["kappa"]), num(&row["d"]));
        let p = VonMises::from_natural(Vector2::new(kappa, 0.0)).unwrap();
        let got = p.log_pdf(&So2::from_angle(d).unwrap());
        let half = (0.5 * d).sin();
        let scale = 2.0 * kappa * half * half + (2.0 * PI).ln() + log_scaled_i0(kappa).abs();
        log_pdf.check(
            got,
            num(&row["log_pdf"]),
            scale,
            &format!("κ {kappa:e}, d {d}"),
        );
    }
    let mut entropy = Ulps::new("von Mises entropy", 3.0);
    for row in rows(&data, "von_mises_entropy") {
        let kappa = num(&row["kappa"]);
        let p = VonMises::from_natural(Vector2::new(kappa, 0.0)).unwrap();
        let scale = (2.0 * PI).ln() + log_scaled_i0(kappa).abs() + 0.5;
        entropy.check(
            p.entropy(),
            num(&row["entropy"]),
            scale,
            &format!("κ {kappa:e}"),
        );
    }
    let mut kl = Ulps::new("von Mises KL", 3.0);
    for row in rows(&data, "von_mises_kl") {
        let (kp, kq, delta) = (
            num(&row["kappa_p"]),
            num(&row["kappa_q"]),
            num(&row["delta"]),
        );
        let p = VonMises::from_natural(Vector2::new(kp, 0.0)).unwrap();
        let q = VonMises::new(So2::from_angle(delta).unwrap(), kq).unwrap();
        let one_minus = special::one_minus_a1(kp).unwrap();
        let scale = log_scaled_i0(kp).abs()
            + log_scaled_i0(kq).abs()
            + kq * (1.0 - delta.cos())
            + one_minus * (kp + kq);
        kl.check(
            p.kl_divergence(&q),
            num(&row["kl"]),
            scale,
            &format!("κp {kp:e}, κq {kq:e}, Δ {delta}"),
        );
    }
    log_pdf.finish();
    entropy.finish();
    kl.finish();
}

#[test]
fn von_mises_fisher() {
    let data = data();
    let pole = S2::new(Vector3::z()).unwrap();
    let mut log_pdf = Ulps::new("von Mises-Fisher log_pdf", 3.0);
    for row in rows(&data, "von_mises_fisher") {
        let kappa = num(&row["kappa"]);
        let x = nums(&row["x"]);
        let point = S2::new_unchecked(Vector3::new(x[0], x[1], x[2]));
        let p = VonMisesFisher::new(pole, kappa).unwrap();
        let gap = x[0] * x[0] + (x[2] - 1.0).powi(2);
        // The terms of ln C(κ) + κ: ln κ − ln 2π − ln(1 − e^(−2κ)) (or −ln 4π − … below κ = 1).
        let scale = kappa.max(1.0).ln() + (4.0 * PI).ln() + 0.5 * kappa * gap;
        log_pdf.check(
            p.log_pdf(&point),
            num(&row["log_pdf"]),
            scale,
            &format!("κ {kappa:e}, t {}", num(&row["t"])),
        );
    }
    let mut entropy = Ulps::new("von Mises-Fisher entropy", 3.0);
    for row in rows(&data, "von_mises_fisher_entropy") {
        let kappa = num(&row["kappa"]);
        let p = VonMisesFisher::new(pole, kappa).unwrap();
        let scale = kappa.max(1.0).ln() + (4.0 * PI).ln() + 1.0;
        entropy.check(
            p.entropy(),
            num(&row["entropy"]),
            scale,
            &format!("κ {kappa:e}"),
        );
    }
    let mut kl = Ulps::new("von Mises-Fisher KL", 3.0);
    for row in rows(&data, "von_mises_fisher_kl") {
        let (kp, kq) = (num(&row["kappa_p"]), num(&row["kappa_q"]));
        let m = nums(&row["mean_q"]);
        let p = VonMisesFisher::new(pole, kp).unwrap();
        let q = VonMisesFisher::new(S2::new_unchecked(Vector3::new(m[0], m[1], m[2])), kq).unwrap();
        let plus = |k: f64| k.max(1.0).ln() + (4.0 * PI).ln();
        let scale = plus(kp) + plus(kq) + kq * (1.0 - m[2]) + (1.0 / kp).min(1.0) * (kp + kq);
        kl.check(
            p.kl_divergence(&q),
            num(&row["kl"]),
            scale,
            &format!("κp {kp:e}, κq {kq:e}"),
        );
    }
    log_pdf.finish();
    entropy.finish();
    kl.finish();
}

#[test]
fn gen_von_mises2() {
    let data = data();
    let mut log_pdf = Ulps::new("GenVonMises2 log_pdf", 3.0);
    let mut normaliser = Ulps::new("GenVonMises2 ln Z", 3.0);
    for row in rows(&data, "gen_von_mises2") {
        let (e1, e2) = (nums(&row["eta1"]), nums(&row["eta2"]));
        let p = GenVonMises2::from_natural(Vector2::new(e1[0], e1[1]), Vector2::new(e2[0], e2[1]))
            .unwrap();
        let angle = num(&row["angle"]);
        let case = format!("η₁ {e1:?}, η₂ {e2:?}, θ {angle}");
        let expected_z = num(&row["log_normalizer"]);
        normaliser.check(p.log_normalizer(), expected_z, expected_z.abs(), &case);
        // The terms: the two harmonics' parts of the exponent's change from the mode to θ, ln Z minus
        // the exponent at the mode, and ln 2π, the size of the quadrature sum's rounding (as the von
        // Mises normaliser's term).
        let mode = p.mode().map_or(0.0, |m| m.angle());
        let exponent = |t: f64| {
            e1[0] * t.cos() + e1[1] * t.sin() + e2[0] * (2.0 * t).cos() + e2[1] * (2.0 * t).sin()
        };
        let d = angle - mode;
        let first = Vector2::new(e1[0], e1[1]).norm() * 2.0 * (0.5 * d).sin().abs();
        let second = Vector2::new(e2[0], e2[1]).norm() * 2.0 * d.sin().abs();
        let scale = first + second + (expected_z - exponent(mode)).abs() + (2.0 * PI).ln();
        log_pdf.check(
            p.log_pdf(&So2::from_angle(angle).unwrap()),
            num(&row["log_pdf"]),
            scale,
            &case,
        );
    }
    log_pdf.finish();
    normaliser.finish();
}

#[test]
fn bingham() {
    let data = data();
    let mut log_pdf = Ulps::new("Bingham log_pdf", 3.0);
    let mut normaliser = Ulps::new("Bingham ln K", 3.0);
    for row in rows(&data, "bingham") {
        let z = nums(&row["z"]);
        let q = nums(&row["q"]);
        let p = Bingham::new(Matrix4::identity(), Vector4::from_column_slice(&z)).unwrap();
        let case = format!("z {z:?}, q {q:?}");
        let expected_k = num(&row["log_normalizer"]);
        let top = z.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        // ln K − z₀ is what the library computes; z₀ is exact.
        normaliser.check(
            p.log_normalizer(),
            expected_k,
            (expected_k - top).abs() + top.abs(),
            &case,
        );
        let point = Su2::from_quaternion_wxyz(q[0], q[1], q[2], q[3]).unwrap();
        let spread: f64 = z.iter().zip(&q).map(|(zk, qk)| (top - zk) * qk * qk).sum();
        log_pdf.check(
            p.log_pdf(&point),
            num(&row["log_pdf"]),
            spread + (expected_k - top).abs(),
            &case,
        );
    }
    log_pdf.finish();
    normaliser.finish();
}

#[test]
fn heat_kernel_so3() {
    let data = data();
    let mut log_pdf = Ulps::new("HeatKernelSo3 log_pdf", 3.0);
    for row in rows(&data, "heat_kernel_so3") {
        let (s, t) = (num(&row["s"]), num(&row["t"]));
        let p = HeatKernelSo3::new(So3::identity(), s).unwrap();
        let x = So3::exp(&Vector3::new(t, 0.0, 0.0));
        let expected = num(&row["log_pdf"]);
        let scale = expected.abs() + 1.5 * s.ln().abs() + t * t / (2.0 * s);
        log_pdf.check(p.log_pdf(&x), expected, scale, &format!("s {s:e}, t {t:e}"));
    }
    log_pdf.finish();
}

#[test]
fn gaussian() {
    let data = data();
    let mut log_pdf = Ulps::new("Gaussian log_pdf", 3.0);
    for row in rows(&data, "gaussian") {
        let variance = num(&row["variance"]);
        let (mean, x) = (nums(&row["mean"]), nums(&row["x"]));
        let p = Gaussian::new(
            Vector3::from_column_slice(&mean),
            Matrix3::identity() * variance,
        );
        // Beyond the limit of every Gaussian, tr Σ⁻¹ = 3/σ² ≤ 1e100 (σ² = 1e-100): refused.
        if 3.0 / variance > liebayes_densities::MAX_SCALE {
            assert!(p.is_err(), "σ² {variance:e}");
            continue;
        }
        let p = p.unwrap();
        let point = Vector3::from_column_slice(&x);
        let expected = num(&row["log_pdf"]);
        let scale =
            1.5 * ((2.0 * PI).ln() + variance.ln().abs()) + 0.5 * p.mahalanobis_squared(&point);
        log_pdf.check(
            p.log_pdf(&point),
            expected,
            scale,
            &format!("σ² {variance:e}, x {x:?}"),
        );
    }
    log_pdf.finish();
}
