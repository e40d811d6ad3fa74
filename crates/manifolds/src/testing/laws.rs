//! The generic law suite: algebraic laws and finite-difference checks of every Jacobian, for any
//! [`Manifold`], [`LieGroup`] and [`GroupAction`].
//!
//! Nothing here assumes a convention: the finite differences perturb inputs with the type's own
//! `retract` and measure outputs with its own `local`, so they check the Jacobians of [`Left`] (world
//! frame) as they check those of the right-perturbed groups; only the intrinsic maps (Jr, Jl, Ad) are
//! differenced through the group operations directly.
//!
//! Each function returns `Err(TestCaseError)` with a message naming the law, the values and the
//! tolerance, so it can be called inside `proptest!` blocks. Tolerances come from [`Tolerance`], which
//! derives them from the scalar's machine epsilon; they are never tuned per test.

use crate::{
    GroupAction, Jacobian, Left, LieGroup, Manifold, ProductManifold, Real, Rn, S2, So2, So3, Su2,
    Tangent,
};
use nalgebra::{ComplexField, RealField, SMatrix, SVector};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

use crate::{Se2, Se3, Se23, se2, se3};
use nalgebra::{Vector1, Vector3, Vector6};

/// Tolerances fitting a scalar type, derived from its machine epsilon `eps`.
#[derive(Clone, Copy, Debug)]
pub struct Tolerance<T> {
    /// Algebraic identities (a few dozen rounded operations, condition numbers up to about 30 for
    /// tangents of norm 30): `1000 eps`, relative to `1 + |value|`.
    pub identity: T,
    /// Finite-difference step `h = eps^(1/3)`, which balances the O(h²) truncation of a central
    /// difference against its O(eps/h) rounding.
    pub fd_step: T,
    /// Finite-difference agreement: `100 (h² + eps/h)`, relative to `1 + max |J|` (the factor 100 covers
    /// third derivatives and evaluation errors of order ten).
    pub fd: T,
}

impl<T: Real> Tolerance<T> {
    /// Fails unless every tolerance is finite and positive (a step of 0 would divide 0 by 0, an
    /// infinite tolerance would pass anything).
    ///
    /// # Errors
    /// The law's failure, naming the field.
    pub fn check(&self) -> Result<(), TestCaseError> {
        for (name, value) in [
            ("identity", self.identity),
            ("fd_step", self.fd_step),
            ("fd", self.fd),
        ] {
            prop_assert!(
                value.is_finite() && value > T::zero(),
                "Tolerance::{name} is {value:?}: it must be finite and positive"
            );
        }
        Ok(())
    }

    /// The tolerances for `T`.
    pub fn for_scalar() -> Self {
        let eps = T::default_epsilon();
        let h = eps.cbrt();
        Self {
            identity: T::lit(1000.0) * eps,
            fd_step: h,
            fd: T::lit(100.0) * (h * h + eps / h),
        }
    }
}

/// What the law suite needs to know about a space beyond its traits: where its exp stops being
/// injective and which tangent vectors reach the same point.
pub trait LawSubject<const D: usize>: Manifold<D> {
    /// The radius below which `local(x, retract(x, v)) == v` (π for SO(2), SO(3), S², SE(2), SE(3),
    /// SE₂(3); 2π
    /// for SU(2)).
    fn injectivity_radius() -> Self::Scalar;

    /// The tangent vector reaching the same point as `v` from any base (`retract(x, result) ==
    /// retract(x, v)`) that is closest to `reference`.
    fn equivalent_tangent_near(
        v: &Tangent<Self::Scalar, D>,
        reference: &Tangent<Self::Scalar, D>,
    ) -> Tangent<Self::Scalar, D>;

    /// Whether the Jacobians of exp (and their inverses) are regular enough at `v` for a finite
    /// difference to be meaningful: false within 0.5 of a singular norm (2π k for the rotation groups).
    fn jacobian_is_regular(v: &Tangent<Self::Scalar, D>) -> bool;

    /// How much `local(x, retract(x, v))` amplifies the rounding of the retracted point: 1 where the
    /// logarithm is well conditioned (the quaternion logs, also at π), `θ / |sin θ|` on S², whose
    /// logarithm loses its direction at the antipode (the cut locus, where every direction is a log).
    fn log_condition(v: &Tangent<Self::Scalar, D>) -> Self::Scalar;

