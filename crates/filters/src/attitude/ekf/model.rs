//! The production filter's state and models: the state manifold with its named tangent blocks, the
//! preintegrated block of samples and its process model, and the measurement models (zero
//! velocity, rest bias, heading).

use super::params::FieldOffset;
use liebayes_manifolds::wrap_angle;
use liebayes_manifolds::{Left, ProductManifold, Rn, So3};
use liebayes_operators::{MeasurementModel, ProcessModel};
use nalgebra::{Matrix3, SMatrix, SVector, UnitQuaternion, Vector3};
use std::ops::{AddAssign, Range};

/// The filter's state: attitude (IMU frame w.r.t. ENU, error `R = exp([δθ]ₓ) R̂` in the world
/// frame) × (gyro bias b (rad/s, IMU frame), horizontal velocity v (m/s, East, North), the local
/// field's heading offset c (rad, the field's heading east of true north), horizontal position p
/// (m, East, North, from the start)); tangent order (δθ, δb, δv, δc, δp): [`ATTITUDE`], [`BIAS`],
/// [`VELOCITY`], [`OFFSET`], [`POSITION`].
pub type AttitudeState = ProductManifold<Left<So3<f64>>, Rn<f64, 8>, 3, 8, 11>;

/// The state's dimension.
pub const STATE_DIM: usize = 11;

/// Tangent indices of the world-frame attitude error δθ (x, y: tilt; z: heading).
pub const ATTITUDE: Range<usize> = 0..3;
/// Tangent indices of the gyro bias.
pub const BIAS: Range<usize> = 3..6;
/// Tangent indices of the horizontal velocity (East, North).
pub const VELOCITY: Range<usize> = 6..8;
/// Tangent index of the field's heading offset c.
pub const OFFSET: usize = 8;
/// Tangent indices of the horizontal position (East, North; m, from the start).
pub const POSITION: Range<usize> = 9..11;

/// Index of a tangent coordinate (of the bias, velocity or offset) in the `Rn<6>` factor.
pub(crate) const fn in_rest(tangent: usize) -> usize {
    tangent - ATTITUDE.end
}

/// The covariance block of the attitude error (rad²).
pub(crate) fn attitude_block(p: &SMatrix<f64, STATE_DIM, STATE_DIM>) -> Matrix3<f64> {
    p.fixed_view::<3, 3>(ATTITUDE.start, ATTITUDE.start)
        .into_owned()
}

/// The preintegrated increments of one block of gyroscope and accelerometer samples, in the IMU
/// frame at the block's start (`ΔRᵢ` the rotation from the start to sample i):
/// `ΔR = Π exp([ωᵢ − b̂]ₓ Δt)`, `Δv = Σ ½ (ΔRᵢ₋₁ + ΔRᵢ) fᵢ Δt`, `Δp = Σ Δvᵢ Δt` (`Δvᵢ` the sum
/// up to sample i), `B = Σ ΔRᵢ Δt`, `T = n Δt`, with the bias `b̂` they were integrated with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Block {
    /// `ΔR`.
    pub rotation: UnitQuaternion<f64>,
    /// `Δv` (m/s, start frame).
    pub velocity: Vector3<f64>,
    /// `Δp = Σ Δvᵢ Δt` (m, start frame): the velocity increments integrated.
    pub position: Vector3<f64>,
    /// `B` (s): how the bias moves the attitude.
    pub bias_coupling: Matrix3<f64>,
    /// `T` (s).
    pub duration: f64,
    /// `b̂` (rad/s).
    pub bias: Vector3<f64>,
}

impl Block {
    pub(crate) fn empty(bias: Vector3<f64>) -> Self {
        Self {
            rotation: UnitQuaternion::identity(),
            velocity: Vector3::zeros(),
            position: Vector3::zeros(),
            bias_coupling: Matrix3::zeros(),
            duration: 0.0,
            bias,
        }
    }

