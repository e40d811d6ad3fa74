//! The magnetometer's bookkeeping: the reference field's norm and dip learned online, and the
//! decision, for each heading update, whether the field is disturbed, whether a lasting disturbance
//! has become the new reference, and how tight the innovation gate is.

use super::params::DisturbanceParams;
use crate::scaled::unit_and_norm;
use nalgebra::Vector3;

/// A field's norm (in the reading's unit) and dip `asin(m_z / |m|)` (rad) of the field `m` in the
/// world frame (ENU: negative where the field points down, as in the northern hemisphere).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct FieldReference {
    pub norm: f64,
    pub dip: f64,
}

impl FieldReference {
    /// The norm and dip of a field `world` in the world frame (ENU), `None` for a zero or
    /// non-finite field. Scale-free (the reading's unit is any): a field whose squares underflow
    /// or overflow (1e-300 or 1e200 in its unit) is measured scaled by its largest component.
    pub fn of(world: &Vector3<f64>) -> Option<Self> {
        let norm = world.norm();
        let (up, norm) = if norm.is_normal() {
            (world.z / norm, norm)
        } else {
            let (unit, norm) = unit_and_norm(world)?;
            (unit.z, norm)
        };
        norm.is_finite().then(|| Self {
            norm,
            dip: up.clamp(-1.0, 1.0).asin(),
        })
    }

    /// Whether `observed` lies within the thresholds of this reference.
    fn admits(&self, observed: &FieldReference, d: &DisturbanceParams) -> bool {
        (observed.norm - self.norm).abs() <= d.norm_threshold * self.norm
            && (observed.dip - self.dip).abs() <= d.dip_threshold
    }

    /// Moves a fraction `a` of the way to `observed`.
    fn follow(&mut self, observed: &FieldReference, a: f64) {
        self.norm += (observed.norm - self.norm) * a;
        self.dip += (observed.dip - self.dip) * a;
    }
}

/// What to do with one heading update.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Verdict {
    /// Condition on the reading, refusing it if its NIS exceeds `gate`; `renew_offset` when a new
    /// reference field was just adopted (its heading offset is a new unknown).
    Use { gate: f64, renew_offset: bool },
    /// The field is disturbed: no update.
    Reject,
}

/// The magnetometer's running state.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Magnetometer {
    pub reference: FieldReference,
    /// The candidate for a new reference during a disturbance, and how long it has held (s).
    candidate: Option<(FieldReference, f64)>,
    /// Whether the last heading update was refused (disturbance or gate).
    pub disturbed: bool,
    /// How long the NIS gate has refused every reading (s).
    gated: f64,
    /// How long the first reference has been learned (s).
    learned: f64,
}

impl Magnetometer {
    /// Starts from the first reading's field.
    pub fn new(reference: FieldReference) -> Self {
        Self {
            reference,
            candidate: None,
            disturbed: false,
            gated: 0.0,
            learned: 0.0,
        }
    }

    /// Judges the field `observed` at a heading update, `interval` seconds after the last one.
    /// Without disturbance settings every reading is used without a gate. Otherwise: during the
    /// first `first_field_time` the reference is the running mean of the readings (all used); then
    /// a reading within the thresholds of the reference is used; one outside them is refused,
    /// unless the readings have agreed with each other (within the thresholds of the first of
    /// them) for `new_field_time`, when they become the new reference. The gate is `nis_gate`
    /// until the gate has refused every reading for `gate_time`, then open for one reading.
    pub fn judge(
        &mut self,
        observed: &FieldReference,
        interval: f64,
        disturbance: Option<&DisturbanceParams>,
    ) -> Verdict {
        let Some(d) = disturbance else {
            return Verdict::Use {
                gate: f64::INFINITY,
                renew_offset: false,
            };
        };
        let mut renew_offset = false;
        if self.learned < d.first_field_time {
            self.learned += interval;
            self.reference.follow(observed, interval / self.learned);
            self.candidate = None;
        } else if self.reference.admits(observed, d) {
            self.candidate = None;
        } else {
            self.candidate = match self.candidate {
                Some((c, held)) if c.admits(observed, d) => Some((c, held + interval)),
                _ => Some((*observed, 0.0)),
            };
            match self.candidate {
                Some((c, held)) if held >= d.new_field_time => {
                    self.reference = c;
                    self.candidate = None;
                    renew_offset = true;
                }
                _ => {
                    self.disturbed = true;
                    return Verdict::Reject;
                }
            }
        }
        let gate = if self.gated < d.gate_time {
            d.nis_gate
        } else {
            f64::INFINITY
        };
        Verdict::Use { gate, renew_offset }
    }

