//! The workspace's files: `cloud.csv` and `hull.obj` (the command's module docs).

use anyhow::Context;
use cablesense::command::workspace::FoldClass;
use cablesense::command::{Hull, WorkspaceCloud};
use std::fmt::Write as _;
use std::path::Path;

/// A solve's status as in files (`stalled`, ...; `None`: readings rejected).
pub(super) fn stop_name(s: Option<cablesense::statics::SolveStatus>) -> String {
    s.and_then(|s| serde_json::to_value(s).ok())
        .and_then(|v| v.as_str().map(str::to_string))
        .unwrap_or_else(|| "readings_rejected".into())
}

/// `cloud.csv`; with `fold` (the fold test ran) two more columns: the test's
/// verdict on a failed sample (empty for a solved one) and its rod passes.
pub(super) fn write_cloud(
    cloud: &WorkspaceCloud,
    scale: f64,
    fold: bool,
    path: &Path,
) -> anyhow::Result<()> {
    let mut s = String::new();
    let markers = !cloud.markers_m.is_empty();
    writeln!(
        s,
        "sample,{},tip_x_m,tip_y_m,tip_z_m,{}last_solve,residual_m,retry_check_m,status,rod_passes{}",
        cloud.columns.join(","),
        if markers {
            "marker_x_m,marker_y_m,marker_z_m,"
        } else {
            ""
        },
        if fold { ",fold_test,fold_test_passes" } else { "" }
    )?;
    for k in 0..cloud.len() {
        let q: Vec<String> = cloud
            .readings(k)
            .iter()
            .map(|v| format!("{}", v / scale))
            .collect();
        let t = cloud.tips_m[k];
        write!(s, "{},{},{},{},{},", k + 1, q.join(","), t.x, t.y, t.z)?;
        if markers {
            let m = cloud.markers_m[k];
            write!(s, "{},{},{},", m.x, m.y, m.z)?;
        }
        write!(
            s,
            "{},{},{},{},{}",
            stop_name(cloud.stop[k]),
            cloud.residual_m[k],
            cloud.retry_check_m[k],
            cloud.status[k].name(),
            cloud.passes[k]
        )?;
        if fold {
            let v = cloud.fold[k].map_or("", FoldClass::name);
            write!(s, ",{v},{}", cloud.fold_passes[k])?;
        }
        writeln!(s)?;
    }
    std::fs::write(path, s).with_context(|| format!("writing {}", path.display()))
}

pub(super) fn write_obj(hull: &Hull, name: &str, path: &Path) -> anyhow::Result<()> {
    let mut s = format!(
        "# convex hull of the reachable tips of {name} (m); volume {:e} m^3\n",
        hull.volume_m3
    );
    for v in &hull.vertices {
        writeln!(s, "v {} {} {}", v.x, v.y, v.z)?;
    }
    for t in &hull.triangles {
        writeln!(s, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1)?;
    }
    std::fs::write(path, s).with_context(|| format!("writing {}", path.display()))
}