    /// The size of the coordinates, which rounding errors scale with: 1 for the compact spaces,
    /// `1 + max |x_i|` for Rⁿ.
    fn coordinate_scale(&self) -> Self::Scalar;

    /// How far `v` reaches towards the injectivity radius: `|v| / injectivity_radius()` (the default),
    /// for a product the largest ratio of its factors (whose blocks have radii of their own), for SE(2),
    /// SE(3) and SE₂(3) the rotation block's (their logarithms keep the rotation principal and leave the
    /// translation block unbounded). `local` and `log` return tangents with a ratio of at most 1.
    fn injectivity_ratio(v: &Tangent<Self::Scalar, D>) -> Self::Scalar {
        v.norm() / Self::injectivity_radius()
    }
}

/// `Left<G>` has the radius, equivalent tangents and conditioning of `G`: exp and log are the same
/// maps, and `local(x, y) = log(y x⁻¹)` is as well conditioned as `log(x⁻¹ y)`.
impl<G: LieGroup<D> + LawSubject<D>, const D: usize> LawSubject<D> for Left<G> {
    fn injectivity_radius() -> G::Scalar {
        G::injectivity_radius()
    }
    fn equivalent_tangent_near(
        v: &Tangent<G::Scalar, D>,
        reference: &Tangent<G::Scalar, D>,
    ) -> Tangent<G::Scalar, D> {
        G::equivalent_tangent_near(v, reference)
    }
    fn jacobian_is_regular(v: &Tangent<G::Scalar, D>) -> bool {
        G::jacobian_is_regular(v)
    }
    fn log_condition(v: &Tangent<G::Scalar, D>) -> G::Scalar {
        G::log_condition(v)
    }
    fn coordinate_scale(&self) -> G::Scalar {
        self.inner().coordinate_scale()
    }
    fn injectivity_ratio(v: &Tangent<G::Scalar, D>) -> G::Scalar {
        G::injectivity_ratio(v)
    }
}

/// A product is injective where both factors are (radius: the smaller one; ratio: the larger one),
/// has equivalent tangents block by block, is regular where both factors are, and is as badly
/// conditioned and as large as its worse factor.
impl<A, B, const DA: usize, const DB: usize, const D: usize> LawSubject<D>
    for ProductManifold<A, B, DA, DB, D>
where
    A: LawSubject<DA>,
    B: LawSubject<DB, Scalar = A::Scalar>,
{
    fn injectivity_radius() -> A::Scalar {
        A::injectivity_radius().min(B::injectivity_radius())
    }
    fn equivalent_tangent_near(
        v: &Tangent<A::Scalar, D>,
        reference: &Tangent<A::Scalar, D>,
    ) -> Tangent<A::Scalar, D> {
        let (va, vb) = Self::split_tangent(v);
        let (ra, rb) = Self::split_tangent(reference);
        Self::join_tangent(
            &A::equivalent_tangent_near(&va, &ra),
            &B::equivalent_tangent_near(&vb, &rb),
        )
    }
    fn jacobian_is_regular(v: &Tangent<A::Scalar, D>) -> bool {
        let (va, vb) = Self::split_tangent(v);
        A::jacobian_is_regular(&va) && B::jacobian_is_regular(&vb)
    }
    fn log_condition(v: &Tangent<A::Scalar, D>) -> A::Scalar {
        let (va, vb) = Self::split_tangent(v);
        A::log_condition(&va).max(B::log_condition(&vb))
    }
    fn coordinate_scale(&self) -> A::Scalar {
        self.first()
            .coordinate_scale()
            .max(self.second().coordinate_scale())
    }
    fn injectivity_ratio(v: &Tangent<A::Scalar, D>) -> A::Scalar {
        let (va, vb) = Self::split_tangent(v);
        A::injectivity_ratio(&va).max(B::injectivity_ratio(&vb))
    }
}

