//! Displacement actuation of the curvature rungs (src/ladder/kinematics.rs): CC with
//! displacement control is the classic constant-curvature kinematics of Webster &
//! Jones 2010 (IJRR 29(13), section 3.1.1): `Delta l_i = -r theta cos(phi - sigma_i)`
//! per segment, the tip of an arc at `(L/theta) ((1 - cos theta) cos phi, (1 - cos
//! theta) sin phi, sin theta)` (their eq. 5 with the base along `+z`).
//!
//! Checked: the closed form (1e-12), the least-squares and slack rules, and the
//! agreement with the Cosserat tendon solve (`tendons::TendonWorkspace`) on stiff,
//! gravity-free robots, with the tolerances and measured numbers stated per test.

use cablesense::ladder::{
    CcSettings, ConstantCurvature, ForwardModel, PccSettings, PiecewiseConstantCurvature,
};
use cablesense::nalgebra::Vector3;
use cablesense::statics::ParamSite;
use cablesense::tendons::TendonWorkspace;
use cablesense::{Loads, PointLoad, Robot, Scene};

const R: f64 = 0.005;
const L: f64 = 0.2;

/// `sections` sections of `L / sections` with 10 disks each, three tendons per
/// section at radius `R` (angles 0, 120, 240, rotated by 60 on odd sections) ending on
/// it; Cosserat, no gravity, no disk mass, inextensible tendons with 1 N pretension.
fn scene(sections: usize) -> Scene {
    let ls = L / sections as f64;
    let mut text = String::new();
    for _ in 0..sections {
        text += &format!(
            r#"
[[robot.sections]]
length_m = {ls}
shape = {{ solid = {{ diameter_m = 1.0e-3 }} }}
youngs_modulus_pa = 50.0e9
poisson_ratio = 0.3
density_kg_m3 = 6450.0
[robot.sections.guides]
count = 10
first_offset_m = {h}
spacing_m = {h}
thickness_m = 0.0
diameter_m = 0.014
mass_kg = 0.0
holes = {{ radius_m = {R} }}
"#,
            h = ls / 10.0
        );
    }
    text += "[robot.tendons]\nstiffness_n = inf\npretension_n = 1.0\n";
    for k in 0..sections {
        for a in [0.0, 120.0, 240.0] {
            text += &format!(
                "[[robot.cables]]\nrouting = {{ radius_m = {R}, angle_deg = {} }}\nend_section = {k}\nactuation = \"displacement\"\n",
                a + 60.0 * (k % 2) as f64
            );
        }
    }
    text += r#"
[loads]
gravity_m_s2 = [0.0, 0.0, 0.0]
[numerics]
rod_model = "cosserat"
guide_mass = "none"
integrator = { rk4 = { steps_per_section = 40 } }
tolerance = 1e-12
"#;
    Scene::from_toml_str(&text).expect("test scene parses")
}

/// Webster & Jones 2010 eq. 5: tip of one arc from the origin along `+z`.
fn arc_tip(theta: f64, phi: f64, l: f64) -> Vector3<f64> {
    if theta.abs() < 1e-12 {
        return Vector3::new(0.0, 0.0, l);
    }
    let rho = l / theta;
    Vector3::new(
        rho * (1.0 - theta.cos()) * phi.cos(),
        rho * (1.0 - theta.cos()) * phi.sin(),
        rho * theta.sin(),
    )
}

/// Readings of one arc `(theta, phi)` on tendons at `sigmas` (deg): `q = r theta cos(phi - sigma)`.
fn readings(theta: f64, phi: f64, sigmas: &[f64]) -> Vec<f64> {
    sigmas
        .iter()
        .map(|s| R * theta * (phi - s.to_radians()).cos())
        .collect()
}

fn cc(robot: &Robot) -> ConstantCurvature {
    ConstantCurvature::new(robot.clone(), CcSettings::default()).unwrap()
}

#[test]
fn cc_from_readings_is_the_closed_form_arc() {
    let robot = scene(1).build_robot().unwrap();
    let mut m = cc(&robot);
    for (theta, phi) in [(0.0, 0.0), (0.3, 0.4), (1.2, -2.0), (2.5, 3.0)] {
        let q = readings(theta, phi, &[0.0, 120.0, 240.0]);
        assert!(m.solve_readings(&q).unwrap().status.is_converged());
        let k = m.kinematics().unwrap();
        let (th, ph) = k.angles(0);
        assert!((th - theta).abs() < 1e-12, "theta {th} vs {theta}");
        if theta > 0.0 {
            assert!((ph - phi).abs() < 1e-12, "phi {ph} vs {phi}");
        }
        assert!((k.kappa(0) - theta / L).abs() < 1e-10);
        let tip = m.tip_position();
        assert!(
            (tip - arc_tip(theta, phi, L)).norm() < 1e-12,
            "tip {tip} vs {}",
            arc_tip(theta, phi, L)
        );
        // the arc gives every tendon its reading back as its path change
        for (i, qi) in q.iter().enumerate() {
            assert!((k.path_change(i) + qi).abs() < 1e-15);
        }
    }
}

