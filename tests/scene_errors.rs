//! Bad scene files fail loudly: the error's Display text names the offending field
//! (a dotted path such as `robot.sections[0].length_m`'s `sections[0].length_m`) and
//! the rejected value (STYLE.md, "Settings, errors, status"). TOML and JSON.

use cablesense::{Scene, SolveStatus};
use serde_json::{json, Value};

/// A small valid scene: one section, three guides, one tensioned cable.
const BASE: &str = r#"
description = "scene-error tests"

[[robot.sections]]
length_m = 0.2
shape = { solid = { diameter_m = 1.56e-3 } }
youngs_modulus_pa = 62.7e9
poisson_ratio = 0.3
density_kg_m3 = 6800.0

[robot.sections.guides]
count = 3
first_offset_m = 0.05
spacing_m = 0.05
thickness_m = 3e-3
diameter_m = 0.028
mass_kg = 2.2e-3
holes = { radius_m = 0.01, angles_deg = [90.0, 210.0, 330.0] }

[[robot.cables]]
hole = 0
end_section = 0

[loads]
tensions_n = [1.0]
"#;

/// Parse and validate (what `Scene::load` does); the error's Display text.
fn toml_error(text: &str) -> String {
    match Scene::from_toml_str(text) {
        Err(e) => e.to_string(),
        Ok(scene) => match scene.validate() {
            Err(e) => e.to_string(),
            Ok(()) => panic!("scene accepted:\n{text}"),
        },
    }
}

fn json_error(value: &Value) -> String {
    let text = serde_json::to_string_pretty(value).unwrap();
    match Scene::from_json_str(&text) {
        Err(e) => e.to_string(),
        Ok(scene) => match scene.validate() {
            Err(e) => e.to_string(),
            Ok(()) => panic!("scene accepted:\n{text}"),
        },
    }
}

/// `BASE` with one TOML line replaced (the line must exist exactly once).
fn toml_with(old: &str, new: &str) -> String {
    assert_eq!(
        BASE.matches(old).count(),
        1,
        "`{old}` must occur once in BASE"
    );
    BASE.replace(old, new)
}

/// `BASE` as a JSON value (via the parsed scene, so the two formats describe the same scene).
fn base_json() -> Value {
    serde_json::to_value(Scene::from_toml_str(BASE).unwrap()).unwrap()
}

#[track_caller]
fn assert_mentions(message: &str, parts: &[&str]) {
    for p in parts {
        assert!(
            message.contains(p),
            "error message does not mention `{p}`:\n{message}"
        );
    }
}

#[test]
fn base_scene_is_valid_in_both_formats() {
    Scene::from_toml_str(BASE).unwrap().validate().unwrap();
    let text = serde_json::to_string(&base_json()).unwrap();
    Scene::from_json_str(&text).unwrap().validate().unwrap();
}

/// A misspelt key is rejected by `deny_unknown_fields`, and the message names it: in a
/// guide table, in the loads, at the top level and (optional key) in a section.
#[test]
fn unknown_key_names_the_key() {
    for (old, new, typo) in [
        ("mass_kg = 2.2e-3", "mass_gk = 2.2e-3", "mass_gk"),
        ("tensions_n = [1.0]", "tension_n = [1.0]", "tension_n"),
        ("description =", "descripton =", "descripton"),
        (
            "poisson_ratio = 0.3",
            "poisson_ratio = 0.3\nshear_coeficient = 1.0",
            "shear_coeficient",
        ),
    ] {
        assert_mentions(&toml_error(&toml_with(old, new)), &[typo]);
    }
    let mut v = base_json();
    let g = v["robot"]["sections"][0]["guides"].as_object_mut().unwrap();
    let m = g.remove("mass_kg").unwrap();
    g.insert("mass_gk".into(), m);
    assert_mentions(&json_error(&v), &["mass_gk"]);
    let mut v = base_json();
    v["robot"]["sections"][0]["shear_coeficient"] = json!(1.0);
    assert_mentions(&json_error(&v), &["shear_coeficient"]);
}

