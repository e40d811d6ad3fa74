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

pub use liebayes_densities as densities;
pub use liebayes_experiments as experiments;
pub use liebayes_filters as filters;
pub use liebayes_manifolds as manifolds;
pub use liebayes_operators as operators;
pub use nalgebra;
pub use rand;
