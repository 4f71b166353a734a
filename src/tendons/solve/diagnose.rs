//! Why a solve from readings did not converge ([`crate::statics::Diagnosis`]), with
//! each displacement-driven tendon named by its readings column, its pull and the
//! tension the solve reached, instead of `loads.tensions_n[j]` (which a
//! displacement-driven tendon does not read).

use super::{TendonWorkspace, Tendons};
use crate::error::Num;
use crate::robot::Robot;
use crate::statics::{diagnose_named, Diagnosis, LoadShare};

impl TendonWorkspace {
    /// Why the last solve from readings ended as it did: the load intensity of the
    /// tensions it reached (and the scene's loads), split by load, the largest first
    /// (`Workspace::diagnose`; a tendon is named by its readings column). Meant for
    /// a row that did not converge; allocates.
    pub fn diagnose(&self) -> Diagnosis {
        let (tendons, free) = (&self.tendons, &self.iter.free);
        let column = |i: usize| format!("readings column {}", tendons.columns[i]);
        let names = |j: usize| {
            let i = tendons.driven.iter().position(|&c| c == j)?;
            let t = Num((self.iter.t[i] * 1e3).round() / 1e3);
            Some((column(i), format!("tension reached {t} N")))
        };
        let ws = &self.ws;
        let r = &self.status.report;
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
        for (i, &j) in tendons.driven.iter().enumerate() {
            let pull = tendons.pull(free, i);
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
        d.compression = tendons.compression(ws.robot(), free);
        d
    }
}

impl Tendons {
    /// How far driven tendon `i` is pulled in from reading 0 (m; `L0 - L_f`) at the
    /// free lengths `free`.
    fn pull(&self, free: &[f64], i: usize) -> f64 {
        self.free0[i] - free[i]
    }

    /// The largest axial load the pulls ask of the backbone, as a share of the Euler
    /// load between two disks; `None` when no section's tendons pull in on the mean.
    ///
    /// The tendons ending in section `k` (`n` of them, evenly spread round the rod:
    /// their path changes cancel in any bend) pulled in by `q_i`: what their mean
    /// `q` does not cancel shortens each path alike, so the rod is compressed (no
    /// bend takes it up) and each tendon stretched, `q = T (c + n L / EA)` (`c` the
    /// tendons' mean compliance, `L` the arc length to their termination, `EA` the
    /// rod's smallest axial stiffness up to it). The axial load `n T`, plus the
    /// pretensions of every driven tendon through section `k`, against the Euler
    /// load `pi^2 EI / h^2` of the rod between the two farthest-apart disks of
    /// sections `0..=k` (pinned ends: the disks hold the rod's position, not its
    /// slope).
    fn compression(&self, robot: &Robot, free: &[f64]) -> Option<LoadShare> {
        let cables = robot.cables();
        let sections = robot.sections();
        let mut best: Option<LoadShare> = None;
        for k in 0..sections.len() {
            let group: Vec<usize> = (0..self.driven.len())
                .filter(|&i| cables[self.driven[i]].end_section == k)
                .collect();
            if group.len() < 2 {
                continue;
            }
            let n = group.len() as f64;
            let q = group.iter().map(|&i| self.pull(free, i)).sum::<f64>() / n;
            if q <= 0.0 {
                continue;
            }
            let c = group
                .iter()
                .map(|&i| self.mech[i].compliance(free[i], 1.0))
                .sum::<f64>()
                / n;
            let length = cables[self.driven[group[0]]].end_s;
            let ea = sections[..=k]
                .iter()
                .map(|s| s.stiffness.shear_stretch.z)
                .fold(f64::INFINITY, f64::min);
            let t = q / (c + n * length / ea);
            let pretension: f64 = (0..self.driven.len())
                .filter(|&i| cables[self.driven[i]].end_section >= k)
                .map(|i| self.mech[i].pretension_n)
                .sum();
            let load = n * t + pretension;
            // the weakest gap between consecutive disks of sections 0..=k
            let (mut euler, mut gap) = (f64::INFINITY, 0.0);
            for s in &sections[..=k] {
                let ei = s.stiffness.bend_twist.x.min(s.stiffness.bend_twist.y);
                let disks = &robot.guides()[s.guides.clone()];
                for w in disks.windows(2) {
                    let h = w[1].s - w[0].s;
                    let e = std::f64::consts::PI.powi(2) * ei / (h * h);
                    if h > 0.0 && e < euler {
                        (euler, gap) = (e, h);
                    }
                }
            }
            if !euler.is_finite() {
                continue;
            }
            let columns: Vec<&str> = group.iter().map(|&i| self.columns[i].as_str()).collect();
            let share = LoadShare {
                field: format!(
                    "the mean pull of section {k}'s tendons ({})",
                    columns.join(", ")
                ),
                value: format!("{} mm", Num((q * 1e6).round() / 1e3)),
                what: format!(
                    "compresses the backbone with about {} N (pretensions included) against \
                     the Euler load pi^2 EI/h^2 = {} N of the rod between disks {} mm apart",
                    Num(load.round()),
                    Num(euler.round()),
                    Num((gap * 1e4).round() / 10.0)
                ),
                intensity: load / euler,
            };
            if best.as_ref().is_none_or(|b| share.intensity > b.intensity) {
                best = Some(share);
            }
        }
        best
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
        assert!(d.to_string().contains("reduce "), "{d}");
    }