/// The equivalent of `v = θ u` along the same axis, `(θ + k·period) u`, closest to `reference`.
fn periodic_near<T: Real, const D: usize>(
    v: &SVector<T, D>,
    reference: &SVector<T, D>,
    period: T,
) -> SVector<T, D> {
    let theta = v.norm();
    if theta == T::zero() {
        return *v;
    }
    let u = v / theta;
    let k = ((reference.dot(&u) - theta) / period).round();
    u * (theta + k * period)
}

/// Whether `|v|` is at least 0.5 away from every positive multiple of `period`.
fn away_from_multiples<T: Real, const D: usize>(v: &SVector<T, D>, period: T) -> bool {
    let theta = v.norm();
    let k = (theta / period).round();
    k == T::zero() || (theta - k * period).abs() > T::lit(0.5)
}

macro_rules! rotation_law_subject {
    ($ty:ident, $dim:literal, $radius:expr, $period:expr, $singular:expr, $condition:expr) => {
        impl<T: Real> LawSubject<$dim> for $ty<T> {
            fn injectivity_radius() -> T {
                $radius
            }
            fn equivalent_tangent_near(
                v: &Tangent<T, $dim>,
                r: &Tangent<T, $dim>,
            ) -> Tangent<T, $dim> {
                periodic_near(v, r, $period)
            }
            fn jacobian_is_regular(v: &Tangent<T, $dim>) -> bool {
                $singular.map_or(true, |period| away_from_multiples(v, period))
            }
            fn log_condition(v: &Tangent<T, $dim>) -> T {
                $condition(v.norm())
            }
            fn coordinate_scale(&self) -> T {
                T::one()
            }
        }
    };
}

/// The quaternion and complex logarithms are well conditioned everywhere.
fn well_conditioned<T: Real>(_theta: T) -> T {
    T::one()
}

/// The sphere's logarithm at distance θ: the direction is determined to rounding / sin θ.
fn sphere_log_condition<T: Real>(theta: T) -> T {
    if theta < T::one() {
        T::one()
    } else {
        theta / theta.sin().abs().max(T::default_epsilon())
    }
}

rotation_law_subject!(So2, 1, T::pi(), T::two_pi(), None::<T>, well_conditioned);
rotation_law_subject!(
    So3,
    3,
    T::pi(),
    T::two_pi(),
    Some(T::two_pi()),
    well_conditioned
);
rotation_law_subject!(
    Su2,
    3,
    T::two_pi(),
    T::lit(2.0) * T::two_pi(),
    Some(T::two_pi()),
    well_conditioned
);
rotation_law_subject!(S2, 2, T::pi(), T::two_pi(), None::<T>, sphere_log_condition);

impl<T: Real, const N: usize> LawSubject<N> for Rn<T, N> {
    fn injectivity_radius() -> T {
        T::max_value().unwrap_or_else(|| T::lit(f64::MAX))
    }
    fn equivalent_tangent_near(v: &Tangent<T, N>, _reference: &Tangent<T, N>) -> Tangent<T, N> {
        *v
    }
    fn jacobian_is_regular(_v: &Tangent<T, N>) -> bool {
        true
    }
    fn log_condition(_v: &Tangent<T, N>) -> T {
        T::one()
    }
    fn coordinate_scale(&self) -> T {
        T::one() + self.coords().amax()
    }
}

/// The rotation block of the equivalent of a pose tangent nearest the reference's rotation block (whole
/// turns added along the same axis, as [`periodic_near`] does), or `None` when that is the rotation
/// block itself.
fn shifted_rotation<T: Real, const D: usize>(
    phi: &SVector<T, D>,
    reference: &SVector<T, D>,
) -> Option<SVector<T, D>> {
    let theta = phi.norm();
    if theta == T::zero() {
        return None;
    }
    let u = phi / theta;
    let k = ((reference.dot(&u) - theta) / T::two_pi()).round();
    (k != T::zero()).then(|| u * (theta + k * T::two_pi()))
}