/// Least squares over three tendons: a common-mode offset (what axial strain takes up)
/// changes nothing; antagonistic readings with the released tendons paid out further
/// than the bend needs leave only the pulled one taut, which alone bends the section by
/// `theta = q / r` towards itself; paid-out-only readings leave the rod straight.
#[test]
fn least_squares_and_slack_rule() {
    let robot = scene(1).build_robot().unwrap();
    let mut m = cc(&robot);
    let q = readings(0.7, 1.0, &[0.0, 120.0, 240.0]);
    let shifted: Vec<f64> = q.iter().map(|x| x + 3e-4).collect();
    m.solve_readings(&shifted).unwrap();
    let (th, ph) = m.kinematics().unwrap().angles(0);
    assert!(
        (th - 0.7).abs() < 1e-12 && (ph - 1.0).abs() < 1e-12,
        "{th} {ph}"
    );
    assert_eq!(m.kinematics().unwrap().taut(), &[true, true, true]);

    let q = [2e-3, -2e-3, -1.5e-3];
    m.solve_readings(&q).unwrap();
    let k = m.kinematics().unwrap();
    assert_eq!(k.taut(), &[true, false, false]);
    let (th, ph) = k.angles(0);
    assert!(
        (th - 2e-3 / R).abs() < 1e-12 && ph.abs() < 1e-12,
        "{th} {ph}"
    );
    // the slack tendons' paths are indeed shorter than their free lengths
    assert!(-k.path_change(1) > q[1] && -k.path_change(2) > q[2]);

    m.solve_readings(&[-1e-3, -1e-3, -2e-3]).unwrap();
    assert_eq!(m.kinematics().unwrap().angles(0).0, 0.0);
    assert!((m.tip_position() - Vector3::new(0.0, 0.0, L)).norm() < 1e-15);

    // bad input is an error naming the reading, never a panic
    let e = m.solve_readings(&[0.0, f64::NAN, 0.0]).unwrap_err();
    assert!(e.to_string().contains("readings[1]"), "{e}");
    assert!(m.solve_readings(&[0.0]).is_err());
}

/// Tip distance of CC from the Cosserat tendon solve for consistent readings of an arc
/// `theta` (bending in the plane of tendon 0), and the tip deflection.
fn cc_vs_cosserat(ws: &mut TendonWorkspace, m: &mut ConstantCurvature, theta: f64) -> (f64, f64) {
    let q = readings(theta, 0.0, &[0.0, 120.0, 240.0]);
    let rep = ws.solve_readings(&q).unwrap();
    assert!(rep.status.is_converged(), "{rep:?}");
    m.solve_readings(&q).unwrap();
    let err = (m.tip_position() - ws.tip_position()).norm();
    let defl = (ws.tip_position() - Vector3::new(0.0, 0.0, L)).norm();
    (err, defl)
}

/// Against the Cosserat tendon solve (inextensible tendons, 1 N pretension, no
/// gravity, 10 disks). At zero bending the only difference is the rod's axial
/// compression by the three pretensions, `3 T0 L / EA` = 15 um, which the kinematics
/// ignores (within 5 %). The CC tip agrees within 0.5 % of the tip deflection for
/// bending up to 0.4 rad (measured: 15 um = 0.30 % at 0.05 rad, 14 um = 0.14 % at 0.1,
/// 12 um = 0.06 % at 0.2, 57 um = 0.14 % at 0.4: mostly that compression), and the
/// error grows with the bending beyond (measured 0.90 mm = 1.2 % at 0.8 rad, 3.8 mm =
/// 2.6 % at 1.6 rad: the chords between disks, the rod's strain under the growing
/// tensions, and the antagonists' pretension, none of which the kinematics sees).
#[test]
fn cc_agrees_with_the_cosserat_tendon_solve_for_small_bending() {
    let sc = scene(1);
    let robot = sc.build_robot().unwrap();
    let mut ws = sc.tendon_workspace().unwrap();
    let mut m = cc(&robot);
    let ea = robot.sections()[0].stiffness.shear_stretch.z;
    let (e0, _) = cc_vs_cosserat(&mut ws, &mut m, 0.0);
    let axial = 3.0 * 1.0 * L / ea;
    assert!((e0 - axial).abs() < 0.05 * axial, "{e0} vs {axial}");
    let mut errs = Vec::new();
    for theta in [0.05, 0.1, 0.2, 0.4, 0.8, 1.6] {
        let (err, defl) = cc_vs_cosserat(&mut ws, &mut m, theta);
        eprintln!(
            "theta {theta}: CC tip error {err:.3e} m, deflection {defl:.3e} m, ratio {:.3e}",
            err / defl
        );
        if theta <= 0.4 {
            assert!(err < 5e-3 * defl, "theta {theta}: {err} vs {defl}");
        }
        errs.push(err);
    }
    assert!(errs[5] > errs[4] && errs[4] > errs[1], "{errs:?}");
}

