//! Shared test helpers: robot builders and one tolerance helper.
#![allow(dead_code)]

use cablesense::robot::{CableSpec, GuideSpec, HolesSpec, SectionSpec};
use cablesense::{CrossSection, Material, Robot, RobotSpec};

/// `|got - want| <= abs + rel * |want|`; the message names what, index and `s`.
#[derive(Clone, Copy, Debug)]
pub struct Tol {
    pub abs: f64,
    pub rel: f64,
}

impl Tol {
    pub fn abs(abs: f64) -> Self {
        Self { abs, rel: 0.0 }
    }
    pub fn rel(rel: f64) -> Self {
        Self { abs: 0.0, rel }
    }
    #[track_caller]
    pub fn check(&self, what: &str, index: usize, s: f64, got: f64, want: f64) {
        let bound = self.abs + self.rel * want.abs();
        assert!(
            (got - want).abs() <= bound && got.is_finite(),
            "{what}[{index}] at s = {s}: got {got:e}, want {want:e}, |diff| = {:e} > {bound:e}",
            (got - want).abs()
        );
    }
    #[track_caller]
    pub fn check3(&self, what: &str, s: f64, got: &nalgebra::Vector3<f64>, want: &nalgebra::Vector3<f64>) {
        for i in 0..3 {
            self.check(what, i, s, got[i], want[i]);
        }
    }
}

pub fn nitinol() -> Material {
    Material { youngs_modulus_pa: 62.7e9, poisson_ratio: 0.3, density_kg_m3: 6800.0 }
}

pub fn section(length: f64, diameter: f64) -> SectionSpec {
    SectionSpec {
        length_m: length,
        shape: CrossSection::Solid { diameter_m: diameter },
        material: nitinol(),
        shear_coefficient: 1.0,
        precurvature_per_m: [0.0; 3],
        guides: None,
    }
}

pub fn guides(count: usize, first: f64, spacing: f64) -> GuideSpec {
    GuideSpec {
        count,
        first_offset_m: first,
        spacing_m: spacing,
        thickness_m: 3e-3,
        diameter_m: 0.03,
        mass_kg: 2.2e-3,
        holes: HolesSpec { radius_m: 0.01, angles_deg: vec![90.0, 210.0, 330.0] },
    }
}

/// One plain rod along world +z.
pub fn plain_rod(length: f64, diameter: f64) -> Robot {
    Robot::new(RobotSpec { base: Default::default(), sections: vec![section(length, diameter)], cables: vec![] }).unwrap()
}

/// Single section, five guides, three cables ending on the last disk.
pub fn five_guide_robot() -> Robot {
    let mut s = section(0.39, 1.56e-3);
    s.guides = Some(guides(5, 0.0054, 0.095));
    Robot::new(RobotSpec {
        base: Default::default(),
        sections: vec![s],
        cables: (0..3).map(|h| CableSpec { name: None, hole: h, end_section: 0 }).collect(),
    })
    .unwrap()
}

/// Two sections with four guides each; cables 0-2 end on section 0, 3-5 on section 1.
pub fn two_section_robot() -> Robot {
    let mut a = section(0.2, 1.56e-3);
    a.guides = Some(guides(4, 0.05, 0.05));
    let mut b = section(0.2, 1.2e-3);
    b.guides = Some(guides(4, 0.05, 0.05));
    let mut cables: Vec<CableSpec> = (0..3).map(|h| CableSpec { name: None, hole: h, end_section: 0 }).collect();
    cables.extend((0..3).map(|h| CableSpec { name: None, hole: h, end_section: 1 }));
    Robot::new(RobotSpec { base: Default::default(), sections: vec![a, b], cables }).unwrap()
}