/// SE(2): exp is injective while the angle stays below π; an equivalent tangent turns the angle by whole
/// turns and changes the translation block so that exp keeps its translation, `ρ' = V(θ')⁻¹ t`.
impl<T: Real> LawSubject<3> for Se2<T> {
    fn injectivity_radius() -> T {
        T::pi()
    }
    fn injectivity_ratio(v: &Tangent<T, 3>) -> T {
        v.z.abs() / T::pi()
    }
    fn equivalent_tangent_near(v: &Tangent<T, 3>, reference: &Tangent<T, 3>) -> Tangent<T, 3> {
        match shifted_rotation(&Vector1::new(v.z), &Vector1::new(reference.z)) {
            None => *v,
            Some(theta) => {
                let rho = se2::v_inverse_times(theta.x, Se2::exp(v).translation());
                Vector3::new(rho.x, rho.y, theta.x)
            }
        }
    }
    fn jacobian_is_regular(v: &Tangent<T, 3>) -> bool {
        away_from_multiples(&Vector1::new(v.z), T::two_pi())
    }
    fn log_condition(_v: &Tangent<T, 3>) -> T {
        T::one()
    }
    fn coordinate_scale(&self) -> T {
        T::one() + self.translation().amax()
    }
}

/// SE(3): as SE(2), with the rotation vector in place of the angle, `ρ' = V(φ')⁻¹ t`.
impl<T: Real> LawSubject<6> for Se3<T> {
    fn injectivity_radius() -> T {
        T::pi()
    }
    fn injectivity_ratio(v: &Tangent<T, 6>) -> T {
        Vector3::new(v[3], v[4], v[5]).norm() / T::pi()
    }
    fn equivalent_tangent_near(v: &Tangent<T, 6>, reference: &Tangent<T, 6>) -> Tangent<T, 6> {
        let phi = Vector3::new(v[3], v[4], v[5]);
        let reference_phi = Vector3::new(reference[3], reference[4], reference[5]);
        match shifted_rotation(&phi, &reference_phi) {
            None => *v,
            Some(phi) => {
                let rho = se3::v_inverse_times(&phi, Se3::exp(v).translation());
                Vector6::new(rho.x, rho.y, rho.z, phi.x, phi.y, phi.z)
            }
        }
    }
    fn jacobian_is_regular(v: &Tangent<T, 6>) -> bool {
        away_from_multiples(&Vector3::new(v[3], v[4], v[5]), T::two_pi())
    }
    fn log_condition(_v: &Tangent<T, 6>) -> T {
        T::one()
    }
    fn coordinate_scale(&self) -> T {
        T::one() + self.translation().amax()
    }
}

/// SE₂(3): as SE(3), with both linear blocks recomputed, `ρ' = V(φ')⁻¹ p` and `ν' = V(φ')⁻¹ v`.
impl<T: Real> LawSubject<9> for Se23<T> {
    fn injectivity_radius() -> T {
        T::pi()
    }
    fn injectivity_ratio(v: &Tangent<T, 9>) -> T {
        v.fixed_rows::<3>(3).norm() / T::pi()
    }
    fn equivalent_tangent_near(v: &Tangent<T, 9>, reference: &Tangent<T, 9>) -> Tangent<T, 9> {
        let phi = v.fixed_rows::<3>(3).into_owned();
        match shifted_rotation(&phi, &reference.fixed_rows::<3>(3).into_owned()) {
            None => *v,
            Some(phi) => {
                let x = Se23::exp(v);
                let mut shifted = *v;
                shifted
                    .fixed_rows_mut::<3>(0)
                    .copy_from(&se3::v_inverse_times(&phi, x.position()));
                shifted.fixed_rows_mut::<3>(3).copy_from(&phi);
                shifted
                    .fixed_rows_mut::<3>(6)
                    .copy_from(&se3::v_inverse_times(&phi, x.velocity()));
                shifted
            }
        }
    }
    fn jacobian_is_regular(v: &Tangent<T, 9>) -> bool {
        away_from_multiples(&v.fixed_rows::<3>(3).into_owned(), T::two_pi())
    }
    fn log_condition(_v: &Tangent<T, 9>) -> T {
        T::one()
    }
    fn coordinate_scale(&self) -> T {
        T::one() + self.position().amax().max(self.velocity().amax())
    }
}