    /// `ΔR exp([ω − b̂]ₓ Δt)`: the rotation to the end of one more sample, gyroscope ω over the
    /// interval Δt, for [`push`](Self::push). Apart, so that a filter can check the orientation it
    /// gives before the block changes.
    pub(crate) fn turned(&self, gyro: &Vector3<f64>, dt: f64) -> UnitQuaternion<f64> {
        self.rotation * crate::attitude::rotation(&((gyro - self.bias) * dt))
    }

    /// Adds one sample: its rotation `rotation` ([`turned`](Self::turned) with its gyroscope),
    /// accelerometer f, interval Δt. Both sensors' samples are taken as their means over the
    /// same interval, through which the sensor turns from `ΔRᵢ₋₁` to `ΔRᵢ`, so the specific force
    /// is rotated by the interval's mean rotation, `½ (ΔRᵢ₋₁ + ΔRᵢ)` (the trapezoid rule, exact to
    /// second order in the turn |ω| Δt).
    pub(crate) fn push(&mut self, rotation: UnitQuaternion<f64>, acc: &Vector3<f64>, dt: f64) {
        let before = self.rotation.to_rotation_matrix().into_inner();
        self.rotation = rotation;
        let r = self.rotation.to_rotation_matrix().into_inner();
        self.velocity += (before + r) * acc * (0.5 * dt);
        self.position += self.velocity * dt;
        self.bias_coupling += r * dt;
        self.duration += dt;
    }
}

/// The block's process model on [`AttitudeState`]:
/// `R′ = exp(−[R B (b − b̂)]ₓ) R ΔR`, `b′ = b`, `v′ = v + (R Δv)_xy`, `c′ = a c` with
/// `a = exp(−T/τ_c)`, `p′ = p + v T + (R Δp)_xy`; noise `min((σ_g² + s² |ω̄|²) T, U) I₃` on the
/// attitude ([`UNIFORM_ROTATION_VARIANCE`] U: beyond it a block leaves the attitude uniformly
/// unknown), `σ_b² T I₃` on the bias, `σ_c² (1 − a²)` on the offset and the velocity's random
/// walk with the position it integrates to, `σ_v² [T, T²/2; T²/2, T³/3]` per axis (|ω̄| the
/// block's mean rate);
/// Jacobian (world-frame error) `∂δθ′/∂δb = −R B`, `∂δv′/∂δθ = −[R Δv]ₓ` and
/// `∂δp′/∂δθ = −[R Δp]ₓ` restricted to the two tilt columns (the accelerometer never turns the
/// heading: its horizontal part is velocity, not direction, information), `∂δp′/∂δv = T I`,
/// `∂δc′/∂δc = a`. The bias's second-order effect on v and p inside a block is omitted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlockProcess {
    /// Gyroscope angle random walk (rad/√s).
    pub gyro_noise: f64,
    /// Rate-proportional attitude noise (√s).
    pub rate_noise: f64,
    /// Bias random walk (rad/s/√s).
    pub bias_walk: f64,
    /// Velocity random walk (m/s/√s).
    pub velocity_walk: f64,
    /// The field offset's process; `None` keeps it constant without noise.
    pub offset: Option<FieldOffset>,
}

/// U = π²/9 + 2/3 ≈ 1.763 rad², the variance per axis of the rotation vector of a uniformly
/// distributed rotation (its angle θ has the density `(1 − cos θ)/π` on [0, π], so
/// `E[θ²] = π²/3 + 2`, shared by three axes): the most attitude noise a block of
/// [`BlockProcess`] adds. A block's `(σ_g² + s² |ω̄|²) T` beyond it says nothing more of an angle
/// that wraps, and made the predicted covariance singular to rounding: at σ_g = 1e4 rad/√s and
/// one sample in 1000 s (T = 1000 s), 1e11 rad² of tilt turned into velocity and position by
/// `g T` and `g T²/2` left their own noise below the rounding of their variances (1e19 and
/// 2e24 m²/s² and m²), and every block after the second failed.
pub const UNIFORM_ROTATION_VARIANCE: f64 =
    std::f64::consts::PI * std::f64::consts::PI / 9.0 + 2.0 / 3.0;

