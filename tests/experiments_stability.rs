//! The `stability` experiment as a library call (src/experiments/stability.rs,
//! stability_estimate.rs, tdcr.rs): map points, outcomes, the region summary and the
//! CSV, on a force direction of the track demo and on the TDCR's readings.

use cablesense::experiments::stability::{
    self, Outcome, PointKind, RegionCell, StabilitySettings, StartKind,
};
use cablesense::experiments::sweep::Direction;
use cablesense::experiments::write;
use cablesense::Scene;

#[test]
fn settings_are_validated() {
    let s = StabilitySettings {
        tick_budget_s: 0.0,
        ..StabilitySettings::default()
    };
    assert!(s
        .validate()
        .unwrap_err()
        .to_string()
        .contains("tick_budget_s"));
    let s = StabilitySettings {
        directions: vec![Direction::Readings],
        ..StabilitySettings::default()
    };
    assert!(s.validate().is_err());
}

/// Lateral tip force on the track demo: 22 forward rows (CC and PCC cold/warm, six rod
/// settings cold/warm/continuation) and 4 estimation methods, 17 magnitudes each (to
/// `P L^2/EI` = 1000); the default rod solve (continuation) stays on the reference
/// branch to the end of the axis, 1000 (docs/where-methods-fail.md), CC never (it
/// ignores gravity), LM to 40.
#[test]
fn lateral_map_of_the_track_demo() {
    let sc = Scene::load("data/scenes/track_demo.toml").unwrap();
    let settings = StabilitySettings {
        directions: vec![Direction::Lateral],
        ..StabilitySettings::default()
    };
    let map = stability::run(&sc, &settings, &mut |_| {}).unwrap();
    assert_eq!(map.directions, vec![Direction::Lateral]);
    assert_eq!(map.points.len(), (22 + 4) * 17);
    let region = stability::region(&map);
    let cell = |method: &str, start: StartKind| {
        region
            .iter()
            .find(|((_, m, s), _)| m == method && *s == start)
            .map(|(_, c)| c[0])
            .unwrap()
    };
    for method in ["cosserat/point/adaptive-1e-8", "kirchhoff/point/rk4-32"] {
        let rod = cell(method, StartKind::Continuation);
        assert_eq!(rod, RegionCell::All(1000.0), "{method}");
    }
    assert_eq!(cell("cc", StartKind::Cold), RegionCell::None);
    let lm = cell("LevenbergMarquardt", StartKind::Cold);
    assert!(
        matches!(lm, RegionCell::UpTo(v) | RegionCell::All(v) if v >= 40.0),
        "{lm:?}"
    );

    let mut csv = Vec::new();
    write::stability_csv(&mut csv, &map.points).unwrap();
    let text = String::from_utf8(csv).unwrap();
    assert_eq!(text.lines().count(), 1 + map.points.len());
    assert!(text.contains("forward,cc,cold,lateral,0,"));
    assert!(text.contains("\nestimate,LevenbergMarquardt,cold,lateral,0,"));
}

/// The two-segment TDCR along its readings (every segment bent by `theta` rad in the
/// constant-curvature kinematics): every setting converges at small bending; CC and
/// PCC (pure kinematics) stay within 5 % of L of the reference tendon solve to
/// 0.5 rad per segment; the rod settings with continuation stay on the reference
/// branch to at least 1 rad per segment.
#[test]
fn tdcr_readings_map() {
    let sc = Scene::load("data/scenes/tdcr_two_segment.toml").unwrap();
    let settings = StabilitySettings {
        directions: vec![],
        estimation: false,
        ..StabilitySettings::default()
    };
    let map = stability::run(&sc, &settings, &mut |_| {}).unwrap();
    assert_eq!(map.directions, vec![Direction::Readings]);
    assert!(map
        .points
        .iter()
        .all(|p| p.kind == PointKind::Forward && p.dir == Direction::Readings));
    for p in map.points.iter().filter(|p| p.magnitude <= 0.25) {
        assert_eq!(p.outcome, Outcome::Ok, "{p:?}");
    }
    let region = stability::region(&map);
    for ((_, m, s), cells) in &region {
        eprintln!("{m} [{}]: {:?}", s.as_str(), cells[0]);
        let need = match (m.as_str(), s) {
            ("cc" | "pcc/none/8", _) => 0.5,
            (_, StartKind::Continuation) => 1.0,
            _ => 0.25,
        };
        assert!(
            matches!(cells[0], RegionCell::UpTo(v) | RegionCell::All(v) if v >= need),
            "{m} [{}]: {:?}",
            s.as_str(),
            cells[0]
        );
    }
}

/// The forward settings of the map drop the curvature rungs on a robot with a
/// helical continuous tendon and keep them on straight continuous tendons (Till's
/// robot) and on a disk-routed robot (the track demo); the full map of Till's robot is `cablesense stability
/// data/scenes/till_tendon_robot.toml` (measured: every rod setting converged in
/// every direction up to the last magnitude mapped, 460 s on a busy machine).
#[test]
fn continuous_routing_maps_the_rod_settings() {
    let till = Scene::load("data/scenes/till_tendon_robot.toml")
        .unwrap()
        .build_robot()
        .unwrap();
    let demo = Scene::load("data/scenes/track_demo.toml")
        .unwrap()
        .build_robot()
        .unwrap();
    assert_eq!(stability::forward_settings(&till).len(), 8);
    let text = std::fs::read_to_string("data/scenes/till_tendon_robot.toml")
        .unwrap()
        .replacen(
            "path = { straight = { radius_m = 0.01506, angle_deg = 0.0 } }",
            "path = { helical = { radius_m = 0.01506, start_angle_deg = 0.0, pitch_m_per_turn = 0.5 } }",
            1,
        );
    let helical = Scene::from_toml_str(&text).unwrap().build_robot().unwrap();
    let on_helical = stability::forward_settings(&helical);
    assert_eq!(on_helical.len(), 6);
    assert!(on_helical
        .iter()
        .all(|r| matches!(r, cablesense::ladder::Rung::Rod(_))));
    assert_eq!(stability::forward_settings(&demo).len(), 8);
}