fn close<T: Real, const R: usize, const C: usize>(
    law: &str,
    got: &SMatrix<T, R, C>,
    expected: &SMatrix<T, R, C>,
    tolerance: T,
) -> Result<(), TestCaseError> {
    // amax skips a NaN followed by any number: non-finite entries fail here, explicitly.
    prop_assert!(
        got.iter()
            .chain(expected.iter())
            .all(ComplexField::is_finite),
        "{law}: a non-finite entry\n got {got:?}\n expected {expected:?}"
    );
    let error = (got - expected).amax();
    let scale = T::one() + expected.amax();
    prop_assert!(
        error <= tolerance * scale,
        "{law}: error {error:?} exceeds {:?}\n got {got:?}\n expected {expected:?}",
        tolerance * scale
    );
    Ok(())
}

fn same_point<M: Manifold<D>, const D: usize>(
    law: &str,
    got: &M,
    expected: &M,
    tol: M::Scalar,
) -> Result<(), TestCaseError> {
    let d = got.distance(expected);
    prop_assert!(
        d <= tol,
        "{law}: distance {d:?} exceeds {tol:?}\n got {got:?}\n expected {expected:?}"
    );
    Ok(())
}

fn one<T: Real>() -> T {
    T::one()
}

/// A function of a tangent perturbation, as the finite differences take it.
type Perturbed<'a, T, const D: usize, Out> = &'a dyn Fn(&Tangent<T, D>) -> Out;

/// Central finite difference: column i is `(f(h e_i) − f(−h e_i)) / 2h`.
fn finite_difference<T: Real, const R: usize, const C: usize>(
    h: T,
    f: impl Fn(&SVector<T, C>) -> SVector<T, R>,
) -> SMatrix<T, R, C> {
    SMatrix::from_fn(|r, c| {
        let e = SVector::<T, C>::from_fn(|i, _| if i == c { h } else { T::zero() });
        (f(&e)[r] - f(&-e)[r]) / (h + h)
    })
}

/// Manifold laws at `x`: `x ⊞ 0 = x`, `x ⊟ x = 0`, `x ⊞ (y ⊟ x) = y`, `(x ⊞ v) ⊟ x ≡ v` (the
/// equivalent tangent nearest the result, inside the injectivity radius), and `distance = |y ⊟ x|`.
///
/// # Errors
/// The first law that fails, with its numbers.
pub fn check_manifold<M: LawSubject<D>, const D: usize>(
    x: &M,
    y: &M,
    v: &Tangent<M::Scalar, D>,
    tol: &Tolerance<M::Scalar>,
) -> Result<(), TestCaseError> {
    tol.check()?;
    let t = tol.identity * x.coordinate_scale().max(y.coordinate_scale());
    let one = one::<M::Scalar>();
    same_point("retract(x, 0) == x", &x.retract(&Tangent::zeros()), x, t)?;
    close("local(x, x) == 0", &x.local(x), &Tangent::zeros(), t)?;
    let back = x.local(&x.retract(v));
    let expected = M::equivalent_tangent_near(v, &back);
    let t_v = t * (one + v.norm());
    prop_assert!(
        (back.norm() - expected.norm()).abs() <= t_v,
        "|local(x, retract(x, v))| = {:?} but |v| = {:?} (mod the period)",
        back.norm(),
        expected.norm()
    );
    close(
        "local(x, retract(x, v)) == v",
        &back,
        &expected,
        t_v * M::log_condition(v),
    )?;
    prop_assert!(
        M::injectivity_ratio(&back) <= one + t,
        "local(x, retract(x, v)) = {back:?} lies outside the injectivity radius"
    );
    let yx = x.local(y);
    same_point("retract(x, local(x, y)) == y", &x.retract(&yx), y, t)?;
    let d = x.distance(y);
    prop_assert!(
        (d - yx.norm()).abs() <= t * (one + d),
        "distance(x, y) = {d:?} but |local(x, y)| = {:?}",
        yx.norm()
    );
    Ok(())
}

