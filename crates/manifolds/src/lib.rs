//! # liebayes-manifolds
//!
//! The spaces of liebayes: the Lie groups [`So2`], [`So3`], [`Su2`] (unit quaternions, the double cover
//! of SO(3)), [`Rn`], the poses [`Se2`], [`Se3`] and the extended poses [`Se23`], and the sphere
//! [`S2`] (a manifold, not a group), behind two traits:
//! [`Manifold`] (`retract`, `local`) and [`LieGroup`] (group operations, `exp`/`log`, `hat`/`vee`,
//! adjoint, Jacobians), plus [`GroupAction`] for the action on points. Everything is generic over the
//! scalar ([`Real`]: `f64` or `f32`) and built on nalgebra's types, with conversions to and from them
//! at no cost.
//!
//! ## The convention
//!
//! **Perturbations live in the tangent space on the right, and all Jacobians are right Jacobians**,
//! unless the group is wrapped in [`Left`].
//!
//! * `x ⊞ v = x · exp(v)` ([`Manifold::retract`]), `y ⊟ x = log(x⁻¹ · y)` ([`Manifold::local`]):
//!   errors in the body frame. [`Left<G>`](Left) gives `exp(v) · x` and `log(y · x⁻¹)`, errors in the
//!   world frame, with every Jacobian in that convention, so every generic operator runs with either.
//! * A Jacobian named `J_out_in` (methods `j_<out>_<in>`) is the matrix with
//!   `out(in ⊞ δ) = out(in) ⊞ (J_out_in δ + O(|δ|²))`, with the type's own ⊞, which is plain addition
//!   for outputs and inputs that are tangent vectors or points.
//! * `Jr(v)` with `exp(v + δ) = exp(v) exp(Jr(v) δ)`; `Jl(v) = Jr(−v)`; `Ad(g)` with
//!   `g exp(v) g⁻¹ = exp(Ad(g) v)`.
//! * Quaternions are Hamilton, scalar first in all I/O (`w, x, y, z`), rotating actively:
//!   `R(q) v = q v q*`. Angles are radians.
//!
//! ## Validation: the input contract
//!
//! Constructors from raw numbers check finiteness, unit norm, orthonormality and determinant against
//! the tolerances of [`constants`] and return [`ManifoldError`]; `*_unchecked` constructors skip the
//! checks for hot paths, as do the wrappers of nalgebra's unit types (`from_unit_quaternion`,
//! `from_unit_complex`, `from_unit_vector` and their `From`, which take nalgebra's word), and `*_normalizing` / `renormalized` / `from_matrix_orthonormalized` repair
//! inputs explicitly. No function panics or returns NaN for finite input.
//!
//! ## Example
//! ```
//! use liebayes_manifolds::{GroupAction, LieGroup, Manifold, So3};
//! use nalgebra::Vector3;
//!
//! let x = So3::<f64>::from_axis_angle(&Vector3::z(), 0.3)?;
//! let delta = Vector3::new(1e-3, 0.0, 0.0);
//! let y = x.retract(&delta);                 // x · exp(δ)
//! assert!((x.local(&y) - delta).norm() < 1e-15);
//! let p = Vector3::new(1.0, 2.0, 3.0);
//! let j = x.j_act_self(&p);                  // ∂(x · p)/∂x, right perturbation
//! assert!((y.act(&p) - (x.act(&p) + j * delta)).norm() < 1e-5);
//! # Ok::<(), liebayes_manifolds::ManifoldError>(())
//! ```
//!
//! ## Poses
//!
//! [`Se2`] and [`Se3`] are the rigid motions `p ↦ R p + t` of the plane and of space, a rotation
//! ([`So2`], [`So3`]) and a translation. Their tangent coordinates put **the translation block first
//! and the rotation block last**, `v = [ρ; θ]` resp. `[ρ; φ]` (the order of manif and Sophus), and
//! `x ⊞ v = x · exp(v)` like every group here, so ρ is a displacement in the body frame of `x`.
//!
//! [`Se23`] is SE₂(3), the extended pose `(R, v, p)` of inertial navigation (rotation, velocity,
//! position; matrix `[[R, v, p], [0, 1, 0], [0, 0, 1]]`), the group of the invariant EKF. Its tangent
//! is **`[ρ; φ; ν]`: position block, rotation vector, velocity block**, manif's order for `SE_2_3`;
//! exp uses the SO(3) left Jacobian for both linear blocks, and its right Jacobian has the SE(3)
//! coupling block once for each. `x.rotation()`, `x.velocity()`, `x.position()` read it, and
//! `Se23::new(rotation, velocity, position)` builds it.
//!
//! ## Products and means
//!
//! [`product_manifold!`] declares a product of any number of named factors, with its dimension
//! computed from theirs (no dimension written by hand), accessors by name, tangent block offsets and
//! split/join helpers, and a Lie group structure when every factor is a group:
//!
//! ```
//! use liebayes_manifolds::{Left, LieGroup, Rn, So3, product_manifold};
//!
//! product_manifold! {
//!     /// Attitude (world-frame errors), velocity, position and six IMU biases.
//!     pub struct NavState<f64> {
//!         attitude: Left<So3<f64>>,
//!         velocity: Rn<f64, 3>,
//!         position: Rn<f64, 3>,
//!         bias: Rn<f64, 6>,
//!     }
//! }
//! assert_eq!(NavState::DIM, 15);
//! assert_eq!(NavState::OFFSETS, [0, 3, 6, 9]);
//! let x = NavState::identity();
//! assert_eq!(x.adjoint().fixed_view::<6, 6>(9, 9), nalgebra::SMatrix::<f64, 6, 6>::identity());
//! ```
//!
//! [`ProductManifold`] is the two-factor form with the dimensions as type parameters (attitude ×
//! bias is `ProductManifold<So3<f64>, Rn<f64, 3>, 3, 3, 6>`), generic over its factors (the macro's
//! structs are concrete: one per scalar type). [`Dimension`] gives any space's dimension as a
//! constant of its type. [`weighted_mean`] averages samples on any [`Manifold`] by Gauss-Newton,
//! without allocating.
//!
//! With the `proptest` feature, the `testing` module exports the strategies (uniform and curated edge
//! elements for every space) and the generic law suite this crate tests itself with; build the docs
//! with `cargo doc --all-features` (as docs.rs does) to see it. With the `serde` feature,
//! every point implements `Serialize` and `Deserialize`, and reading goes through the validated
//! constructors (a file cannot produce a quaternion that is not unit).
#![cfg_attr(docsrs, feature(doc_cfg))]

