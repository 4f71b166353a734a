//! Rod layer: material and cross-section of one backbone section, and the
//! stiffness matrices of the Cosserat constitutive law.
//!
//! Thesis eq. 2.9: `n = R D (v - v*)`, `D = diag(GA, GA, EA)`;
//! thesis eq. 2.12: `m = R C (u - u*)`, `C = diag(EI, EI, GJ)`.
//! Shear modulus `G = E / (2 (1 + nu))`. The thesis (section 4.4.1) prints
//! `G = E(1 + nu)`: a typo, the isotropic relation is used here.

use crate::error::ModelError;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Cross-section of the backbone.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum CrossSection {
    /// Solid circular rod.
    Solid {
        /// Diameter (m).
        diameter_m: f64,
    },
    /// Circular tube.
    Tube {
        /// Outer diameter (m).
        outer_diameter_m: f64,
        /// Inner diameter (m), `< outer_diameter_m`.
        inner_diameter_m: f64,
    },
}

impl CrossSection {
    /// Area `A` (m^2).
    pub fn area(&self) -> f64 {
        match *self {
            Self::Solid { diameter_m: d } => PI * d * d / 4.0,
            Self::Tube {
                outer_diameter_m: o,
                inner_diameter_m: i,
            } => PI * (o * o - i * i) / 4.0,
        }
    }
    /// Second moment of area `I = pi d^4 / 64` (m^4), about either bending axis.
    pub fn second_moment(&self) -> f64 {
        match *self {
            Self::Solid { diameter_m: d } => PI * d.powi(4) / 64.0,
            Self::Tube {
                outer_diameter_m: o,
                inner_diameter_m: i,
            } => PI * (o.powi(4) - i.powi(4)) / 64.0,
        }
    }
    /// Polar moment `J = 2 I` (m^4) for circular sections.
    pub fn polar_moment(&self) -> f64 {
        2.0 * self.second_moment()
    }
    /// Validate the dimensions; `field` is the path used in errors.
    pub fn validate(&self, field: &str) -> Result<(), ModelError> {
        match *self {
            Self::Solid { diameter_m } => {
                ModelError::positive(format!("{field}.solid.diameter_m"), diameter_m)?;
            }
            Self::Tube {
                outer_diameter_m,
                inner_diameter_m,
            } => {
                ModelError::positive(format!("{field}.tube.outer_diameter_m"), outer_diameter_m)?;
                ModelError::non_negative(
                    format!("{field}.tube.inner_diameter_m"),
                    inner_diameter_m,
                )?;
                if inner_diameter_m >= outer_diameter_m {
                    return Err(ModelError::OutOfRange {
                        field: format!("{field}.tube.inner_diameter_m"),
                        value: inner_diameter_m,
                        why: format!(
                            "must be < outer_diameter_m = {}",
                            crate::error::Num(outer_diameter_m)
                        ),
                    });
                }
            }
        }
        Ok(())
    }
}

/// Linear-elastic isotropic material.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Material {
    /// Young's modulus `E` (Pa). Nitinol: 45-75 GPa (thesis 4.4.1).
    pub youngs_modulus_pa: f64,
    /// Poisson's ratio `nu` (-), in (-1, 0.5). Thesis: 0.3.
    pub poisson_ratio: f64,
    /// Density `rho` (kg/m^3). Thesis 4.4.1 prints "6.8 g/mm^3": a typo for g/cm^3 = 6800 kg/m^3.
    pub density_kg_m3: f64,
}

impl Material {
    /// Shear modulus `G = E / (2 (1 + nu))` (Pa).
    pub fn shear_modulus(&self) -> f64 {
        self.youngs_modulus_pa / (2.0 * (1.0 + self.poisson_ratio))
    }
    /// Validate; `field` is the path used in errors.
    pub fn validate(&self, field: &str) -> Result<(), ModelError> {
        ModelError::positive(format!("{field}.youngs_modulus_pa"), self.youngs_modulus_pa)?;
        ModelError::non_negative(format!("{field}.density_kg_m3"), self.density_kg_m3)?;
        let nu = ModelError::finite(format!("{field}.poisson_ratio"), self.poisson_ratio)?;
        if !(nu > -1.0 && nu < 0.5) {
            return Err(ModelError::OutOfRange {
                field: format!("{field}.poisson_ratio"),
                value: nu,
                why: "an isotropic solid needs -1 < nu < 0.5".into(),
            });
        }
        Ok(())
    }
}

/// Diagonal stiffnesses of one section, the quantities the ODE actually uses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stiffness {
    /// `C = diag(EI, EI, GJ)` (N m^2), thesis eq. 2.12.
    pub bend_twist: Vector3<f64>,
    /// `D = diag(k GA, k GA, EA)` (N), thesis eq. 2.9 with shear coefficient `k`
    /// (the thesis uses k = 1).
    pub shear_stretch: Vector3<f64>,
    /// Mass per unit reference length of the bare rod, `rho A` (kg/m).
    pub linear_density: f64,
}

impl Stiffness {
    /// Stiffness of a section of `material` and `shape` with Timoshenko shear coefficient `k`.
    pub fn new(material: &Material, shape: &CrossSection, shear_coefficient: f64) -> Self {
        let e = material.youngs_modulus_pa;
        let g = material.shear_modulus();
        let (a, i, j) = (shape.area(), shape.second_moment(), shape.polar_moment());
        Self {
            bend_twist: Vector3::new(e * i, e * i, g * j),
            shear_stretch: Vector3::new(
                shear_coefficient * g * a,
                shear_coefficient * g * a,
                e * a,
            ),
            linear_density: material.density_kg_m3 * a,
        }
    }
}