/// Group laws: associativity, identity, inverse, `exp(log a) = a`, `log(exp v) ≡ v` (the equivalent
/// tangent nearest the result, inside the injectivity radius), `vee(hat v) = v`, the adjoint identity
/// `Ad(a) v = vee(a hat(v) a⁻¹)` and its group form `a exp(v) a⁻¹ = exp(Ad(a) v)`, and
/// `Jr(v) Jr⁻¹(v) = I` where Jr is regular.
///
/// # Errors
/// The first law that fails, with its numbers.
pub fn check_group<G: LieGroup<D> + LawSubject<D>, const D: usize>(
    a: &G,
    b: &G,
    c: &G,
    v: &Tangent<G::Scalar, D>,
    tol: &Tolerance<G::Scalar>,
) -> Result<(), TestCaseError> {
    tol.check()?;
    let scale = a
        .coordinate_scale()
        .max(b.coordinate_scale())
        .max(c.coordinate_scale());
    let t = tol.identity * scale;
    let one = one::<G::Scalar>();
    let e = G::identity();
    same_point(
        "(a b) c == a (b c)",
        &a.compose(b).compose(c),
        &a.compose(&b.compose(c)),
        t,
    )?;
    same_point("e a == a", &e.compose(a), a, t)?;
    same_point("a e == a", &a.compose(&e), a, t)?;
    same_point("a a^-1 == e", &a.compose(&a.inverse()), &e, t)?;
    same_point("a^-1 a == e", &a.inverse().compose(a), &e, t)?;
    same_point("exp(log(a)) == a", &G::exp(&a.log()), a, t)?;
    let back = G::exp(v).log();
    let expected = G::equivalent_tangent_near(v, &back);
    close("log(exp(v)) == v", &back, &expected, t * (one + v.norm()))?;
    prop_assert!(
        G::injectivity_ratio(&back) <= one + t,
        "log(exp(v)) = {back:?} lies outside the injectivity radius"
    );
    close("vee(hat(v)) == v", &G::vee(&G::hat(v)), v, t)?;
    close(
        "Ad(a) v == vee(a hat(v) a^-1)",
        &(a.adjoint() * v),
        &G::vee(&a.conjugate_algebra(&G::hat(v))),
        t * (one + v.norm()),
    )?;
    same_point(
        "a exp(v) a^-1 == exp(Ad(a) v)",
        &a.compose(&G::exp(v)).compose(&a.inverse()),
        &G::exp(&(a.adjoint() * v)),
        t * (one + v.norm()),
    )?;
    if G::jacobian_is_regular(v) {
        close(
            "Jr(v) Jr^-1(v) == I",
            &(G::right_jacobian(v) * G::right_jacobian_inverse(v)),
            &Jacobian::identity(),
            t * (one + v.norm()),
        )?;
        close(
            "Jl(v) Jl^-1(v) == I",
            &(G::left_jacobian(v) * G::left_jacobian_inverse(v)),
            &Jacobian::identity(),
            t * (one + v.norm()),
        )?;
    }
    Ok(())
}