/// A misspelt *required* key of a section (`lenght_m` for `length_m`) should be named
/// like any other unknown key.
#[test]
fn misspelt_required_section_key_names_the_typo() {
    let msg = toml_error(&toml_with("length_m = 0.2", "lenght_m = 0.2"));
    assert_mentions(&msg, &["lenght_m"]);
    let mut v = base_json();
    let sec = v["robot"]["sections"][0].as_object_mut().unwrap();
    let len = sec.remove("length_m").unwrap();
    sec.insert("lenght_m".into(), len);
    assert_mentions(&json_error(&v), &["lenght_m"]);
}

/// What a misspelt required section key does give today: a schema error naming the
/// missing key and the line of its table, so the typo still fails loudly.
#[test]
fn misspelt_required_section_key_fails_naming_the_missing_key() {
    let msg = toml_error(&toml_with("length_m = 0.2", "lenght_m = 0.2"));
    assert_mentions(&msg, &["length_m", "line"]);
    let mut v = base_json();
    let sec = v["robot"]["sections"][0].as_object_mut().unwrap();
    let len = sec.remove("length_m").unwrap();
    sec.insert("lenght_m".into(), len);
    assert_mentions(&json_error(&v), &["length_m", "line"]);
}

/// A misspelt key in the flattened material fields of a section (`#[serde(flatten)]`
/// on `SectionSpec::material`) is rejected too and named.
#[test]
fn unknown_key_next_to_flattened_material_names_the_key() {
    let msg = toml_error(&toml_with(
        "poisson_ratio = 0.3",
        "poisson_ratio = 0.3\npoison_ratio = 0.3",
    ));
    assert_mentions(&msg, &["poison_ratio"]);
    let mut v = base_json();
    v["robot"]["sections"][0]["poison_ratio"] = json!(0.3);
    assert_mentions(&json_error(&v), &["poison_ratio"]);
}

#[test]
fn negative_length_names_field_and_value() {
    let msg = toml_error(&toml_with("length_m = 0.2", "length_m = -0.2"));
    assert_mentions(&msg, &["sections[0].length_m", "-0.2"]);
    let mut v = base_json();
    v["robot"]["sections"][0]["length_m"] = json!(-0.2);
    assert_mentions(&json_error(&v), &["sections[0].length_m", "-0.2"]);
}

/// NaN is only expressible in TOML (`nan`); JSON has no NaN literal, so the JSON case
/// checks that the parser rejects the non-standard `NaN` token with a position.
#[test]
fn nan_names_field_and_value() {
    let msg = toml_error(&toml_with("length_m = 0.2", "length_m = nan"));
    assert_mentions(&msg, &["sections[0].length_m", "NaN"]);
    let msg = toml_error(&toml_with(
        "youngs_modulus_pa = 62.7e9",
        "youngs_modulus_pa = nan",
    ));
    assert_mentions(&msg, &["sections[0].youngs_modulus_pa", "NaN"]);
    let msg = toml_error(&toml_with("tensions_n = [1.0]", "tensions_n = [nan]"));
    assert_mentions(&msg, &["loads.tensions_n[0]", "NaN"]);
    let text = serde_json::to_string_pretty(&base_json())
        .unwrap()
        .replace("\"length_m\": 0.2", "\"length_m\": NaN");
    assert!(text.contains("NaN"));
    let err = Scene::from_json_str(&text).unwrap_err().to_string();
    assert_mentions(&err, &["line"]);
}

/// A guide that does not fit in its section: `GuideOutsideSection` names the guide
/// (index within its section) and the section. Guides at 0.05 + 0.05 i m, 3 mm thick,
/// on a 0.2 m section: guide 3 is centred on the end and sticks out by 1.5 mm.
#[test]
fn guide_outside_section_names_guide_and_section() {
    let msg = toml_error(&toml_with("count = 3", "count = 4"));
    assert_mentions(&msg, &["guide 3", "section 0", "0.2015"]);
    let mut v = base_json();
    v["robot"]["sections"][0]["guides"]["count"] = json!(4);
    assert_mentions(&json_error(&v), &["guide 3", "section 0"]);
    // a first offset beyond the section
    let msg = toml_error(&toml_with("first_offset_m = 0.05", "first_offset_m = 0.5"));
    assert_mentions(&msg, &["guide 0", "section 0"]);
}

#[test]
fn cable_end_section_out_of_range_names_field_and_value() {
    let msg = toml_error(&toml_with("end_section = 0", "end_section = 3"));
    assert_mentions(&msg, &["cables[0].end_section", "3", "1"]);
    let mut v = base_json();
    v["robot"]["cables"][0]["end_section"] = json!(3);
    assert_mentions(&json_error(&v), &["cables[0].end_section", "3"]);
}