mod approx_impls;
pub mod constants;
mod dimension;
mod error;
mod left;
mod lie_group;
mod manifold;
mod mean;
mod polar;
mod pose;
mod product;
mod product_macro;
mod real;
mod rn;
mod rotation_vector;
mod s2;
mod se2;
mod se23;
mod se3;
#[cfg(feature = "serde")]
mod serde_impls;
mod so2;
mod so3;
mod su2;
#[cfg(feature = "proptest")]
#[cfg_attr(docsrs, doc(cfg(feature = "proptest")))]
pub mod testing;

pub use dimension::Dimension;
pub use error::{ManifoldError, Readable};
pub use left::Left;
pub use lie_group::{GroupAction, LieGroup};
pub use manifold::{Jacobian, Manifold, Tangent};
pub use mean::{MeanSettings, weighted_mean};
pub use product::ProductManifold;
#[doc(hidden)]
pub use product_macro::__private;
pub use real::Real;
pub use rn::Rn;
pub use s2::S2;
pub use se2::Se2;
pub use se3::Se3;
pub use se23::Se23;
pub use so2::{So2, wrap_angle};
pub use so3::So3;
pub use su2::Su2;

/// The traits and types most code needs: `use liebayes_manifolds::prelude::*;`.
pub mod prelude {
    pub use crate::{
        GroupAction, Left, LieGroup, Manifold, ManifoldError, MeanSettings, ProductManifold, Real,
        Rn, S2, Se2, Se3, Se23, So2, So3, Su2, product_manifold, weighted_mean,
    };
}