/// Every Jacobian of [`LieGroup`] against a central finite difference at `a`, `b` (for the binary
/// operations) and `v` (for exp and retract): the intrinsic `Jr` (`log(exp(v)⁻¹ exp(v + δ))`) and
/// `Jl` (`log(exp(v + δ) exp(v)⁻¹)`), and, in the type's own convention, `J_exp_tangent`,
/// `J_log_self`, `J_compose_self`, `J_compose_other`, `J_inverse_self`, `J_retract_self`,
/// `J_retract_tangent`, `J_local_self`, `J_local_other`: inputs are perturbed with the type's
/// `retract`, group-valued outputs are differenced through its `local` at the unperturbed output, and
/// tangent-valued outputs are unwrapped to the equivalent tangent nearest the unperturbed one, so the
/// check also holds on the branch cut (angle exactly π). Checks whose linearisation point is within
/// 0.5 of a singularity of exp are skipped (there is no finite Jacobian to compare with).
///
/// # Errors
/// The first Jacobian that disagrees, with both matrices.
pub fn check_jacobians<G: LieGroup<D> + LawSubject<D>, const D: usize>(
    a: &G,
    b: &G,
    v: &Tangent<G::Scalar, D>,
    tol: &Tolerance<G::Scalar>,
) -> Result<(), TestCaseError> {
    tol.check()?;
    let h = tol.fd_step;
    let t = tol.fd * a.coordinate_scale().max(b.coordinate_scale());
    // Group-valued function, differenced in the tangent space of its unperturbed value.
    let group_fd = |f: Perturbed<G::Scalar, D, G>| {
        let f0 = f(&Tangent::zeros());
        finite_difference(h, |d| f0.local(&f(d)))
    };
    // Tangent-valued function, unwrapped around its unperturbed value.
    let tangent_fd = |f: Perturbed<G::Scalar, D, Tangent<G::Scalar, D>>| {
        let f0 = f(&Tangent::zeros());
        finite_difference(h, |d| G::equivalent_tangent_near(&f(d), &f0))
    };

    let ev = G::exp(v);
    close(
        "Jr(v)",
        &G::right_jacobian(v),
        &finite_difference(h, |d| ev.inverse().compose(&G::exp(&(v + d))).log()),
        t,
    )?;
    close(
        "J_exp_tangent",
        &G::j_exp_tangent(v),
        &group_fd(&|d| G::exp(&(v + d))),
        t,
    )?;
    close(
        "Jl(v)",
        &G::left_jacobian(v),
        &finite_difference(h, |d| G::exp(&(v + d)).compose(&ev.inverse()).log()),
        t,
    )?;
    close(
        "J_compose_self",
        &a.j_compose_self(b),
        &group_fd(&|d| a.retract(d).compose(b)),
        t,
    )?;
    close(
        "J_compose_other",
        &a.j_compose_other(b),
        &group_fd(&|d| a.compose(&b.retract(d))),
        t,
    )?;
    close(
        "J_inverse_self",
        &a.j_inverse_self(),
        &group_fd(&|d| a.retract(d).inverse()),
        t,
    )?;
    close(
        "J_retract_self",
        &a.j_retract_self(v),
        &group_fd(&|d| a.retract(d).retract(v)),
        t,
    )?;
    close(
        "J_retract_tangent",
        &a.j_retract_tangent(v),
        &group_fd(&|d| a.retract(&(v + d))),
        t,
    )?;
    if G::jacobian_is_regular(&a.log()) {
        close(
            "J_log_self",
            &a.j_log_self(),
            &tangent_fd(&|d| a.retract(d).log()),
            t,
        )?;
    }
    if G::jacobian_is_regular(&a.local(b)) {
        close(
            "J_local_self",
            &a.j_local_self(b),
            &tangent_fd(&|d| a.retract(d).local(b)),
            t,
        )?;
        close(
            "J_local_other",
            &a.j_local_other(b),
            &tangent_fd(&|d| a.local(&b.retract(d))),
            t,
        )?;
    }
    Ok(())
}

/// Action laws at `p`: `e · p = p`, `(a b) · p = a · (b · p)`, and `J_act_self` (with `a` perturbed by
/// the type's `retract`) and `J_act_point` against central finite differences.
///
/// # Errors
/// The first law that fails, with its numbers.
pub fn check_action<G: GroupAction<D, P> + LawSubject<D>, const D: usize, const P: usize>(
    a: &G,
    b: &G,
    p: &SVector<G::Scalar, P>,
    tol: &Tolerance<G::Scalar>,
) -> Result<(), TestCaseError> {
    tol.check()?;
    let scale = a.coordinate_scale().max(b.coordinate_scale()) + p.norm();
    let t = tol.identity * scale;
    close("e . p == p", &G::identity().act(p), p, t)?;
    close(
        "(a b) . p == a . (b . p)",
        &a.compose(b).act(p),
        &a.act(&b.act(p)),
        t,
    )?;
    let h = tol.fd_step;
    close(
        "J_act_self",
        &a.j_act_self(p),
        &finite_difference(h, |d| a.retract(d).act(p)),
        tol.fd * scale,
    )?;
    close(
        "J_act_point",
        &a.j_act_point(p),
        &finite_difference(h, |d| a.act(&(p + d))),
        tol.fd * scale,
    )?;
    Ok(())
}