#[test]
fn hole_index_out_of_range_names_field_and_value() {
    let msg = toml_error(&toml_with("hole = 0", "hole = 7"));
    assert_mentions(&msg, &["cables[0].hole", "7"]);
    let mut v = base_json();
    v["robot"]["cables"][0]["hole"] = json!(7);
    assert_mentions(&json_error(&v), &["cables[0].hole", "7"]);
}

#[test]
fn poisson_ratio_out_of_range_names_field_and_value() {
    let msg = toml_error(&toml_with("poisson_ratio = 0.3", "poisson_ratio = 0.6"));
    assert_mentions(&msg, &["sections[0].poisson_ratio", "0.6"]);
    let mut v = base_json();
    v["robot"]["sections"][0]["poisson_ratio"] = json!(0.6);
    assert_mentions(&json_error(&v), &["sections[0].poisson_ratio", "0.6"]);
}

#[test]
fn negative_tension_names_field_and_value() {
    let msg = toml_error(&toml_with("tensions_n = [1.0]", "tensions_n = [-1.0]"));
    assert_mentions(&msg, &["loads.tensions_n[0]", "-1"]);
    let mut v = base_json();
    v["loads"]["tensions_n"] = json!([-1.0]);
    assert_mentions(&json_error(&v), &["loads.tensions_n[0]", "-1"]);
}

#[test]
fn tube_with_inner_not_below_outer_names_field_and_value() {
    for (inner, shown) in [("2e-3", "0.002"), ("3e-3", "0.003")] {
        let msg = toml_error(&toml_with(
            "shape = { solid = { diameter_m = 1.56e-3 } }",
            &format!(
                "shape = {{ tube = {{ outer_diameter_m = 2e-3, inner_diameter_m = {inner} }} }}"
            ),
        ));
        assert_mentions(&msg, &["sections[0].shape.tube.inner_diameter_m", shown]);
    }
    let mut v = base_json();
    v["robot"]["sections"][0]["shape"] =
        json!({ "tube": { "outer_diameter_m": 2e-3, "inner_diameter_m": 2e-3 } });
    assert_mentions(
        &json_error(&v),
        &["sections[0].shape.tube.inner_diameter_m", "0.002"],
    );
}

#[test]
fn empty_sections_are_rejected() {
    let msg = toml_error("[robot]\nsections = []\n");
    assert_mentions(&msg, &["sections", "at least one"]);
    assert_mentions(
        &json_error(&json!({ "robot": { "sections": [] } })),
        &["sections", "at least one"],
    );
}

/// `Scene::load` puts the file path in front of the field and value.
#[test]
fn load_names_the_file_field_and_value() {
    let dir = std::env::temp_dir().join(format!("cablesense-scene-errors-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("bad.toml");
    std::fs::write(&path, toml_with("length_m = 0.2", "length_m = -0.2")).unwrap();
    let msg = Scene::load(&path).unwrap_err().to_string();
    let _ = std::fs::remove_dir_all(&dir);
    assert_mentions(&msg, &["bad.toml", "sections[0].length_m", "-0.2"]);
}

/// The shipped demo scene loads, validates and solves to `Converged`.
#[test]
fn shipped_demo_scene_loads_and_solves() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/data/scenes/demo_two_section.toml"
    );
    let scene = Scene::load(path).unwrap();
    let robot = scene.build_robot().unwrap();
    let sol = cablesense::solve(&robot, &scene.loads, &scene.numerics).unwrap();
    assert_eq!(
        sol.report.status,
        SolveStatus::Converged,
        "{:?}",
        sol.report
    );
    assert_eq!(sol.cables.len(), 6);
    assert!(sol
        .cables
        .iter()
        .all(|c| c.total_m.is_finite() && c.total_m > 0.0));
}

/// Scenes survive a round trip through TOML and JSON unchanged (the shipped demo and
/// the test scene): what is written can be read back exactly.
#[test]
fn scenes_round_trip_through_toml_and_json() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/data/scenes/demo_two_section.toml"
    );
    for scene in [
        Scene::load(path).unwrap(),
        Scene::from_toml_str(BASE).unwrap(),
    ] {
        let toml = scene.to_toml_string();
        assert_eq!(Scene::from_toml_str(&toml).unwrap(), scene, "TOML:\n{toml}");
        let json = serde_json::to_string(&scene).unwrap();
        assert_eq!(Scene::from_json_str(&json).unwrap(), scene, "JSON:\n{json}");
    }
}

