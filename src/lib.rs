#![doc = include_str!("../README.md")]
//!
//! ## Crates
//!
//! * [`manifolds`]: spaces and groups (SO(2), SO(3), SU(2), S², Rⁿ) with exact exp/log and right Jacobians.
//! * [`densities`]: probability densities on those spaces and their special functions.
//! * [`operators`]: propagate, condition, and filters as generic algorithms.
//! * [`filters`]: the applications.
//! * [`experiments`]: the experiment layer: one filter interface, scenarios, replay, scoring, and
//!   studies that shard across machines and merge exactly.
//!
//! [`prelude`] gathers what most programs use first: `use liebayes::prelude::*;`.
//!
//! [`nalgebra`] and [`rand`] are re-exported: use `liebayes::nalgebra` and `liebayes::rand` so that your
//! vectors, matrices and random number generators are the exact types the library takes, whatever
//! versions your own crate depends on.
//!
//! ## Features
//!
//! | feature | default | what it adds |
//! |---|---|---|
//! | `cli` | yes | the `liebayes` command-line program (clap, progress bars, SVG plots, JSON summaries; implies `rayon`) |
//! | `proptest` | no | proptest strategies for every space and density, and the law suites |
//! | `rayon` | no | parallel particle weighting and parallel runs of a study |
//! | `serde` | no | `Serialize`/`Deserialize` for points, densities and filter states, read back through the validated constructors |
#![cfg_attr(docsrs, feature(doc_cfg))]

pub use liebayes_densities as densities;
pub use liebayes_experiments as experiments;
pub use liebayes_filters as filters;
pub use liebayes_manifolds as manifolds;
pub use liebayes_operators as operators;
pub use nalgebra;
pub use rand;

/// The traits and types most programs need first: `use liebayes::prelude::*;`. The spaces and
/// their traits (the manifolds crate's prelude), the main densities and their traits, the
/// operators' `Propagate` / `Condition` with the Kalman filters' model wrappers and the particle
/// set, and the experiment layer's filter interface, replay and study.
///
/// # Example
/// ```
/// use liebayes::prelude::*;
/// use liebayes::nalgebra::{Matrix1, Vector1};
///
/// // A heading EKF on SO(2): a compass reading of 0.2 rad with variance 0.01 on a prior of
/// // variance 0.01 at 0 moves the heading half-way.
/// let compass = MeasurementFn::new(|x: &So2<f64>| Vector1::new(x.angle()), |_| Matrix1::new(0.01));
/// let prior = ManifoldGaussian::new(So2::from_angle(0.0).unwrap(), Matrix1::new(0.01)).unwrap();
/// let step = prior.condition(&Ekf(&compass), &Vector1::new(0.2)).unwrap();
/// assert!((step.posterior.mean().angle() - 0.1).abs() < 1e-12);
/// assert!((step.posterior.covariance()[0] - 0.005).abs() < 1e-12);
/// ```
pub mod prelude {
    pub use liebayes_densities::{
        Bingham, Convolve, Density, DensityError, Entropy, Gaussian, HeatKernelSo3, KlDivergence,
        ManifoldGaussian, Product, Rotate, VonMises, VonMisesFisher,
    };
    pub use liebayes_experiments::{
        ExperimentError, ManifoldScorer, Recursive, RecursiveFilter, Scenario, Scorer, Shard, Step,
        Study, Summary, replay,
    };
    pub use liebayes_manifolds::prelude::*;
    pub use liebayes_operators::particle::ParticleSet;
    pub use liebayes_operators::smoother::RtsSmoother;
    pub use liebayes_operators::{
        Condition, Conditioned, Ekf, MeasurementFn, MeasurementModel, OperatorError, ProcessFn,
        ProcessModel, Propagate, Ukf,
    };
}
