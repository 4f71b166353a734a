//! The plot stack (`cablesense::files::svg`). Shape figures: the SVG of a solved robot
//! parses as XML and has the three orthographic views, each with backbone, disks and
//! cables, equal scales, and sub-pixel (non-integer) coordinates. Charts: known points
//! land on their pixels on linear, log and equal axes; tick rules; a chart has its
//! series and labels and no NaN.

use cablesense::files::demo::{DataRef, SOLVE_SCENE};
use cablesense::files::svg::{straight_path, tick_label, ticks, Axis, Doc, Figure, Panel, Swatch};
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

/// A known point lands on the pixel it should, on linear and log axes.
#[test]
fn data_maps_to_pixels() {
    let p = Panel::new(
        [100.0, 50.0, 400.0, 200.0],
        Axis::linear(0.0, 10.0),
        Axis::log(1e-6, 1e-2),
    );
    assert!((p.px(2.5) - 200.0).abs() < 1e-9);
    assert!((p.py(1e-4) - 150.0).abs() < 1e-9);
    assert!((p.py(1e-2) - 50.0).abs() < 1e-9);
    let e = Panel::equal([0.0, 0.0, 200.0, 100.0], (0.0, 0.0), (1.0, 1.0));
    let (ux, uy) = (e.px(1.0) - e.px(0.0), e.py(0.0) - e.py(1.0));
    assert!((ux - uy).abs() < 1e-9, "{ux} {uy}");
}

#[test]
fn log_ticks_are_decades_with_labels() {
    let t = Axis::log(3e-9, 2e-3).ticks();
    let v: Vec<&str> = t.iter().map(|(_, s)| s.as_str()).collect();
    assert_eq!(v, ["1e-8", "1e-7", "1e-6", "1e-5", "1e-4", "0.001"]);
    let t = Axis::log(15.0, 60.0).ticks();
    let v: Vec<&str> = t.iter().map(|(_, s)| s.as_str()).collect();
    assert_eq!(v, ["20", "50"]);
    assert_eq!(Axis::log(1e-15, 1e1).ticks().len(), 8);
}

/// A chart parses as XML, has one group per dot series, its labels, and no NaN
/// even when the data hold one.
#[test]
fn chart_svg_has_its_series_and_no_nan() {
    let mut doc = Doc::new(600.0, 400.0, 12.0);
    let p = Panel::new(
        [60.0, 40.0, 500.0, 300.0],
        Axis::log(1.0, 1e3),
        Axis::linear(0.0, 2.0),
    );
    p.frame(&mut doc, "t & c", "time (us)", "error (mm)");
    p.dots(
        &mut doc,
        &[(10.0, 1.0), (f64::NAN, 1.0)],
        3.0,
        r#"fill="red""#,
    );
    p.dots(&mut doc, &[(100.0, 0.5)], 3.0, r#"fill="blue""#);
    p.polyline(
        &mut doc,
        &[(1.0, 0.0), (-1.0, 1.0), (1e3, 2.0)],
        "stroke=\"k\"",
    );
    p.legend(
        &mut doc,
        &[(Swatch::Dot, "red", "a"), (Swatch::Line, "k", "b")],
        true,
    );
    let svg = doc.finish();
    assert!(!svg.contains("NaN") && !svg.contains("inf"), "{svg}");
    let xml = roxmltree::Document::parse(&svg).expect("well-formed");
    let groups = xml.descendants().filter(|n| n.has_tag_name("g")).count();
    assert_eq!(groups, 2);
    let texts: Vec<&str> = xml.descendants().filter_map(|n| n.text()).collect();
    for t in ["t & c", "time (us)", "error (mm)", "100", "a", "b"] {
        assert!(texts.contains(&t), "{t}: {texts:?}");
    }
    let c = xml
        .descendants()
        .find(|n| n.has_tag_name("circle"))
        .unwrap();
    assert_eq!(c.attribute("cx"), Some("226.67"));
    assert_eq!(c.attribute("cy"), Some("190.00"));
}

#[test]
fn linear_ticks_and_paths() {
    assert_eq!(ticks(-0.05, 0.61, 0.2), [0.0, 0.2, 0.4, 0.6000000000000001]);
    assert_eq!(tick_label(0.6000000000000001, 0.2), "0.6");
    assert_eq!(tick_label(-40.0, 20.0), "-40");
    assert_eq!(tick_label(2e-4, 1e-4), "2.0e-4");
    assert!(ticks(0.0, f64::NAN, 1.0).is_empty());
    let d = straight_path(&[(0.0, 1.0), (2.5, 3.0), (f64::NAN, 0.0), (4.0, 5.0)]);
    assert_eq!(d, "M0.00,1.00 L2.50,3.00 M4.00,5.00");
}
