//! Why a solve from readings did not converge ([`crate::statics::Diagnosis`]), with
//! each displacement-driven tendon named by its readings column, its pull and the
//! tension the solve reached, instead of `loads.tensions_n[j]` (which a
//! displacement-driven tendon does not read).

use super::TendonWorkspace;
use crate::error::Num;
use crate::statics::{diagnose_named, Diagnosis, LoadShare};

impl TendonWorkspace {
    /// Why the last solve from readings ended as it did: the load intensity of the
    /// tensions it reached (and the scene's loads), split by load, the largest first
    /// (`Workspace::diagnose`; a tendon is named by its readings column). Meant for
    /// a row that did not converge; allocates.
    pub fn diagnose(&self) -> Diagnosis {
        let column = |i: usize| format!("readings column {}", self.columns[i]);
        let names = |j: usize| {
            let i = self.driven.iter().position(|&c| c == j)?;
            let t = Num((self.t[i] * 1e3).round() / 1e3);
            Some((column(i), format!("tension reached {t} N")))
        };
        let ws = &self.ws;
        let r = &self.report;
        let outcome = (r.status, r.residual_m, self.tendon_settings().tolerance_m);
        let mut d = diagnose_named(
            ws.robot(),
            ws.loads(),
            ws.params(),
            ws.theta(),
            &names,
            outcome,
        );
        // the bend each pull asks of the rod by constant-curvature kinematics (path
        // change = hole radius x bending angle: the CC rung's displacement control)
        for (i, &j) in self.driven.iter().enumerate() {
            let pull = self.free0[i] - self.free[i];
            let radius = ws.robot().cables()[j]
                .hole_local
                .last()
                .map_or(0.0, |h| h.norm());
            if pull > 0.0 && radius > 0.0 {
                d.pulls.push(LoadShare {
                    field: column(i),
                    value: format!("{} mm", Num((pull * 1e6).round() / 1e3)),
                    what: format!("at a {} mm hole radius", Num((radius * 1e6).round() / 1e3)),
                    intensity: pull / radius,
                });
            }
        }
        d.pulls.sort_by(|a, b| b.intensity.total_cmp(&a.intensity));
        d
    }
}

#[cfg(test)]
mod tests {
    use crate::Scene;

    /// A 30 mm pull on one tendon of the shipped FTDCR v4 scene (a 62 mm segment)
    /// does not converge from zero readings, and the diagnosis names that tendon's
    /// readings column first among the pulls, with the bend it asks for, and blames
    /// it (the tension the solve reached is no measure of what the pull asks).
    #[test]
    fn an_unreachable_pull_names_the_readings_column() {
        let scene = Scene::load("data/scenes/ftdcr_v4.toml").expect("shipped scene");
        let mut ws = scene.tendon_workspace().expect("workspace");
        let p = ws.driven().len();
        let zero = vec![0.0; p];
        let rep = ws.solve_readings(&zero).expect("valid readings");
        assert!(rep.status.is_converged(), "{rep:?}");
        let mut q = zero.clone();
        q[0] = 0.030;
        let rep = ws.solve_readings(&q).expect("valid readings");
        assert!(!rep.status.is_converged(), "{rep:?}");
        let d = ws.diagnose();
        let column = ws.columns()[0].clone();
        assert_eq!(d.pulls[0].field, format!("readings column {column}"), "{d}");
        assert_eq!(d.pulls[0].value, "30 mm", "{d}");
        // 30 mm at the 4.5 mm hole radius: 6.67 rad, more than a full turn
        assert!((d.pulls[0].intensity - 0.030 / 0.0045).abs() < 1e-9, "{d}");
        assert!(d.loads_blamed(), "{d}");
        assert!(
            d.to_string()
                .contains(&format!("reduce readings column {column}")),
            "{d}"
        );
    }
}
