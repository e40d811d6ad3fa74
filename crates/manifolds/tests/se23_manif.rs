//! SE₂(3) against manif's `SE_2_3` (artivis/manif, MIT licence, Copyright (c) 2018 Jeremie Deray):
//! reference values only, no code.
//!
//! * The element, tangent-order and action cases are those of manif's test suite
//!   (`test/se_2_3/gtest_se_2_3.cpp`): the identity's compose and inverse, the blocks `lin`, `ang`,
//!   `lin2` of the tangent `[1, …, 9]`, and the two rigid-motion actions on `(1, 1, 1)`.
//! * That file checks exp, log, the adjoint and the Jacobians only by generic properties, not by
//!   values. The values below for those were computed with manif's implementation itself (commit
//!   de52f8b, `double`, printed to 17 digits) at three tangents: `a` and `b` with rotation angles
//!   1.2 and 2.9, and `c` with angle 3.7e-5.
//! * At `c` manif's closed forms (`(1 − cos θ)/θ²` and the coefficients of its Q blocks, evaluated
//!   above its small-angle switch) cancel: its exp is off by 4.5e-12 and its Jacobians by 2.2e-10
//!   (measured). There the comparison with manif uses [`MANIF_SMALL_ANGLE_ERROR`], and exactness is
//!   checked against the defining series instead: exp against the matrix exponential of `hat(ξ)`,
//!   Jr against `Σ (−ad ξ)ⁿ/(n + 1)!` summed to convergence, Jr⁻¹ against that sum's inverse
//!   (a dense solve), at all three tangents.
//!
//! manif's element `(t, q, v)` is this crate's `(rotation q, velocity v, position t)`, and its tangent
//! `[lin; ang; lin2]` is `[ρ; φ; ν]` here: the same order. Its Jacobians are right Jacobians in the
//! `J_out_in` convention, as here, so every matrix compares entry by entry.

use liebayes_manifolds::{GroupAction, LieGroup, Manifold, Se23, So3};
use nalgebra::{Quaternion, SMatrix, SVector, Vector3};
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

/// manif's tangents.
const TANGENT_A: [f64; 9] = [0.5, -1.2, 2.0, 0.3, -0.4, 1.1, 0.7, 0.1, -0.9];
const TANGENT_B: [f64; 9] = [-3.0, 0.25, 1.5, 1.9, 2.1, -0.6, -2.2, 4.0, 0.35];
const TANGENT_C: [f64; 9] = [1.0, 2.0, 3.0, 1e-5, -2e-5, 3e-5, -1.0, 0.5, 2.0];
/// The point of the action case.
const POINT: [f64; 3] = [0.3, -2.0, 1.5];

/// Agreement of two double-precision evaluations of the same formula: both round each of a few
/// dozen operations on numbers of order one.
const TOLERANCE: f64 = 64.0 * f64::EPSILON;

/// manif's own error at the tangent `c` (measured 2.2e-10, see the module docs), with a margin of 4.
const MANIF_SMALL_ANGLE_ERROR: f64 = 1e-9;

/// The element `[w, x, y, z, v_x, v_y, v_z, p_x, p_y, p_z]`.
fn element(c: &[f64; 10]) -> Se23<f64> {
    let q = So3::from_quaternion(Quaternion::new(c[0], c[1], c[2], c[3])).unwrap();
    Se23::new(
        q,
        Vector3::new(c[4], c[5], c[6]),
        Vector3::new(c[7], c[8], c[9]),
    )
    .unwrap()
}

fn tangent(c: &[f64; 9]) -> SVector<f64, 9> {
    SVector::from_column_slice(c)
}

/// A matrix given row by row.
fn matrix<const R: usize, const C: usize>(rows: &[f64]) -> SMatrix<f64, R, C> {
    SMatrix::from_row_slice(rows)
}

fn assert_close<const R: usize, const C: usize>(
    what: &str,
    got: &SMatrix<f64, R, C>,
    expected: &SMatrix<f64, R, C>,
    tolerance: f64,
) {
    let error = (got - expected).amax();
    assert!(
        error <= tolerance * (1.0 + expected.amax()),
        "{what}: error {error:e}\n got {got}\n expected {expected}"
    );
}

fn assert_same_element(what: &str, got: &Se23<f64>, expected: &Se23<f64>) {
    assert_close(what, &got.to_matrix(), &expected.to_matrix(), TOLERANCE);
}

