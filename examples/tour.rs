//! A short tour of the library at work: a gyro integrated on SO(3), the logarithm next to a half
//! turn, a Jacobian against a finite difference, the double cover SU(2) → SO(3) and a geodesic on
//! the sphere, then exact Bayes on the circle and exact diffusion on SO(3).
//!
//! ```sh
//! cargo run --example tour
//! ```

use liebayes::manifolds::{GroupAction, LieGroup, Manifold, S2, So3, Su2};
use nalgebra::Vector3;
use std::f64::consts::PI;

fn main() {
    println!("\nThe library at work (manifolds and densities):");
    integrate_a_gyro();
    log_near_pi();
    jacobian_against_finite_difference();
    double_cover_and_sphere();
    densities_demo();
}

/// Bayes on the circle, and diffusion on SO(3), with exact densities.
fn densities_demo() {
    use liebayes::densities::{Convolve, Density, HeatKernelSo3, Product, VonMises};
    use liebayes::manifolds::So2;
    let prior = VonMises::new(So2::from_angle_unchecked(0.5), 4.0).expect("valid");
    let likelihood = VonMises::new(So2::from_angle_unchecked(1.2), 1e6).expect("valid");
    let posterior = prior
        .product(&likelihood)
        .expect("von Mises products are exact");
    println!("\n6. Von Mises Bayes (prior kappa 4, likelihood kappa 1e6, no overflow):");
    println!(
        "   posterior mean {:.9} rad, kappa {:.3}, log evidence {:.6}",
        posterior.mean().map_or(f64::NAN, |m| m.angle()),
        posterior.concentration(),
        prior
            .log_product_integral(&likelihood)
            .expect("finite for von Mises densities")
    );
    let gyro_noise = HeatKernelSo3::new(So3::identity(), 1e-4).expect("valid");
    let after_1000_steps = (1..1000).fold(gyro_noise, |acc, _| {
        acc.convolve(&gyro_noise).expect("variances stay finite")
    });
    println!(
        "7. SO(3) heat kernel: 1000 gyro steps of sigma^2 = 1e-4 convolve exactly to sigma^2 = {:.4}; \
         density at the centre {:.3e}",
        after_1000_steps.variance(),
        after_1000_steps.log_pdf(&after_1000_steps.mean()).exp()
    );
}

/// Integrates a constant angular rate with 10 000 right-multiplied steps and compares with the closed form.
fn integrate_a_gyro() {
    let rate = Vector3::new(0.3, -0.2, 0.9);
    let (dt, steps) = (1e-3, 10_000);
    let step = So3::exp(&(rate * dt));
    let mut attitude = So3::identity();
    for _ in 0..steps {
        attitude = attitude.compose(&step);
    }
    let exact = So3::exp(&(rate * dt * f64::from(steps)));
    println!("1. Gyro integration: 10 000 steps of exp(omega dt) composed on the right");
    println!(
        "   angle {:.12} rad, error against exp(omega T): {:.2e} rad\n",
        attitude.angle(),
        attitude.distance(&exact)
    );
}

/// Shows that the logarithm stays exact at and next to a half turn.
fn log_near_pi() {
    println!("2. Logarithm next to a half turn (the classic failure point of matrix-based logs)");
    let axis = Vector3::new(2.0, -1.0, 2.0) / 3.0;
    for delta in [1e-6, 1e-12, 0.0] {
        let v = axis * (PI - delta);
        let error = (So3::exp(&v).log() - v).norm();
        let matrix = nalgebra::Rotation3::from_scaled_axis(v);
        let matrix_error = (matrix.scaled_axis() - v).norm();
        println!(
            "   angle pi - {delta:.0e}: |log(exp(v)) - v| = {error:.1e} (nalgebra Rotation3::scaled_axis: {matrix_error:.1e})"
        );
    }
    println!();
}

/// Compares the right Jacobian of the action with a central finite difference.
fn jacobian_against_finite_difference() {
    let r = So3::exp(&Vector3::new(0.4, 1.1, -0.7));
    let p = Vector3::new(1.0, -2.0, 0.5);
    let analytic = r.j_act_self(&p);
    let h = 1e-6;
    let numeric = nalgebra::Matrix3::from_fn(|i, j| {
        let e = Vector3::ith(j, h);
        (r.retract(&e).act(&p)[i] - r.retract(&-e).act(&p)[i]) / (2.0 * h)
    });
    println!("3. Right Jacobian of R p with respect to R (perturbation R exp(delta)), -R hat(p)");
    println!(
        "   max |analytic - central difference| = {:.1e}\n",
        (analytic - numeric).amax()
    );
}

/// The double cover SU(2) -> SO(3), and a geodesic step on the sphere.
fn double_cover_and_sphere() {
    let q = Su2::exp(&Vector3::new(0.0, 0.0, 1.0));
    println!(
        "4. SU(2) is a double cover: q and -q are {:.6} apart on SU(2) (tangent norm 2 pi),",
        q.distance(&q.antipode())
    );
    println!(
        "   and {:.1e} apart as rotations in SO(3)",
        q.to_so3().distance(&q.antipode().to_so3())
    );
    let north = S2::new(Vector3::z()).expect("unit vector");
    let moved = north.retract(&nalgebra::Vector2::new(PI / 2.0, 0.0));
    println!(
        "5. S2: a quarter great circle from the north pole reaches {:.3?}, at angle {:.12} rad",
        moved.as_vector().as_slice(),
        north.distance(&moved)
    );
}
