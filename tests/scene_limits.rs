//! `[robot.limits]`: the shipped ranges resolve to metres through `[readings] scale_m`,
//! and every bad range or name is an error naming its field.

use cablesense::Scene;

const FTDCR: &str = include_str!("../data/calibration/ftdcr_v4_calibrated.toml");
const DARU: &str = include_str!("../data/calibration/daru_calibrated.toml");
const SHIPPED_FTDCR_LIMITS: &str = "sections = [[-10.5, 5.5], [-10.5, 9.0], [-10.5, 13.0]]";

fn scene(text: &str) -> Scene {
    let s = Scene::from_toml_str(text).expect("parses");
    s.validate().expect("valid");
    s
}

/// The FTDCR scene with its limits line replaced; the validation error's text.
fn error_with(limits: &str) -> String {
    assert!(FTDCR.contains(SHIPPED_FTDCR_LIMITS));
    let text = FTDCR.replace(SHIPPED_FTDCR_LIMITS, limits);
    match Scene::from_toml_str(&text) {
        Err(e) => e.to_string(),
        Ok(s) => match (s.validate(), s.actuator_limits()) {
            (Err(e), _) | (Ok(()), Err(e)) => e.to_string(),
            (Ok(()), Ok(_)) => panic!("accepted: {limits}"),
        },
    }
}

#[test]
fn shipped_limits_resolve_to_metres() {
    let ft = scene(FTDCR).actuator_limits().unwrap();
    assert_eq!(ft.len(), 9);
    // cables t0..t2 end on section 0, t3..t5 on 1, t6..t8 on 2; mm -> m
    for i in 0..9 {
        assert!((ft.min_m[i] + 0.0105).abs() < 1e-15, "{i}: {}", ft.min_m[i]);
    }
    let hi = [
        0.0055, 0.0055, 0.0055, 0.009, 0.009, 0.009, 0.013, 0.013, 0.013,
    ];
    for (i, h) in hi.iter().enumerate() {
        assert!((ft.max_m[i] - h).abs() < 1e-15, "{i}: {}", ft.max_m[i]);
    }
    let da = scene(DARU).actuator_limits().unwrap();
    assert_eq!(da.min_m, vec![0.0; 3]);
    for h in &da.max_m {
        assert!((h - 0.01).abs() < 1e-15, "100 units of 1e-4 m: {h}");
    }
    // the shipped scene files too
    for f in ["data/scenes/ftdcr_v4.toml", "data/scenes/daru.toml"] {
        let s = Scene::load(f).unwrap();
        assert!(s.actuator_limits().unwrap().is_bounded(), "{f}");
    }
}

#[test]
fn per_tendon_entry_overrides_its_segment_and_default() {
    let text = FTDCR.replace(
        SHIPPED_FTDCR_LIMITS,
        "default = [-1.0, 1.0]\nsections = [[-10.5, 5.5], [-10.5, 9.0], [-10.5, 13.0]]\ntendons = { servo_7_mm = [-2.0, 3.0] }",
    );
    let l = scene(&text).actuator_limits().unwrap();
    assert_eq!(l.max_m[8], 0.003);
    assert_eq!(l.min_m[8], -0.002);
    assert!((l.max_m[7] - 0.013).abs() < 1e-15);
    let only_default = FTDCR.replace(SHIPPED_FTDCR_LIMITS, "default = [-1.0, 2.0]");
    let l = scene(&only_default).actuator_limits().unwrap();
    assert!(l.max_m.iter().all(|v| *v == 0.002));
    // without the table: unbounded
    let none = FTDCR
        .replace("[robot.limits]", "")
        .replace(SHIPPED_FTDCR_LIMITS, "");
    let l = scene(&none).actuator_limits().unwrap();
    assert!(!l.is_bounded());
}

#[test]
fn bad_limits_name_their_field() {
    let cases = [
        (
            "tendons = { servo_99_mm = [0.0, 1.0] }",
            "robot.limits.tendons.servo_99_mm",
        ),
        (
            "tendons = { servo_1_mm = [2.0, 1.0] }",
            "robot.limits.tendons.servo_1_mm",
        ),
        (
            "tendons = { servo_1_mm = [nan, 1.0] }",
            "robot.limits.tendons.servo_1_mm[0]",
        ),
        (
            "tendons = { servo_1_mm = [-1.0, inf] }",
            "robot.limits.tendons.servo_1_mm[1]",
        ),
        ("default = [1.0, 2.0]", "excludes reading 0"),
        ("default = [-2.0, -1.0]", "robot.limits.default"),
        ("sections = [[-1.0, 1.0]]", "1 ranges for 3 sections"),
        (
            "sections = [[-1.0, 1.0], [-1.0, 1.0], [3.0, 1.0]]",
            "robot.limits.sections[2]",
        ),
        ("speed = 3", "unknown field `speed`"),
    ];
    for (limits, needle) in cases {
        let e = error_with(limits);
        assert!(e.contains(needle), "{limits}: {e}");
    }
    assert!(error_with("tendons = { servo_99_mm = [0.0, 1.0] }").contains("servo_4_mm"));
}