/// manif's `SE_2_3(x, y, z, roll, pitch, yaw, vx, vy, vz)`: the rotation `Rz(yaw) Ry(pitch) Rx(roll)`.
fn from_roll_pitch_yaw(position: [f64; 3], rpy: [f64; 3], velocity: [f64; 3]) -> Se23<f64> {
    let about = |axis: Vector3<f64>, angle: f64| So3::from_axis_angle(&axis, angle).unwrap();
    let r = about(Vector3::z(), rpy[2])
        .compose(&about(Vector3::y(), rpy[1]))
        .compose(&about(Vector3::x(), rpy[0]));
    Se23::new(r, Vector3::from(velocity), Vector3::from(position)).unwrap()
}

#[test]
fn identity_compose_inverse_and_tangent_order_as_in_manif() {
    let e = Se23::<f64>::identity();
    assert_eq!(e.compose(&e), e);
    assert_eq!(e.inverse(), e);
    assert_eq!(e.rotation().to_quaternion_wxyz(), [1.0, 0.0, 0.0, 0.0]);
    // The tangent [1, …, 9] has lin = (1, 2, 3), ang = (4, 5, 6), lin2 = (7, 8, 9): with no rotation
    // exp puts lin into the position and lin2 into the velocity.
    let v = tangent(&[1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 7.0, 8.0, 9.0]);
    let x = Se23::exp(&v);
    assert_eq!(*x.position(), Vector3::new(1.0, 2.0, 3.0));
    assert_eq!(*x.velocity(), Vector3::new(7.0, 8.0, 9.0));
    let hat = Se23::hat(&tangent(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]));
    // hat(ang) in the rotation block, lin2 beside it (the velocity column), lin last (the position
    // column): manif's `hat` with its position and velocity columns in this crate's order.
    assert_eq!(
        hat.fixed_view::<3, 1>(0, 3).into_owned(),
        Vector3::new(7.0, 8.0, 9.0)
    );
    assert_eq!(
        hat.fixed_view::<3, 1>(0, 4).into_owned(),
        Vector3::new(1.0, 2.0, 3.0)
    );
    assert_eq!(hat[(2, 1)], 4.0);
    assert_eq!(hat[(0, 2)], 5.0);
    assert_eq!(hat[(1, 0)], 6.0);
}

#[test]
fn action_cases_of_manifs_test_suite() {
    let ones = Vector3::new(1.0, 1.0, 1.0);
    let e = Se23::<f64>::identity();
    assert!((e.act(&ones) - ones).amax() <= 1e-15);
    let x = from_roll_pitch_yaw([1.0, 1.0, 1.0], [PI, FRAC_PI_2, FRAC_PI_4], [0.0; 3]);
    let y = x.act(&ones);
    assert!((y.x - 1.0).abs() <= 1e-15, "{y}");
    assert!((y.y + 0.414_213_562_373).abs() <= 1e-12, "{y}");
    assert!(y.z.abs() <= 1e-15, "{y}");
    // The velocity does not move points.
    let x = from_roll_pitch_yaw(
        [-1.0, -1.0, -1.0],
        [FRAC_PI_4, -FRAC_PI_2, -PI],
        [0.0, 0.0, 1.0],
    );
    let y = x.act(&ones);
    assert!((y.x - 0.414_213_562_373).abs() <= 1e-12, "{y}");
    assert!((y.y + 1.0).abs() <= 1e-15, "{y}");
    assert!(y.z.abs() <= 1e-15, "{y}");
}

#[test]
fn exp_and_jacobians_match_manif() {
    let cases = [
        (TANGENT_A, EXP_A, JR_A, JR_INV_A, TOLERANCE),
        (TANGENT_B, EXP_B, JR_B, JR_INV_B, TOLERANCE),
        (TANGENT_C, EXP_C, JR_C, JR_INV_C, MANIF_SMALL_ANGLE_ERROR),
    ];
    for (v, exp, jr, jr_inv, tolerance) in cases {
        let v = tangent(&v);
        let x = Se23::exp(&v);
        assert_close("exp", &x.to_matrix(), &element(&exp).to_matrix(), tolerance);
        assert_close("Jr", &Se23::right_jacobian(&v), &matrix(&jr), tolerance);
        assert_close(
            "Jr^-1",
            &Se23::right_jacobian_inverse(&v),
            &matrix(&jr_inv),
            tolerance,
        );
        assert_close(
            "J_exp_tangent",
            &Se23::j_exp_tangent(&v),
            &matrix(&jr),
            tolerance,
        );
    }
    let a = tangent(&TANGENT_A);
    assert_close("Jl", &Se23::left_jacobian(&a), &matrix(&JL_A), TOLERANCE);
    assert_close(
        "Jl^-1",
        &Se23::left_jacobian_inverse(&a),
        &matrix(&JL_INV_A),
        TOLERANCE,
    );
}