    /// The compression a pull asks of the backbone when the antagonists are held,
    /// on the textbook TDCR (1 mm NiTi rod, EI = 60 GPa pi (1 mm)^4 / 64, disks 10
    /// mm apart: Euler load pi^2 EI / h^2 = 291 N): at 2 mm on `s1a` the solve
    /// converges, and the estimate (`compression`) is within 3 % of the axial load
    /// the solve found (the tensions of every tendon through section 0: ~181 N); at
    /// 3 mm it does not converge, the estimate is above
    /// `COMPRESSION_BLAMED_ABOVE` of the Euler load, and the diagnosis blames the
    /// compression.
    #[test]
    fn held_antagonists_compress_the_backbone() {
        let scene = Scene::load("data/scenes/tdcr_two_segment.toml").expect("shipped scene");
        let mut ws = scene.tendon_workspace().expect("workspace");
        // the Euler load from the scene's rod and disk gap (checked against 291 N)
        let robot = ws.workspace().robot();
        let ei = robot.min_bending_stiffness();
        let disks = robot.guides();
        let gap = disks[1].s - disks[0].s;
        let euler = std::f64::consts::PI.powi(2) * ei / (gap * gap);
        assert!((euler - 291.0).abs() < 1.0, "{euler} N");
        let rest = ws.solve_readings(&[0.0; 6]).expect("valid");
        assert!(rest.status.is_converged(), "{rest:?}");
        let rep = ws
            .solve_readings(&[0.002, 0.0, 0.0, 0.0, 0.0, 0.0])
            .expect("valid");
        assert!(rep.status.is_converged(), "{rep:?}");
        let solved: f64 = ws.tensions().iter().sum();
        let c = ws.diagnose().compression.expect("a mean pull in section 0");
        let estimate = c.intensity * euler;
        assert!(
            (estimate - solved).abs() <= 0.03 * solved,
            "{estimate} N against {solved} N ({c:?})"
        );
        let rep = ws
            .solve_readings(&[0.003, 0.0, 0.0, 0.0, 0.0, 0.0])
            .expect("valid");
        assert!(!rep.status.is_converged(), "{rep:?}");
        let d = ws.diagnose();
        let c = d.compression.as_ref().expect("a mean pull in section 0");
        assert!(
            c.intensity > crate::statics::COMPRESSION_BLAMED_ABOVE,
            "{d}"
        );
        assert!(d.to_string().contains("may buckle between disks"), "{d}");
    }
}
