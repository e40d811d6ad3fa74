//! Instruction counts of the manifold layer beside nalgebra, for a measurement that does not depend on
//! the load of a shared machine: run it under callgrind, once with `none` (the setup alone) and once per
//! operation, and divide the difference by the number of calls (10⁶).
//!
//! ```sh
//! cargo build --release --example bench_instructions
//! for op in none exp_ours exp_nalgebra log_ours log_nalgebra compose_ours compose_nalgebra act_ours act_nalgebra; do
//!   valgrind --tool=callgrind --callgrind-out-file=/dev/null \
//!     target/release/examples/bench_instructions $op 2>&1 | grep Collected
//! done
//! ```

use liebayes::manifolds::{GroupAction, LieGroup, So3};
use nalgebra::{UnitQuaternion, Vector3};
use std::hint::black_box;

const INPUTS: u32 = 100_000;
const REPEATS: usize = 10;

fn main() {
    let v: Vec<_> = (0..INPUTS)
        .map(|i| {
            let t = f64::from(i) * 0.001;
            let angle = 3.0 * f64::from((i * 7919) % 1000) / 1000.0;
            Vector3::new(t.sin(), (1.3 * t).cos(), 0.5).normalize() * angle
        })
        .collect();
    let ours: Vec<_> = v.iter().map(So3::exp).collect();
    let theirs: Vec<_> = v
        .iter()
        .map(|x| UnitQuaternion::from_scaled_axis(*x))
        .collect();
    let op = std::env::args().nth(1).unwrap_or_else(|| "none".into());
    let mut sum = 0.0;
    for _ in 0..REPEATS {
        match op.as_str() {
            "none" => {}
            "exp_ours" => v
                .iter()
                .for_each(|x| sum += So3::exp(black_box(x)).to_quaternion_wxyz()[0]),
            "exp_nalgebra" => v
                .iter()
                .for_each(|x| sum += UnitQuaternion::from_scaled_axis(*black_box(x)).w),
            "log_ours" => ours.iter().for_each(|r| sum += black_box(r).log().x),
            "log_nalgebra" => theirs
                .iter()
                .for_each(|q| sum += black_box(q).scaled_axis().x),
            "compose_ours" => ours.windows(2).for_each(|w| {
                sum += black_box(&w[0])
                    .compose(black_box(&w[1]))
                    .to_quaternion_wxyz()[0];
            }),
            "compose_nalgebra" => theirs
                .windows(2)
                .for_each(|w| sum += (black_box(&w[0]) * black_box(&w[1])).w),
            "act_ours" => ours
                .iter()
                .zip(&v)
                .for_each(|(r, p)| sum += black_box(r).act(black_box(p)).x),
            "act_nalgebra" => theirs
                .iter()
                .zip(&v)
                .for_each(|(q, p)| sum += (black_box(q) * black_box(p)).x),
            other => {
                eprintln!("unknown operation {other}");
                std::process::exit(2);
            }
        }
    }
    println!("{op}: checksum {sum}");
}