impl BlockProcess {
    /// The offset's factor `a = exp(−T/τ_c)` over `t` seconds (1 without an offset process).
    fn offset_decay(&self, t: f64) -> f64 {
        self.offset
            .as_ref()
            .map_or(1.0, |f| (-t / f.correlation_time).exp())
    }
}

impl ProcessModel<AttitudeState, STATE_DIM> for BlockProcess {
    type Input = Block;

    fn transition(&self, x: &AttitudeState, u: &Block) -> AttitudeState {
        let r = x.first().inner().as_unit_quaternion();
        let rest = x.second().coords();
        let bias = rest.fixed_rows::<3>(in_rest(BIAS.start)).into_owned();
        let turn = r * (u.bias_coupling * (bias - u.bias)).into_owned();
        let attitude = crate::attitude::rotation(&-turn) * r * u.rotation;
        let dv = r * u.velocity;
        let dp = r * u.position;
        let mut next = *rest;
        let (v, p) = (in_rest(VELOCITY.start), in_rest(POSITION.start));
        next[p] += rest[v] * u.duration + dp.x;
        next[p + 1] += rest[v + 1] * u.duration + dp.y;
        next[v] += dv.x;
        next[v + 1] += dv.y;
        next[in_rest(OFFSET)] *= self.offset_decay(u.duration);
        AttitudeState::new(
            Left::new(So3::from_unit_quaternion(attitude)),
            Rn::new_unchecked(next),
        )
    }

    fn noise(&self, _x: &AttitudeState, u: &Block) -> SMatrix<f64, STATE_DIM, STATE_DIM> {
        let t = u.duration;
        // (rate_noise |ω̄|)² T with |ω̄| = angle(ΔR)/T.
        let turned = self.rate_noise * u.rotation.angle();
        let attitude = (self.gyro_noise * self.gyro_noise * t
            + turned * turned / t.max(f64::MIN_POSITIVE))
        .min(UNIFORM_ROTATION_VARIANCE);
        let mut q = SMatrix::<f64, STATE_DIM, STATE_DIM>::zeros();
        for i in ATTITUDE {
            q[(i, i)] = attitude;
        }
        for i in BIAS {
            q[(i, i)] = self.bias_walk * self.bias_walk * t;
        }
        // The velocity's random walk and the position it integrates to: `σ² [T, T²/2; T²/2, T³/3]`.
        let walk = self.velocity_walk * self.velocity_walk;
        for (v, p) in VELOCITY.zip(POSITION) {
            q[(v, v)] = walk * t;
            q[(v, p)] = walk * t * t / 2.0;
            q[(p, v)] = walk * t * t / 2.0;
            q[(p, p)] = walk * t * t * t / 3.0;
        }
        if let Some(f) = &self.offset {
            let a = self.offset_decay(t);
            q[(OFFSET, OFFSET)] = f.sigma * f.sigma * (1.0 - a * a);
        }
        q
    }

    fn jacobian(&self, x: &AttitudeState, u: &Block) -> SMatrix<f64, STATE_DIM, STATE_DIM> {
        let mut f = SMatrix::<f64, STATE_DIM, STATE_DIM>::identity();
        for (i, k, value) in self.jacobian_entries(x, u) {
            f[(i, k)] += value;
        }
        f
    }

