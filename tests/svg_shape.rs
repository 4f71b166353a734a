//! Shape figures (`cablesense::files::svg`): the SVG of a solved robot parses as XML
//! and has the three orthographic views, each with backbone, disks and cables, equal
//! scales, and sub-pixel (non-integer) coordinates.

use cablesense::files::demo::{DataRef, SOLVE_SCENE};
use cablesense::files::svg::Figure;
use cablesense::{Start, Workspace};
use std::path::Path;

fn demo_svg() -> (String, usize, usize) {
    let scene = DataRef::parse(Path::new(SOLVE_SCENE))
        .unwrap()
        .scene()
        .unwrap();
    let robot = scene.build_robot().unwrap();
    let (guides, cables) = (robot.guides().len(), robot.cables().len());
    let mut ws = Workspace::new(robot, scene.loads.clone(), scene.numerics.clone()).unwrap();
    assert!(ws.solve(Start::Cold).status.is_converged());
    let sol = ws.solution();
    (
        Figure::shape("demo", ws.robot(), &sol).to_svg(),
        guides,
        cables,
    )
}

/// Numbers in a path's `d` attribute.
fn numbers(d: &str) -> Vec<f64> {
    d.split(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-'))
        .filter(|t| !t.is_empty())
        .map(|t| t.parse().unwrap())
        .collect()
}

#[test]
fn three_views_with_backbone_disks_and_cables() {
    let (svg, guides, cables) = demo_svg();
    let doc = roxmltree::Document::parse(&svg).expect("well-formed SVG");
    let views: Vec<_> = doc
        .descendants()
        .filter(|n| n.attribute("class") == Some("view"))
        .collect();
    let ids: Vec<_> = views.iter().filter_map(|v| v.attribute("id")).collect();
    assert_eq!(ids, ["view-xy", "view-xz", "view-yz"]);
    let mut scales = Vec::new();
    for v in &views {
        let paths: Vec<_> = v
            .children()
            .filter(|n| n.has_tag_name("path"))
            .filter_map(|n| n.attribute("d"))
            .collect();
        // a disk outline per guide, a polyline per cable, the backbone
        assert_eq!(paths.len(), guides + cables + 1, "{:?}", v.attribute("id"));
        let backbone = paths.last().unwrap();
        assert!(
            backbone.contains('C'),
            "backbone is a Bezier path: {backbone}"
        );
        let nums = numbers(backbone);
        assert!(nums.len() > 100);
        assert!(
            nums.iter().filter(|x| x.fract() != 0.0).count() > nums.len() / 2,
            "coordinates are rounded to whole pixels: {backbone}"
        );
        // axis labels with units
        let texts: Vec<_> = v.descendants().filter_map(|n| n.text()).collect();
        assert!(texts.iter().any(|t| t.ends_with("(mm)")), "{texts:?}");
        // px per mm from two labelled ticks on the horizontal axis
        let ticks: Vec<(f64, f64)> = v
            .children()
            .filter(|n| n.has_tag_name("text") && n.attribute("text-anchor") == Some("middle"))
            .filter_map(|n| {
                let x: f64 = n.attribute("x")?.parse().ok()?;
                let value: f64 = n.text()?.parse().ok()?;
                Some((x, value))
            })
            .collect();
        assert!(ticks.len() >= 2, "{ticks:?}");
        let (a, b) = (ticks[0], ticks[1]);
        scales.push((b.0 - a.0) / (b.1 - a.1));
    }
    for s in &scales {
        assert!(
            (s - scales[0]).abs() < 1e-6 * scales[0],
            "views differ in scale: {scales:?}"
        );
    }
}
