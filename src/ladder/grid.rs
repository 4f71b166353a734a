//! One builder for every list of rungs the project charts or chooses from: a grid of
//! curvature rungs (CC, PCC pieces per section) and rod rungs (models x guide-mass
//! models x integrators, optionally the arc coupling's twins). The named lists
//! ([`super::full_ladder`], [`super::auto_ladder`], [`super::readings_ladder`], the
//! stability maps' settings) are grids; a new rung family or setting is added here
//! once, not in each list.

use super::{guide_mass_choices, reject_continuous, CcSettings, PccSettings, Rung};
use crate::robot::Robot;
use crate::settings::{CableCoupling, GuideMass, Integrator, RodModel, SolverSettings};

/// Which guide-mass models a grid's rungs take.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MassChoice {
    /// Those worth distinguishing on the robot ([`guide_mass_choices`]).
    Relevant,
    /// One model.
    Only(GuideMass),
}

/// When a grid's curvature rungs (CC, PCC) are left out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CurvatureRungs {
    /// Always listed.
    Always,
    /// Left out when a tendon is routed continuously on a path the curvature rungs
    /// reject ([`reject_continuous`]).
    UnlessRejected,
}

/// A grid of rungs, listed in this order: CC; PCC (mass outer, pieces inner); rod
/// rungs (model, then mass, then the RK4 steps, then the adaptive tolerances); with
/// `arc_twins` and disks on the robot, the arc-coupling twin of every RK4 rod rung.
#[derive(Clone, Debug, PartialEq)]
pub struct LadderGrid {
    /// Whether the curvature rungs are left out on a robot they reject.
    pub curvature: CurvatureRungs,
    /// List the constant-curvature rung.
    pub cc: bool,
    /// PCC pieces per section (none: no PCC rung).
    pub pcc_pieces: Vec<usize>,
    /// Guide-mass models of the PCC rungs.
    pub pcc_masses: MassChoice,
    /// Rod models of the rod rungs.
    pub rod_models: Vec<RodModel>,
    /// Guide-mass models of the rod rungs.
    pub rod_masses: MassChoice,
    /// RK4 steps per section of the rod rungs.
    pub rk4_steps: Vec<usize>,
    /// Adaptive Dormand-Prince tolerances of the rod rungs (at most 100,000 steps).
    pub adaptive_tols: Vec<f64>,
    /// With disks on the robot: an arc-coupling twin of every RK4 rod rung.
    pub arc_twins: bool,
}

impl LadderGrid {
    /// The rungs of this grid on `robot`.
    pub fn rungs(&self, robot: &Robot) -> Vec<Rung> {
        let masses = |choice: MassChoice| match choice {
            MassChoice::Relevant => guide_mass_choices(robot),
            MassChoice::Only(g) => vec![g],
        };
        let mut out = Vec::new();
        let curvature = match self.curvature {
            CurvatureRungs::Always => true,
            CurvatureRungs::UnlessRejected => reject_continuous(robot).is_ok(),
        };
        if curvature {
            if self.cc {
                out.push(Rung::ConstantCurvature(CcSettings::default()));
            }
            for g in masses(self.pcc_masses) {
                for &pieces in &self.pcc_pieces {
                    out.push(Rung::PiecewiseConstantCurvature(PccSettings {
                        pieces_per_section: pieces,
                        guide_mass: g,
                        ..PccSettings::default()
                    }));
                }
            }
        }
        let first_rod = out.len();
        let rod_masses = masses(self.rod_masses);
        for &model in &self.rod_models {
            for &g in &rod_masses {
                let rk4 = self.rk4_steps.iter().map(|&n| Integrator::Rk4 {
                    steps_per_section: n,
                });
                let adaptive = self.adaptive_tols.iter().map(|&tol| Integrator::Adaptive {
                    tol,
                    max_steps: super::ADAPTIVE_MAX_STEPS,
                });
                for integrator in rk4.chain(adaptive) {
                    out.push(Rung::Rod(SolverSettings {
                        rod_model: model,
                        guide_mass: g,
                        integrator,
                        ..SolverSettings::default()
                    }));
                }
            }
        }
        if self.arc_twins && !robot.guides().is_empty() {
            let twins: Vec<Rung> = out[first_rod..]
                .iter()
                .filter_map(|r| match r {
                    Rung::Rod(s) if matches!(s.integrator, Integrator::Rk4 { .. }) => {
                        Some(Rung::Rod(SolverSettings {
                            cable_coupling: CableCoupling::Arc,
                            ..s.clone()
                        }))
                    }
                    _ => None,
                })
                .collect();
            out.extend(twins);
        }
        out
    }