    /// `F P Fᵀ` and `P Fᵀ` with F the identity plus its 16 entries off the identity (the terms of
    /// the Jacobian in the type's docs): each entry adds one scaled column of P to `P Fᵀ`, and
    /// one scaled row of that to `F P Fᵀ`, a few hundred operations instead of two dense
    /// products.
    fn propagate_covariance(
        &self,
        x: &AttitudeState,
        u: &Block,
        p: &SMatrix<f64, STATE_DIM, STATE_DIM>,
    ) -> (
        SMatrix<f64, STATE_DIM, STATE_DIM>,
        SMatrix<f64, STATE_DIM, STATE_DIM>,
    ) {
        let entries = self.jacobian_entries(x, u);
        // Column i of P Fᵀ is Σ_k F_ik P[:, k].
        let mut cross = *p;
        for &(i, k, value) in &entries {
            let column = p.column(k) * value;
            cross.column_mut(i).add_assign(&column);
        }
        // Row i of F (P Fᵀ) is Σ_k F_ik (P Fᵀ)[k, :].
        let mut propagated = cross;
        for &(i, k, value) in &entries {
            let row = cross.row(k) * value;
            propagated.row_mut(i).add_assign(&row);
        }
        (propagated, cross)
    }
}

impl BlockProcess {
    /// The Jacobian's entries off the identity, `(row, column, value)`: `−R B` (attitude × bias),
    /// `−[R Δv]ₓ` and `−[R Δp]ₓ` on the tilt columns (velocity and position rows), `T` (position ×
    /// velocity) and `a − 1` on the offset.
    fn jacobian_entries(&self, x: &AttitudeState, u: &Block) -> [(usize, usize, f64); 16] {
        let r = x.first().inner().as_unit_quaternion().to_rotation_matrix();
        let rb = r.matrix() * u.bias_coupling;
        let (a, d) = (r * u.velocity, r * u.position);
        let (tilt_x, tilt_y) = (ATTITUDE.start, ATTITUDE.start + 1);
        let (vx, px) = (VELOCITY.start, POSITION.start);
        let bias = |i: usize, j: usize| (ATTITUDE.start + i, BIAS.start + j, -rb[(i, j)]);
        [
            bias(0, 0),
            bias(0, 1),
            bias(0, 2),
            bias(1, 0),
            bias(1, 1),
            bias(1, 2),
            bias(2, 0),
            bias(2, 1),
            bias(2, 2),
            // −[a]ₓ, rows x and y, columns of the two tilt components.
            (vx, tilt_y, a.z),
            (vx + 1, tilt_x, -a.z),
            (px, tilt_y, d.z),
            (px + 1, tilt_x, -d.z),
            (px, vx, u.duration),
            (px + 1, vx + 1, u.duration),
            (OFFSET, OFFSET, self.offset_decay(u.duration) - 1.0),
        ]
    }
}

/// The pseudo-measurement that the horizontal velocity and position are zero,
/// `z = (v_x, v_y, p_x, p_y) = 0`, noise `diag(σ_v², σ_v², σ_p², σ_p²)`: the bounded velocity (at
/// rest, zero velocity) and the bounded position in one update, at the cost of one. Linear with a
/// constant Jacobian: the posterior covariance and the vector part of the mean equal the two pairs'
/// conditioned in turn; the attitude differs from theirs only at second order in the two
/// corrections (retracting by δ₁ and then δ₂ is not retracting by δ₁ + δ₂), micro-radians here.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ZeroMotion {
    /// σ_v (m/s).
    pub velocity_sigma: f64,
    /// σ_p (m).
    pub position_sigma: f64,
}

impl ZeroMotion {
    /// The tangent indices measured, in the order of z.
    const MEASURED: [usize; 4] = [
        VELOCITY.start,
        VELOCITY.start + 1,
        POSITION.start,
        POSITION.start + 1,
    ];
}

impl MeasurementModel<AttitudeState, STATE_DIM, 4> for ZeroMotion {
    fn predict(&self, x: &AttitudeState) -> SVector<f64, 4> {
        let rest = x.second().coords();
        SVector::<f64, 4>::from_fn(|row, _| rest[in_rest(Self::MEASURED[row])])
    }

    fn noise(&self, _x: &AttitudeState) -> SMatrix<f64, 4, 4> {
        let (v, p) = (self.velocity_sigma.powi(2), self.position_sigma.powi(2));
        SMatrix::<f64, 4, 4>::from_diagonal(&SVector::<f64, 4>::new(v, v, p, p))
    }