/// A lateral tip force `P` (along `y`, normal to the bending plane) the kinematics
/// cannot see: the Cosserat tip moves and the CC error grows linearly with `P L^2/EI`
/// (measured at 0.2 rad of bending: 12 um at 0, 4.4 mm at 0.25, 8.7 mm at 0.5, 17.7 mm
/// at 1, i.e. about 0.09 L per unit `P L^2/EI`: the taut tendons fix each section's
/// total bending angle but not how the load redistributes it).
#[test]
fn cc_error_grows_with_an_external_load() {
    let sc = scene(1);
    let robot = sc.build_robot().unwrap();
    let mut loads = Loads::none();
    loads.point.push(PointLoad {
        section: 0,
        ..Default::default()
    });
    let site = ParamSite::Force { point: 0, axis: 1 };
    let mut ws =
        TendonWorkspace::with_params(robot.clone(), loads, sc.numerics.clone(), &[site]).unwrap();
    let mut m = cc(&robot);
    let ei = robot.sections()[0].stiffness.bend_twist.x;
    let mut errs = Vec::new();
    for p in [0.0, 0.25, 0.5, 1.0] {
        ws.set_extra(&[p * ei / (L * L)]);
        let (err, _) = cc_vs_cosserat(&mut ws, &mut m, 0.2);
        eprintln!("P L^2/EI = {p}: CC tip error {err:.3e} m");
        errs.push(err);
    }
    for w in errs.windows(2) {
        assert!(w[1] > w[0], "{errs:?}");
    }
    // linear for small loads: doubling P roughly doubles the error (within 30 %)
    let r = (errs[2] - errs[0]) / (errs[1] - errs[0]);
    assert!((r - 2.0).abs() < 0.6, "{errs:?}");
}

/// Two segments (tendons of segment 2 pass the disks of segment 1): PCC from readings
/// chains the two arcs, segment 2's readings with segment 1's path change subtracted;
/// it equals the chained closed form and CC, and against the Cosserat tendon solve
/// both segment ends agree within 1 % of the deflection for 0.2 and 0.15 rad (measured
/// 14 um of 10 mm at the end of segment 1, 20 um of 33 mm at the tip: again mostly
/// the axial compression by the six pretensions).
#[test]
fn pcc_chains_segments_and_matches_the_cosserat_solve() {
    let sc = scene(2);
    let robot = sc.build_robot().unwrap();
    let (t1, p1, t2, p2) = (0.2, 0.3, 0.15, -1.0);
    let mut q = readings(t1, p1, &[0.0, 120.0, 240.0]);
    // distal tendons (at 60, 180, 300) see both arcs
    let q_prox = readings(t1, p1, &[60.0, 180.0, 300.0]);
    let q_dist = readings(t2, p2, &[60.0, 180.0, 300.0]);
    q.extend(q_prox.iter().zip(&q_dist).map(|(a, b)| a + b));
    let mut pcc = PiecewiseConstantCurvature::new(
        robot.clone(),
        PccSettings {
            pieces_per_section: 8,
            ..PccSettings::default()
        },
    )
    .unwrap();
    assert!(pcc.solve_readings(&q).unwrap().status.is_converged());
    let k = pcc.kinematics().unwrap();
    let ((a1, b1), (a2, b2)) = (k.angles(0), k.angles(1));
    assert!((a1 - t1).abs() < 1e-12 && (b1 - p1).abs() < 1e-12);
    assert!(
        (a2 - t2).abs() < 1e-12 && (b2 - p2).abs() < 1e-12,
        "{a2} {b2}"
    );
    let out = pcc.output();
    let e1 = arc_tip(t1, p1, L / 2.0);
    assert!((out.section_tips[0].position - e1).norm() < 1e-12);
    let mut m = cc(&robot);
    m.solve_readings(&q).unwrap();
    assert!((m.tip_position() - pcc.tip_position()).norm() < 1e-12);

    let mut ws = sc.tendon_workspace().unwrap();
    let rep = ws.solve_readings(&q).unwrap();
    assert!(rep.status.is_converged(), "{rep:?}");
    let sol = ws.workspace_mut().solution();
    for s in 0..2 {
        let err = (out.section_tips[s].position - sol.section_tips[s].position).norm();
        let defl = (sol.section_tips[s].position
            - Vector3::new(0.0, 0.0, L * (s + 1) as f64 / 2.0))
        .norm();
        eprintln!("segment {s}: PCC end error {err:.3e} m, deflection {defl:.3e} m");
        assert!(err < 1e-2 * defl, "segment {s}: {err} vs {defl}");
    }
}
