//! The exact azimuth-alignment filter on one simulated run of the circle scenario, beside the
//! EKF on [r, A]: `cargo run --release --example azimuth`.
//!
//! The platform's velocity is known in its own axes, its position is measured in world axes, and the two
//! frames differ by an unknown azimuth. The exact filter holds the posterior in seven numbers.

use liebayes::filters::azimuth::scenario::{Config, Scenario, simulate};
use liebayes::filters::azimuth::{
    AzimuthDensity, AzimuthFilter, GaussianBaseline, Linearisation, PositionMeasurement,
    VelocityInput, VelocityProcess,
};
use liebayes::manifolds::So2;
use liebayes::operators::OperatorError;
use liebayes::operators::evaluation::estimation_error;
use nalgebra::Vector2;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

fn main() -> Result<(), OperatorError> {
    let config = Config::default();
    let sim = simulate(Scenario::Circle, &config, &mut ChaCha8Rng::seed_from_u64(2))?;
    let truth = So2::from_angle_unchecked(sim.true_azimuth);
    // The azimuth error `estimate ⊟ truth`, wrapped by SO(2).
    let error = |a: f64| estimation_error(&truth, &So2::from_angle_unchecked(a))[0];
    let process = VelocityProcess::new(config.q)?;
    let measurement = PositionMeasurement::new(config.sigma_m)?;
    let mut exact = AzimuthDensity::new(Vector2::zeros(), config.sigma0)?;
    let mut ekf = GaussianBaseline::new(Linearisation::Extended, Vector2::zeros(), config.sigma0)?;
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    println!("true azimuth {:.2} deg", sim.true_azimuth.to_degrees());
    println!("   t   exact: error  sigma_A     EKF: error  sigma_A   (deg)");
    for (k, v) in sim.velocities.iter().enumerate() {
        if let Some(z) = sim.measurements[k] {
            exact.update(&measurement, &z)?;
            AzimuthFilter::update(&mut ekf, &measurement, &z, &mut rng)?;
            if k % 1000 == 0 {
                let (e, b) = (exact.estimate()?, ekf.estimate()?);
                let show = |x: Option<f64>| {
                    x.map_or("   -   ".into(), |x| format!("{:8.3}", x.to_degrees()))
                };
                println!(
                    "{:4.0}   {} {}    {} {}",
                    k as f64 * config.dt,
                    show(e.azimuth.map(error)),
                    show(e.sigma_a()),
                    show(b.azimuth.map(error)),
                    show(b.sigma_a()),
                );
            }
        }
        let input = VelocityInput {
            velocity: *v,
            dt: config.dt,
        };
        exact.predict(&process, &input)?;
        AzimuthFilter::predict(&mut ekf, &process, &input, &mut rng)?;
    }
    let final_state = exact.estimates();
    println!(
        "\nexact filter: kappa {:.1}, E r = ({:.2}, {:.2}) m, log evidence of one more measurement {:.3}",
        final_state.kappa,
        final_state.mean_r.x,
        final_state.mean_r.y,
        exact.log_evidence(&measurement, &Vector2::new(1.0, 0.0))?
    );
    Ok(())
}
