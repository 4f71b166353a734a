//! The capstan friction of a solve from readings (parent module docs): the law,
//! each driven tendon's sliding direction from its readings, and the chord factors
//! of the last shape, refreshed after each joint solve (the lagged coupling).

use super::TendonWorkspace;
use crate::robot::FrictionLaw;
use crate::statics::Workspace;
use nalgebra::Vector3;

/// The friction law and its state per driven tendon.
#[derive(Clone)]
pub(super) struct Friction {
    /// The law ([`FrictionLaw`]): configuration.
    law: FrictionLaw,
    /// Direction state (-1 pulled in, +1 paid out, 0 at rest, between while turning
    /// round under the pre-sliding law) and the reading it was last moved from.
    pub(super) sign: Vec<f64>,
    last_q: Vec<f64>,
    /// Chord factors (scratch of `refresh`).
    factors: Vec<Vec<f64>>,
}

impl Friction {
    /// At rest, every factor 1; `chords` per driven tendon.
    pub(super) fn new(law: FrictionLaw, chords: impl Iterator<Item = usize>) -> Self {
        let factors: Vec<Vec<f64>> = chords.map(|c| vec![1.0; c]).collect();
        let p = factors.len();
        Self {
            law,
            sign: vec![0.0; p],
            last_q: vec![0.0; p],
            factors,
        }
    }

    /// Every tendon at rest with its last reading 0 (as at construction).
    pub(super) fn forget_direction_memory(&mut self) {
        self.sign.fill(0.0);
        self.last_q.fill(0.0);
    }

    /// Tendon `i`'s direction state from its new pull `q` (m): the way it last
    /// moved (`FrictionLaw::next_direction`; frictionless, it stays 0).
    pub(super) fn follow_reading(&mut self, i: usize, q: f64) {
        let (s, moved) = self.law.next_direction(self.sign[i], q - self.last_q[i]);
        self.sign[i] = s;
        if moved {
            self.last_q[i] = q;
        }
    }

    /// Capstan factors of the driven cables `driven` from the current shape of `ws`
    /// (set there when they moved), and each one's length-weighted mean, the factor
    /// of its stretch (`mean_factor`); `true` when they did not change.
    pub(super) fn refresh(
        &mut self,
        ws: &mut Workspace,
        driven: &[usize],
        mean_factor: &mut [f64],
    ) -> bool {
        if self.law.is_frictionless() {
            return true;
        }
        let axis = ws.robot().base_rotation() * Vector3::z();
        let mut settled = true;
        for (i, &j) in driven.iter().enumerate() {
            let base = ws.base_hole_world(j);
            let holes = ws.cable_holes(j);
            let f = &mut self.factors[i];
            self.law.chord_factors(self.sign[i], &axis, &base, holes, f);
            let old = ws.chord_factors(j);
            let changed = old.iter().zip(f.iter()).any(|(a, b)| (a - b).abs() > 1e-13);
            // length-weighted mean factor of the chords, for the stretch
            let (mut prev, mut total, mut weighted) = (base, 0.0, 0.0);
            for (h, fk) in holes.iter().zip(f.iter()) {
                let l = (h - prev).norm();
                total += l;
                weighted += l * fk;
                prev = *h;
            }
            mean_factor[i] = if total > 0.0 { weighted / total } else { 1.0 };
            if changed {
                // (setting them invalidates the last pass: only when they moved)
                ws.set_chord_factors(j, &self.factors[i]);
                settled = false;
            }
        }
        settled
    }
}

impl TendonWorkspace {
    /// [`Friction::refresh`] at the current shape, into the iterate's mean factors.
    pub(super) fn refresh_factors(&mut self) -> bool {
        let (driven, mf) = (&self.tendons.driven, &mut self.iter.mean_factor);
        self.friction.refresh(&mut self.ws, driven, mf)
    }
}

impl crate::math::warm::WarmCopy for Friction {
    fn warm_copy_from(&mut self, src: &Self) {
        crate::math::warm::warm_fields!(self, src,
            copy: [sign, last_q, factors], keep: [law]);
    }
}