    fn jacobian(&self, _x: &AttitudeState) -> SMatrix<f64, 4, STATE_DIM> {
        let mut h = SMatrix::<f64, 4, STATE_DIM>::zeros();
        for (row, column) in Self::MEASURED.into_iter().enumerate() {
            h[(row, column)] = 1.0;
        }
        h
    }
}

/// The low-passed gyroscope at rest as a measurement of the bias, `z = b`, noise `σ² I₃`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct RestBias {
    /// σ of each component (rad/s).
    pub sigma: f64,
}

impl MeasurementModel<AttitudeState, STATE_DIM, 3> for RestBias {
    fn predict(&self, x: &AttitudeState) -> SVector<f64, 3> {
        x.second()
            .coords()
            .fixed_rows::<3>(in_rest(BIAS.start))
            .into_owned()
    }

    fn noise(&self, _x: &AttitudeState) -> SMatrix<f64, 3, 3> {
        SMatrix::<f64, 3, 3>::identity() * (self.sigma * self.sigma)
    }

    fn jacobian(&self, _x: &AttitudeState) -> SMatrix<f64, 3, STATE_DIM> {
        let mut h = SMatrix::<f64, 3, STATE_DIM>::zeros();
        for (row, column) in BIAS.enumerate() {
            h[(row, column)] = 1.0;
        }
        h
    }
}

/// The heading-only magnetometer measurement: the heading `ψ = atan2(m_E, m_N)` of the measured
/// field `m` (IMU frame, brought to the current sample) rotated into the world frame by the
/// state's attitude, less the field's offset c, measured as 0 (North is the reference field's
/// north) with the wrapped residual. Jacobian: `∂/∂δθ_z = −1`, `∂/∂δc = −1`, the tilt columns
/// zero; their share of the error, `h_t P_tt h_tᵀ` with `h_t = ∂ψ/∂δθ_xy`, is in the variance
/// (`tilt_variance`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Heading {
    /// The magnetometer reading in the current IMU frame.
    pub field: Vector3<f64>,
    /// σ of the heading (rad).
    pub sigma: f64,
    /// The tilt's share of the heading variance (rad²).
    pub tilt_variance: f64,
}

impl Heading {
    /// The world-frame field and `∂ψ/∂δθ` (all three columns) at the attitude `r`.
    pub(crate) fn jacobian_full(&self, r: &UnitQuaternion<f64>) -> (Vector3<f64>, Vector3<f64>) {
        let m = r * self.field;
        let h2 = (m.x * m.x + m.y * m.y).max(f64::MIN_POSITIVE);
        // dψ/dm = (m_N, −m_E, 0)/h², dm/dδθ = −[m]ₓ.
        let dpsi = Vector3::new(m.y / h2, -m.x / h2, 0.0);
        (m, -(m.cross_matrix().transpose() * dpsi))
    }
}

impl MeasurementModel<AttitudeState, STATE_DIM, 1> for Heading {
    fn predict(&self, x: &AttitudeState) -> SVector<f64, 1> {
        let m = x.first().inner().as_unit_quaternion() * self.field;
        SVector::<f64, 1>::new(wrap_angle(
            m.x.atan2(m.y) - x.second().coords()[in_rest(OFFSET)],
        ))
    }

    fn noise(&self, _x: &AttitudeState) -> SMatrix<f64, 1, 1> {
        SMatrix::<f64, 1, 1>::new(self.sigma * self.sigma + self.tilt_variance)
    }

    fn residual(&self, z: &SVector<f64, 1>, predicted: &SVector<f64, 1>) -> SVector<f64, 1> {
        SVector::<f64, 1>::new(wrap_angle(z[0] - predicted[0]))
    }