/// `ad(ξ)` in the order `[ρ; φ; ν]`: `[[hat φ, hat ρ, 0], [0, hat φ, 0], [0, hat ν, hat φ]]`
/// (manif's `smallAdj`), the matrix of `η ↦ vee([hat ξ, hat η])`.
fn small_adjoint(v: &SVector<f64, 9>) -> SMatrix<f64, 9, 9> {
    let hat = |i: usize| {
        let x = Vector3::new(v[i], v[i + 1], v[i + 2]);
        x.cross_matrix()
    };
    let mut ad = SMatrix::<f64, 9, 9>::zeros();
    for k in [0, 3, 6] {
        ad.fixed_view_mut::<3, 3>(k, k).copy_from(&hat(3));
    }
    ad.fixed_view_mut::<3, 3>(0, 3).copy_from(&hat(0));
    ad.fixed_view_mut::<3, 3>(6, 3).copy_from(&hat(6));
    ad
}

#[test]
fn exp_and_jacobians_match_their_defining_series() {
    for v in [TANGENT_A, TANGENT_B, TANGENT_C] {
        let v = tangent(&v);
        let ad = small_adjoint(&v);
        // The small adjoint is the commutator with hat(ξ): a check of the tangent order against
        // the matrix representation.
        let w = tangent(&[0.2, -0.1, 0.4, 0.3, 0.0, -0.5, 1.0, 0.6, -0.7]);
        let (hv, hw) = (Se23::hat(&v), Se23::hat(&w));
        assert_close("ad", &(ad * w), &Se23::vee(&(hv * hw - hw * hv)), TOLERANCE);
        // Σ (−ad)ⁿ/(n+1)!, summed until the terms vanish: terms grow to ‖ad‖ⁿ/(n+1)!, so the
        // rounding of the sum is a few eps e^‖ad‖.
        let mut term = SMatrix::<f64, 9, 9>::identity();
        let mut jr = term;
        for n in 1..80 {
            term = term * (-ad) / f64::from(n + 1);
            jr += term;
        }
        let rounding = 8.0 * f64::EPSILON * ad.norm().exp();
        assert_close("Jr", &Se23::right_jacobian(&v), &jr, rounding);
        let jr_inv = jr.try_inverse().unwrap();
        assert_close(
            "Jr^-1",
            &Se23::right_jacobian_inverse(&v),
            &jr_inv,
            rounding * jr_inv.amax(),
        );
        // nalgebra's matrix exponential (scaling and squaring with a Padé approximant).
        let scale = 1.0 + v.amax();
        assert_close(
            "exp",
            &Se23::exp(&v).to_matrix(),
            &Se23::hat(&v).exp(),
            TOLERANCE * scale,
        );
    }
}

#[test]
fn group_operations_and_their_jacobians_match_manif() {
    let a = Se23::exp(&tangent(&TANGENT_A));
    let b = Se23::exp(&tangent(&TANGENT_B));
    assert_same_element("compose", &a.compose(&b), &element(&COMPOSE_AB));
    assert_same_element("inverse", &a.inverse(), &element(&INVERSE_A));
    assert_close("log a", &a.log(), &tangent(&LOG_A), TOLERANCE);
    assert_close("log b", &b.log(), &tangent(&LOG_B), TOLERANCE);
    assert_close("adjoint", &a.adjoint(), &matrix(&ADJOINT_A), TOLERANCE);
    let p = Vector3::from(POINT);
    assert_close("act", &a.act(&p), &Vector3::from(ACT_A), TOLERANCE);
    assert_close(
        "J_act_self",
        &a.j_act_self(&p),
        &matrix(&J_ACT_SELF_A),
        TOLERANCE,
    );
    assert_close(
        "J_compose_self",
        &a.j_compose_self(&b),
        &matrix(&J_COMPOSE_SELF_AB),
        TOLERANCE,
    );
    assert_close(
        "J_inverse_self",
        &a.j_inverse_self(),
        &matrix(&J_INVERSE_SELF_A),
        TOLERANCE,
    );
    assert_close(
        "J_log_self",
        &a.j_log_self(),
        &matrix(&J_LOG_SELF_A),
        TOLERANCE,
    );
    // manif's `b.minus(a)` is b ⊟ a = log(a⁻¹ b), this crate's `a.local(&b)`.
    assert_close("local", &a.local(&b), &tangent(&LOCAL_A_B), TOLERANCE);
    assert_close(
        "J_local_self",
        &a.j_local_self(&b),
        &matrix(&J_LOCAL_SELF_AB),
        TOLERANCE,
    );
    assert_close(
        "J_local_other",
        &a.j_local_other(&b),
        &matrix(&J_LOCAL_OTHER_AB),
        TOLERANCE,
    );
}

#[path = "se23_manif/values.rs"]
mod values;
use values::*;
