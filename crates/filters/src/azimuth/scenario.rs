//! The seed's three motion scenarios, and a seeded simulator of truth and measurements.

use nalgebra::{Matrix2, Vector2};
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};
use std::f64::consts::PI;

/// How the platform moves (velocity in its own axes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scenario {
    /// `v = 0`: the azimuth is unobservable.
    Static,
    /// `v = 0.5 (cos(2πt/10), sin(2πt/10))`: bounded circles around the origin.
    Circle,
    /// `v = (−1, 2)`: constant velocity, an ever longer lever arm.
    Line,
}

impl Scenario {
    /// All three, in the seed's order.
    pub const ALL: [Scenario; 3] = [Scenario::Static, Scenario::Circle, Scenario::Line];

    /// The velocity at time t.
    pub fn velocity(self, t: f64) -> Vector2<f64> {
        match self {
            Scenario::Static => Vector2::zeros(),
            Scenario::Circle => {
                let (s, c) = (2.0 * PI * t / 10.0).sin_cos();
                Vector2::new(c, s) * 0.5
            }
            Scenario::Line => Vector2::new(-1.0, 2.0),
        }
    }

    /// Its name on the command line: `static`, `circle` or `line`.
    pub fn name(self) -> &'static str {
        match self {
            Scenario::Static => "static",
            Scenario::Circle => "circle",
            Scenario::Line => "line",
        }
    }
}

/// Noise levels and timing; the default is the seed's: 500 s, propagation every 0.1 s, a position
/// measurement every 1 s, σ_m = σ₀ = 1 m, q = 0.1 m/√s, initial position at the origin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Config {
    /// Initial position standard deviation σ₀ (m), per axis.
    pub sigma0: f64,
    /// Position measurement noise σ_m (m), per axis.
    pub sigma_m: f64,
    /// Velocity noise density q (m/√s).
    pub q: f64,
    /// Propagation step (s).
    pub dt: f64,
    /// A measurement every this many steps (at steps 0, n, 2n, …).
    pub measure_every: usize,
    /// Number of propagation steps.
    pub steps: usize,
}

impl Default for Config {
    fn default() -> Self {
        Self {
            sigma0: 1.0,
            sigma_m: 1.0,
            q: 0.1,
            dt: 0.1,
            measure_every: 10,
            steps: 5000,
        }
    }
}

/// One simulated run. At step k: if `k % measure_every == 0` the platform is measured at
/// `positions[k]` (`measurements[k]` is `Some`); then it moves with `velocities[k]` over dt plus noise.
#[derive(Clone, Debug)]
pub struct Simulation {
    /// The true azimuth A, uniform on [0, 2π).
    pub true_azimuth: f64,
    /// The velocity input of every step (platform axes).
    pub velocities: Vec<Vector2<f64>>,
    /// The true position at every step, before the step's motion (platform axes).
    pub positions: Vec<Vector2<f64>>,
    /// `z = R(A) r + n` where a measurement is taken.
    pub measurements: Vec<Option<Vector2<f64>>>,
}

/// A draw of `N(0, I₂)`.
pub(crate) fn normal2<R: Rng + ?Sized>(rng: &mut R) -> Vector2<f64> {
    Vector2::new(StandardNormal.sample(rng), StandardNormal.sample(rng))
}

/// Simulates a run: initial position from `N(0, σ₀² I)` (the filters' prior), true azimuth uniform.
pub fn simulate<R: Rng + ?Sized>(scenario: Scenario, config: &Config, rng: &mut R) -> Simulation {
    let true_azimuth = rng.random::<f64>() * 2.0 * PI;
    let (s, c) = true_azimuth.sin_cos();
    let world_from_platform = Matrix2::new(c, -s, s, c);
    let mut r = normal2(rng) * config.sigma0;
    let mut simulation = Simulation {
        true_azimuth,
        velocities: Vec::with_capacity(config.steps),
        positions: Vec::with_capacity(config.steps),
        measurements: Vec::with_capacity(config.steps),
    };
    for k in 0..config.steps {
        let t = k as f64 * config.dt;
        let measurement = (k % config.measure_every.max(1) == 0)
            .then(|| world_from_platform * r + normal2(rng) * config.sigma_m);
        let v = scenario.velocity(t);
        simulation.positions.push(r);
        simulation.measurements.push(measurement);
        simulation.velocities.push(v);
        r += v * config.dt + normal2(rng) * (config.q * config.dt.sqrt());
    }
    simulation
}