    /// Records whether the update judged usable passed the gate: an accepted reading pulls the
    /// reference towards itself (time constant `reference_tau`).
    pub fn conclude(
        &mut self,
        observed: &FieldReference,
        accepted: bool,
        interval: f64,
        disturbance: Option<&DisturbanceParams>,
    ) {
        self.disturbed = !accepted;
        if accepted {
            self.gated = 0.0;
            if let Some(d) = disturbance {
                self.reference
                    .follow(observed, (interval / d.reference_tau).min(1.0));
            }
        } else {
            self.gated += interval;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> DisturbanceParams {
        DisturbanceParams {
            norm_threshold: 0.1,
            dip_threshold: 0.2,
            nis_gate: 25.0,
            gate_time: 5.0,
            reference_tau: 20.0,
            new_field_time: 3.0,
            first_field_time: 2.0,
        }
    }

    const EARTH: FieldReference = FieldReference {
        norm: 50.0,
        dip: 1.0,
    };

    /// A magnetometer past its learning time, on the earth's field.
    fn learned() -> Magnetometer {
        let mut m = Magnetometer::new(EARTH);
        for _ in 0..4 {
            assert!(matches!(
                m.judge(&EARTH, 1.0, Some(&params())),
                Verdict::Use { .. }
            ));
        }
        m
    }

    #[test]
    fn first_reference_is_the_running_mean() {
        let mut m = Magnetometer::new(EARTH);
        let d = params();
        let other = FieldReference {
            norm: 70.0,
            dip: 0.0,
        };
        // Learning: everything is used and averaged (mean of 50, 70 after the second second).
        assert!(matches!(
            m.judge(&EARTH, 1.0, Some(&d)),
            Verdict::Use { .. }
        ));
        assert!(matches!(
            m.judge(&other, 1.0, Some(&d)),
            Verdict::Use { .. }
        ));
        assert!((m.reference.norm - 60.0).abs() < 1e-12);
        assert!((m.reference.dip - 0.5).abs() < 1e-12);
    }

    #[test]
    fn a_short_disturbance_is_refused_and_a_lasting_one_adopted() {
        let d = params();
        let mut m = learned();
        let magnet = FieldReference {
            norm: 80.0,
            dip: 1.0,
        };
        // Refused for new_field_time (3 s), adopted at the fourth reading that agrees.
        for _ in 0..3 {
            assert_eq!(m.judge(&magnet, 1.0, Some(&d)), Verdict::Reject);
            assert!(m.disturbed);
        }
        assert_eq!(
            m.judge(&magnet, 1.0, Some(&d)),
            Verdict::Use {
                gate: 25.0,
                renew_offset: true
            }
        );
        assert_eq!(m.reference, magnet);
    }

    #[test]
    fn a_wandering_disturbance_is_never_adopted() {
        let d = params();
        let mut m = learned();
        for k in 0..20 {
            // Alternating between two disturbed fields that disagree with each other.
            let norm = if k % 2 == 0 { 80.0 } else { 30.0 };
            let observed = FieldReference { norm, dip: 1.0 };
            assert_eq!(m.judge(&observed, 1.0, Some(&d)), Verdict::Reject);
        }
        assert_eq!(m.reference, EARTH);
    }

    #[test]
    fn the_gate_opens_after_refusing_for_gate_time() {
        let d = params();
        let mut m = learned();
        for _ in 0..5 {
            assert_eq!(
                m.judge(&EARTH, 1.0, Some(&d)),
                Verdict::Use {
                    gate: 25.0,
                    renew_offset: false
                }
            );
            m.conclude(&EARTH, false, 1.0, Some(&d));
        }
        assert_eq!(
            m.judge(&EARTH, 1.0, Some(&d)),
            Verdict::Use {
                gate: f64::INFINITY,
                renew_offset: false
            }
        );
        m.conclude(&EARTH, true, 1.0, Some(&d));
        assert!(!m.disturbed);
        assert!(matches!(
            m.judge(&EARTH, 1.0, Some(&d)),
            Verdict::Use { gate, .. } if gate == 25.0
        ));
    }

    #[test]
    fn accepted_readings_pull_the_reference() {
        let d = params();
        let mut m = learned();
        let near = FieldReference {
            norm: 52.0,
            dip: 1.05,
        };
        m.conclude(&near, true, 1.0, Some(&d));
        // One twentieth of the way (interval 1 s, tau 20 s).
        assert!((m.reference.norm - 50.1).abs() < 1e-12);
        assert!((m.reference.dip - 1.0025).abs() < 1e-12);
    }

    #[test]
    fn without_settings_everything_is_used_ungated() {
        let mut m = Magnetometer::new(EARTH);
        let far = FieldReference {
            norm: 500.0,
            dip: -1.0,
        };
        assert_eq!(
            m.judge(&far, 1.0, None),
            Verdict::Use {
                gate: f64::INFINITY,
                renew_offset: false
            }
        );
    }
}