    fn jacobian(&self, _x: &AttitudeState) -> SMatrix<f64, 1, STATE_DIM> {
        let mut h = SMatrix::<f64, 1, STATE_DIM>::zeros();
        h[(0, ATTITUDE.start + 2)] = -1.0;
        h[(0, OFFSET)] = -1.0;
        h
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use liebayes_densities::ManifoldGaussian;
    use liebayes_manifolds::{LieGroup, Manifold};
    use liebayes_operators::{Condition, Ekf, MeasurementFn};
    use nalgebra::{SMatrix, Vector2};

    /// The joint bounded-velocity and bounded-position update against the velocity pair and then
    /// the position pair conditioned in turn (each written out with its own exact Jacobian), on a
    /// prior with every state coupled and a reading off zero: the same covariance and vector part,
    /// and an attitude within the second-order term |δ₁| |δ₂| of the two corrections.
    #[test]
    fn the_joint_bounds_equal_the_two_pairs_in_turn() {
        let a = SMatrix::<f64, STATE_DIM, STATE_DIM>::from_fn(|i, j| {
            ((i * 7 + j * 3) % 11) as f64 / 11.0 - 0.4
        });
        let covariance =
            a * a.transpose() * 0.3 + SMatrix::<f64, STATE_DIM, STATE_DIM>::identity() * 0.05;
        let mean = AttitudeState::new(
            Left::new(So3::exp(&Vector3::new(0.3, -0.2, 1.1))),
            Rn::new_unchecked(SVector::<f64, 8>::from_fn(|i, _| 0.1 * i as f64 - 0.3)),
        );
        let prior = ManifoldGaussian::new(mean, covariance).unwrap();
        let (sigma_v, sigma_p) = (0.7, 1.3);
        let joint = ZeroMotion {
            velocity_sigma: sigma_v,
            position_sigma: sigma_p,
        };
        let z = SVector::<f64, 4>::new(0.4, -0.2, 1.5, 0.9);
        let together = prior.condition(&Ekf(joint), &z).unwrap().posterior;
        let pair = |start: usize, sigma: f64| {
            MeasurementFn::new(
                move |x: &AttitudeState| {
                    x.second()
                        .coords()
                        .fixed_rows::<2>(in_rest(start))
                        .into_owned()
                },
                move |_: &AttitudeState| SMatrix::<f64, 2, 2>::identity() * (sigma * sigma),
            )
            .with_jacobian(move |_: &AttitudeState| {
                let mut h = SMatrix::<f64, 2, STATE_DIM>::zeros();
                h[(0, start)] = 1.0;
                h[(1, start + 1)] = 1.0;
                h
            })
        };
        let velocity = pair(VELOCITY.start, sigma_v);
        let position = pair(POSITION.start, sigma_p);
        let first = prior
            .condition(&Ekf(velocity), &Vector2::new(z[0], z[1]))
            .unwrap()
            .posterior;
        let in_turn = first
            .condition(&Ekf(position), &Vector2::new(z[2], z[3]))
            .unwrap()
            .posterior;
        let gap = together.mean().local(in_turn.mean());
        let vector_gap = gap.fixed_rows::<8>(3).amax();
        assert!(vector_gap < 1e-12, "vector parts {vector_gap:e} apart");
        let attitude = |d: SVector<f64, STATE_DIM>| d.fixed_rows::<3>(ATTITUDE.start).norm();
        let (first_turn, second_turn) = (
            attitude(prior.mean().local(first.mean())),
            attitude(first.mean().local(in_turn.mean())),
        );
        let attitude_gap = attitude(gap);
        assert!(
            attitude_gap < first_turn * second_turn,
            "attitudes {attitude_gap:e} apart, turns {first_turn:e} and {second_turn:e}"
        );
        let difference = (together.covariance() - in_turn.covariance()).amax();
        assert!(difference < 1e-12 * covariance.amax(), "{difference:e}");
        // Not a vacuous comparison: both updates turned the attitude.
        assert!(
            first_turn > 0.01 && second_turn > 0.01,
            "{first_turn} {second_turn}"
        );
    }
}