    /// `cablesense pareto`'s ladder ([`super::full_ladder`]).
    pub fn full() -> Self {
        Self {
            curvature: CurvatureRungs::UnlessRejected,
            cc: true,
            pcc_pieces: vec![4, 8, 16, 32],
            pcc_masses: MassChoice::Relevant,
            rod_models: vec![RodModel::Kirchhoff, RodModel::Cosserat],
            rod_masses: MassChoice::Relevant,
            rk4_steps: vec![4, 8, 16, 32, 64],
            adaptive_tols: vec![1e-4, 1e-6, 1e-8, 1e-10],
            arc_twins: false,
        }
    }

    /// `--model auto`'s ladder ([`super::auto_ladder`]).
    pub fn auto() -> Self {
        Self {
            pcc_pieces: vec![4, 16],
            adaptive_tols: vec![1e-8],
            ..Self::full()
        }
    }

    /// The readings ladder ([`super::readings_ladder`]): the kinematics' PCC has no
    /// mass, and the rod rungs get their arc twins.
    pub fn readings() -> Self {
        Self {
            pcc_masses: MassChoice::Only(GuideMass::None),
            arc_twins: true,
            ..Self::auto()
        }
    }

    /// The forward stability map's settings
    /// (`experiments::stability::forward_settings`).
    pub fn stability_forward() -> Self {
        Self {
            curvature: CurvatureRungs::UnlessRejected,
            cc: true,
            pcc_pieces: vec![8],
            pcc_masses: MassChoice::Only(GuideMass::Point),
            rod_models: vec![RodModel::Kirchhoff, RodModel::Cosserat],
            rod_masses: MassChoice::Only(GuideMass::Point),
            rk4_steps: vec![8, 32],
            adaptive_tols: vec![1e-8],
            arc_twins: false,
        }
    }

    /// The readings stability map's settings
    /// (`experiments::stability::tdcr::readings_settings`): PCC without mass, and the
    /// curvature rungs always listed (the map's robots route through disks).
    pub fn stability_readings() -> Self {
        Self {
            curvature: CurvatureRungs::Always,
            pcc_masses: MassChoice::Only(GuideMass::None),
            ..Self::stability_forward()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn labels(grid: &LadderGrid, robot: &Robot) -> Vec<String> {
        grid.rungs(robot).iter().map(Rung::label).collect()
    }

    /// The named grids on the shipped FTDCR v4 (disks with mass, no continuous
    /// tendon): the stability maps' lists label by label, the other lists by count,
    /// ends and the order of their parts (CC, PCC mass by mass, rods model by model,
    /// the arc twins last).
    #[test]
    fn the_named_grids_list_their_rungs_in_order() {
        let scene = crate::Scene::load("data/scenes/ftdcr_v4.toml").expect("shipped scene");
        let robot = scene.build_robot().expect("robot");
        let rods = [
            "kirchhoff/point/rk4-8",
            "kirchhoff/point/rk4-32",
            "kirchhoff/point/adaptive-1e-8",
            "cosserat/point/rk4-8",
            "cosserat/point/rk4-32",
            "cosserat/point/adaptive-1e-8",
        ];
        let mut want = vec!["cc", "pcc/point/8"];
        want.extend(rods);
        assert_eq!(labels(&LadderGrid::stability_forward(), &robot), want);
        want[1] = "pcc/none/8";
        assert_eq!(labels(&LadderGrid::stability_readings(), &robot), want);

        let full = labels(&LadderGrid::full(), &robot);
        assert_eq!(full.len(), 1 + 3 * 4 + 2 * 3 * 9);
        assert_eq!(full[..3], ["cc", "pcc/average/4", "pcc/average/8"]);
        assert_eq!(full[12], "pcc/point/32");
        assert_eq!(full[13], "kirchhoff/average/rk4-4");
        assert_eq!(full[21], "kirchhoff/average/adaptive-1e-10");
        assert_eq!(full.last().unwrap(), "cosserat/point/adaptive-1e-10");

        let auto = labels(&LadderGrid::auto(), &robot);
        assert_eq!(auto.len(), 1 + 3 * 2 + 2 * 3 * 6);
        assert_eq!(auto[..3], ["cc", "pcc/average/4", "pcc/average/16"]);
        assert_eq!(auto[7], "kirchhoff/average/rk4-4");
        assert_eq!(auto[12], "kirchhoff/average/adaptive-1e-8");

        let readings = labels(&LadderGrid::readings(), &robot);
        assert_eq!(readings.len(), 3 + 2 * 3 * 6 + 2 * 3 * 5);
        assert_eq!(readings[..3], ["cc", "pcc/none/4", "pcc/none/16"]);
        assert_eq!(readings[3..39], auto[7..]);
        assert_eq!(readings[39], "kirchhoff/average/rk4-4/arc");
        assert_eq!(readings.last().unwrap(), "cosserat/point/rk4-64/arc");
    }
}
