//! The exact azimuth-alignment filter on one simulated run of the circle scenario, beside the
//! EKF on [r, A]: `cargo run --release --example azimuth`.
//!
//! The platform's velocity is known in its own axes, its position is measured in world axes, and
//! the two frames differ by an unknown azimuth. The exact filter holds the posterior in seven
//! numbers. Both filters run through the experiment layer: one scenario, one `replay`, the two
//! filters side by side with `Paired`, and a scorer that reads their azimuth errors.

use liebayes::experiments::{
    Metric, Paired, PairedEstimate, RecursiveFilter, Reduction, Scenario, Scorer, replay,
};
use liebayes::filters::azimuth::{
    AzimuthEstimate, AzimuthScenario, Config, Motion, PositionAzimuth, PositionMeasurement,
    VelocityProcess, ekf, exact,
};
use liebayes::manifolds::Manifold;
use nalgebra::Vector2;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Each filter's azimuth error `estimate ⊟ truth` on SO(2) and its σ_A (deg).
struct SideBySide;

impl Scorer<PositionAzimuth, PairedEstimate<AzimuthEstimate, AzimuthEstimate>> for SideBySide {
    fn metrics(&self) -> Vec<Metric> {
        ["exact_error", "exact_sigma", "ekf_error", "ekf_sigma"]
            .map(|name| Metric::new(name, Reduction::RootMeanSquare, "deg"))
            .to_vec()
    }

    fn score(
        &self,
        truth: &PositionAzimuth,
        pair: &PairedEstimate<AzimuthEstimate, AzimuthEstimate>,
        values: &mut [f64],
    ) {
        for (i, e) in [&pair.first, &pair.second].into_iter().enumerate() {
            let error = e.azimuth.map(|a| truth.second().local(&a)[0]);
            values[2 * i] = error.map_or(f64::NAN, f64::to_degrees);
            values[2 * i + 1] = e.sigma_a().map_or(f64::NAN, f64::to_degrees);
        }
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let config = Config::default();
    let scenario = AzimuthScenario::new(Motion::Circle, config)?;
    let process = VelocityProcess::new(config.q)?;
    let measurement = PositionMeasurement::new(config.sigma_m)?;
    let mut filters = Paired::new(
        exact(process, measurement, Vector2::zeros(), config.sigma0)?,
        ekf(process, measurement, Vector2::zeros(), config.sigma0)?,
    );
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let scores = replay(&mut filters, scenario.simulate(&mut rng)?, &SideBySide)?;
    let show = |x: f64| {
        if x.is_nan() {
            "   -   ".into()
        } else {
            format!("{x:8.3}")
        }
    };
    println!("   t   exact: error  sigma_A     EKF: error  sigma_A   (deg)");
    for k in (0..scores.epochs()).step_by(100) {
        let at = |name| show(scores.get(name, k).unwrap_or(f64::NAN));
        println!(
            "{:4.0}   {} {}    {} {}",
            scores.times[k],
            at("exact_error"),
            at("exact_sigma"),
            at("ekf_error"),
            at("ekf_sigma")
        );
    }
    let density = filters.first().density();
    let estimate = filters.first().estimate()?;
    println!(
        "\nexact filter: kappa {:.1}, E r = ({:.2}, {:.2}) m, log evidence of one more measurement {:.3}",
        density.azimuth().concentration(),
        estimate.mean_r.x,
        estimate.mean_r.y,
        density.log_evidence(&measurement, &Vector2::new(1.0, 0.0))?
    );
    Ok(())
}