/// BASE with 15 thin disks on a 0.1 m section, first offset and spacing as given.
fn fifteen_disks(first: &str, spacing: &str) -> String {
    BASE.replace("length_m = 0.2", "length_m = 0.1")
        .replace("count = 3", "count = 15")
        .replace(
            "first_offset_m = 0.05",
            &format!("first_offset_m = {first}"),
        )
        .replace("spacing_m = 0.05", &format!("spacing_m = {spacing}"))
        .replace("thickness_m = 3e-3", "thickness_m = 0.0")
}

/// Disks evenly spaced to the section's end, written with a rounded spacing: an
/// overshoot within 1e-9 m is accepted (the disk sits on the end), a larger one is
/// refused with enough digits to see it (the issue's `spans s = [0.100000,
/// 0.100000] m` hid 5e-10 m).
#[test]
fn rounded_guide_spacing_within_a_nanometre_is_accepted_and_larger_is_shown() {
    // 15 x 0.0066666667 = 0.1000000005: 5e-10 m past the end
    let text = fifteen_disks("0.0066666667", "0.0066666667");
    let scene = Scene::from_toml_str(&text).unwrap();
    scene.validate().unwrap();
    let robot = scene.build_robot().unwrap();
    let last = robot.guides().last().unwrap().s;
    assert!(last <= 0.1 && last > 0.1 - 1e-9, "last disk at {last}");
    // 15 x 0.006666667 = 0.100000005: 5e-9 m past the end
    let msg = toml_error(&fifteen_disks("0.006666667", "0.006666667"));
    assert_mentions(&msg, &["guide 14", "0.10000000", "tolerance", "\"even\""]);
    assert!(!msg.contains("[0.100000, 0.100000]"), "{msg}");
}

/// `"even"` spaces the disks to the section's end without a rounded decimal, is
/// written back as `"even"`, and spaces them again when the length changes (e.g.
/// a calibrated length).
#[test]
fn even_guide_spacing_reaches_the_sections_end() {
    let scene = Scene::from_toml_str(&fifteen_disks("\"even\"", "\"even\"")).unwrap();
    scene.validate().unwrap();
    let robot = scene.build_robot().unwrap();
    let s: Vec<f64> = robot.guides().iter().map(|g| g.s).collect();
    assert_eq!(s.len(), 15);
    assert!((s[0] - 0.1 / 15.0).abs() < 1e-15, "{s:?}");
    assert!((s[14] - 0.1).abs() < 1e-15, "{s:?}");
    // a numeric first offset with an even spacing: the last disk on the end
    let scene = Scene::from_toml_str(&fifteen_disks("0.02", "\"even\"")).unwrap();
    let g = scene.robot.sections[0].guides.as_ref().unwrap();
    assert!((g.first_offset_m + 14.0 * g.spacing_m - 0.1).abs() < 1e-15);
    // written back as "even"; a patched length spaces the disks again
    let v =
        serde_json::to_value(Scene::from_toml_str(&fifteen_disks("\"even\"", "\"even\"")).unwrap())
            .unwrap();
    assert_eq!(
        v["robot"]["sections"][0]["guides"]["spacing_m"],
        json!("even")
    );
    let path: cablesense::validation::ParamPath = "robot/sections/0/length_m".parse().unwrap();
    let longer = cablesense::validation::set_values(&scene_of(&v), &[path], &[0.12]).unwrap();
    let robot = longer.build_robot().unwrap();
    assert!((robot.guides().last().unwrap().s - 0.12).abs() < 1e-15);
    // any other word is refused
    let msg = match Scene::from_toml_str(&fifteen_disks("\"even\"", "\"equal\"")) {
        Err(e) => e.to_string(),
        Ok(_) => panic!("`equal` accepted"),
    };
    assert_mentions(&msg, &["spacing_m"]);
}

fn scene_of(v: &Value) -> Scene {
    Scene::from_json_str(&serde_json::to_string(v).unwrap()).unwrap()
}