/// The bad-input law of a manifold: at a valid point `x`, a tangent `v` of any finite magnitude
/// ([`extreme_tangent`](crate::testing::strategies::extreme_tangent)) gives a finite
/// `retract(x, v)` and finite `local` both ways between it and `x`: the crate's contract "no
/// function panics or returns NaN for finite input". A tangent with a NaN or an infinite component
/// ([`extreme_raw_tangent`](crate::testing::strategies::extreme_raw_tangent)) must not panic or
/// hang, and a NaN is never hidden: `retract(x, v)` is then not finite, so that a check of the
/// result catches it (the unchecked operations' precondition is finite input; raw numbers enter
/// through the checked constructors).
///
/// # Errors
/// The first operation whose result is not finite, with its input, or a NaN tangent whose
/// retraction is finite.
pub fn check_manifold_bad_input<M: Manifold<D>, const D: usize>(
    x: &M,
    v: &Tangent<M::Scalar, D>,
) -> Result<(), TestCaseError> {
    let y = x.retract(v);
    let (there, back) = (x.local(&y), y.local(x));
    if v.iter().any(|c| c.to_f64().is_nan()) {
        prop_assert!(
            !y.is_finite(),
            "retract(x, v) is finite for a NaN tangent: x = {:?}, v = {:?}",
            x,
            v
        );
    }
    if !v.iter().all(ComplexField::is_finite) {
        return Ok(());
    }
    prop_assert!(
        y.is_finite(),
        "retract(x, v) is not finite for x = {:?}, v = {:?}",
        x,
        v
    );
    for (what, w) in [
        ("local(x, retract(x, v))", there),
        ("local(retract(x, v), x)", back),
    ] {
        prop_assert!(
            w.iter().all(ComplexField::is_finite),
            "{} is not finite for x = {:?}, v = {:?}",
            what,
            x,
            v
        );
    }
    Ok(())
}

/// The bad-input law of a group: [`check_manifold_bad_input`], and at a valid element `x`, a
/// tangent `v` of any finite magnitude gives finite results from every group operation (`exp`,
/// `compose`, `inverse`, `log`, the adjoint, `Jr` and `Jr⁻¹`). Elements are
/// checked with [`Manifold::is_finite`], vectors and matrices entry by entry. A tangent with a NaN
/// or an infinite component (the unchecked operations' precondition is finite input; raw numbers
/// enter through the checked constructors) must not panic or hang, and with a NaN `exp(v)` is not
/// finite.
///
/// # Errors
/// The first operation whose result is not finite, with its input.
pub fn check_bad_input<G: LieGroup<D>, const D: usize>(
    x: &G,
    v: &Tangent<G::Scalar, D>,
) -> Result<(), TestCaseError> {
    check_manifold_bad_input(x, v)?;
    let finite_vector = |m: &Tangent<G::Scalar, D>| m.iter().all(ComplexField::is_finite);
    let finite_matrix = |m: &Jacobian<G::Scalar, D, D>| m.iter().all(ComplexField::is_finite);
    let e = G::exp(v);
    let y = x.retract(v);
    let z = x.compose(&e);
    let results = (
        e.log(),
        x.local(&y),
        y.local(x),
        z.inverse(),
        y.adjoint(),
        G::right_jacobian(v),
        G::right_jacobian_inverse(v),
    );
    if v.iter().any(|c| c.to_f64().is_nan()) {
        prop_assert!(
            !e.is_finite(),
            "exp(v) is finite for a NaN tangent: v = {:?}",
            v
        );
    }
    if !v.iter().all(ComplexField::is_finite) {
        return Ok(());
    }
    let (log, there, back, inverse, adjoint, jr, jr_inverse) = results;
    for (what, ok) in [
        ("exp(v)", e.is_finite()),
        ("retract(x, v)", y.is_finite()),
        ("x exp(v)", z.is_finite()),
        ("(x exp(v))⁻¹", inverse.is_finite()),
        ("log(exp(v))", finite_vector(&log)),
        ("local(x, retract(x, v))", finite_vector(&there)),
        ("local(retract(x, v), x)", finite_vector(&back)),
        ("Ad(retract(x, v))", finite_matrix(&adjoint)),
        ("Jr(v)", finite_matrix(&jr)),
        ("Jr⁻¹(v)", finite_matrix(&jr_inverse)),
    ] {
        prop_assert!(ok, "{} is not finite for x = {:?}, v = {:?}", what, x, v);
    }
    Ok(())
}
