//! Steps 3 and 4 of the identification ([`super::identify`]): the model's response
//! per segment, its fit to each servo's measured tip path, and the assignment of
//! servos to segments and angles, with the proposal as a TOML snippet.

use super::frame::RigidTransform;
use super::identify::{
    linear_response, scene_segments, servo_rows, wrap, IdentifyError, IdentifySettings,
    LinearResponse, PullRecording, SceneSegment, ServoRows,
};
use crate::files::Scene;
use crate::statics::Start;
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

/// What the recording says about one servo.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ServoEvidence {
    /// Servo column.
    pub column: String,
    /// Labels of the patterns pulling it.
    pub labels: Vec<String>,
    /// Evidence rows (others slack).
    pub rows: usize,
    /// Model-free response.
    pub linear: LinearResponse,
    /// Per scene segment (order of [`IdentifyResult::segments`]): RMS of the model's
    /// tip path against the measured one after the best rotation and shift (m).
    pub rms_m: Vec<f64>,
    /// Per segment: the hole angle (deg) the servo's tendon has if on that segment.
    pub angle_deg: Vec<f64>,
    /// Assigned segment (index into [`IdentifyResult::segments`]).
    pub segment: usize,
    /// Assigned scene cable.
    pub cable: usize,
    /// Its angle misfit to the segment's pattern (deg).
    pub angle_misfit_deg: f64,
    /// Next-best segment by RMS and its RMS over the assigned one's (> 1: assigned is
    /// better; near 1: ambiguous).
    pub next_best: Option<(usize, f64)>,
}

/// Proposal for one segment.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SegmentProposal {
    /// Section the segment's tendons end on.
    pub section: usize,
    /// Scene cables of the segment.
    pub cables: Vec<usize>,
    /// Servo (index into [`IdentifyResult::servos`]) per cable.
    pub servos: Vec<usize>,
    /// Proposed hole angle of the segment's first tendon (deg).
    pub first_angle_deg: f64,
    /// The scene's angle of that tendon (deg).
    pub scene_first_angle_deg: f64,
    /// Proposed minus scene (deg, wrapped): the angle offset to apply.
    pub offset_deg: f64,
}

/// Cost increase when two segments' servo groups are exchanged.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SwapMargin {
    /// Segments (indices).
    pub segments: (usize, usize),
    /// Cost of the swapped assignment minus the best (-, in the cost's units).
    pub margin: f64,
}

/// The identification's result.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IdentifyResult {
    /// Recording file.
    pub file: String,
    /// Per servo, recording order.
    pub servos: Vec<ServoEvidence>,
    /// Per segment, base to tip.
    pub segments: Vec<SegmentProposal>,
    /// Total assignment cost (-).
    pub cost: f64,
    /// Per pair of equal-size segments.
    pub swaps: Vec<SwapMargin>,
    /// Proposed reading column per scene cable (`None` for cables not driven).
    pub readings: Vec<Option<String>>,
    /// Proposed hole angle per scene cable (deg).
    pub angles_deg: Vec<Option<f64>>,
}

impl IdentifyResult {
    /// Does the proposed mapping equal the scene's `reading` columns?
    pub fn mapping_matches(&self, scene: &Scene) -> bool {
        scene
            .robot
            .cables
            .iter()
            .zip(&self.readings)
            .all(|(c, r)| r.is_none() || c.reading.as_ref().or(c.name.as_ref()) == r.as_ref())
    }

    /// The scene's `[[robot.cables]]` with the proposed `reading` and routing
    /// `angle_deg` (0.1 deg), as TOML to paste over the scene's cables.
    pub fn toml_snippet(&self, scene: &Scene) -> Result<String, IdentifyError> {
        #[derive(Serialize)]
        struct Robot<'a> {
            cables: &'a [crate::robot::CableSpec],
        }
        #[derive(Serialize)]
        struct Snippet<'a> {
            robot: Robot<'a>,
        }
        let mut cables = scene.robot.cables.clone();
        for (j, c) in cables.iter_mut().enumerate() {
            if let Some(r) = &self.readings[j] {
                c.reading = Some(r.clone());
            }
            if let (Some(a), Some(rt)) = (self.angles_deg[j], c.routing.as_mut()) {
                rt.angle_deg = (a.rem_euclid(360.0) * 10.0).round() / 10.0;
            }
        }
        toml::to_string(&Snippet {
            robot: Robot { cables: &cables },
        })
        .map_err(|e| IdentifyError::Model(format!("writing the snippet: {e}")))
    }
}

/// Model tip paths per segment on a pull grid (base frame, m).
struct Grid {
    q0: f64,
    step: f64,
    tips: Vec<Vec<Vector3<f64>>>,
}

impl Grid {
    fn at(&self, seg: usize, q: f64) -> Vector3<f64> {
        let t = &self.tips[seg];
        let x = ((q - self.q0) / self.step).clamp(0.0, (t.len() - 1) as f64);
        let i = (x.floor() as usize).min(t.len().saturating_sub(2));
        let f = x - i as f64;
        if t.len() == 1 {
            return t[0];
        }
        t[i] * (1.0 - f) + t[i + 1] * f
    }
}

fn model_grid(
    scene: &Scene,
    segs: &[SceneSegment],
    q_range: (f64, f64),
    slack_m: f64,
    offset: &Vector3<f64>,
    step: f64,
) -> Result<Grid, IdentifyError> {
    let mut ws = scene
        .tendon_workspace()
        .map(crate::tendons::TendonWorkspace::without_rollback)
        .map_err(|e| IdentifyError::Model(format!("scene: {e}")))?;
    let driven = ws.driven().to_vec();
    let n = ((q_range.1 - q_range.0) / step).ceil().max(1.0) as usize + 1;
    let mut tips = Vec::new();
    for seg in segs {
        let pos = driven
            .iter()
            .position(|&j| j == seg.cables[0])
            .expect("segments hold driven cables");
        let mut path = Vec::with_capacity(n);
        let mut start = Start::Cold;
        for k in 0..n {
            let mut r = vec![slack_m; driven.len()];
            r[pos] = q_range.0 + k as f64 * step;
            let mut rep = ws
                .solve_readings_from(&r, start)
                .map_err(|e| IdentifyError::Model(format!("pull {:.3} mm: {e}", r[pos] * 1e3)))?;
            if !rep.status.is_converged() {
                rep = ws
                    .solve_readings_from(&r, Start::Cold)
                    .map_err(|e| IdentifyError::Model(e.to_string()))?;
            }
            if !rep.status.is_converged() {
                return Err(IdentifyError::Model(format!(
                    "section {} tendon pulled {:.3} mm: {:?} (residual {:.2e})",
                    seg.section,
                    r[pos] * 1e3,
                    rep.status,
                    rep.residual_m
                )));
            }
            start = Start::Warm;
            let sol = ws.workspace_mut().solution();
            let tip = sol.tip();
            path.push(tip.position + tip.rotation * offset);
        }
        tips.push(path);
    }
    Ok(Grid {
        q0: q_range.0,
        step,
        tips,
    })
}

/// Rotation about `z` and shift taking `p` onto `m`: (angle, RMS residual).
fn procrustes_z(p: &[Vector3<f64>], m: &[Vector3<f64>]) -> (f64, f64) {
    let n = p.len() as f64;
    let pc = p.iter().sum::<Vector3<f64>>() / n;
    let mc = m.iter().sum::<Vector3<f64>>() / n;
    let (mut num, mut den) = (0.0, 0.0);
    for (a, b) in p.iter().zip(m) {
        let (a, b) = (a - pc, b - mc);
        num += a.x * b.y - a.y * b.x;
        den += a.x * b.x + a.y * b.y;
    }
    let phi = num.atan2(den);
    let r = Matrix3::new(
        phi.cos(),
        -phi.sin(),
        0.0,
        phi.sin(),
        phi.cos(),
        0.0,
        0.0,
        0.0,
        1.0,
    );
    let ss: f64 = p
        .iter()
        .zip(m)
        .map(|(a, b)| (r * (a - pc) - (b - mc)).norm_squared())
        .sum();
    (phi, (ss / n).sqrt())
}

fn permutations(k: usize) -> Vec<Vec<usize>> {
    if k == 0 {
        return vec![Vec::new()];
    }
    let mut out = Vec::new();
    for p in permutations(k - 1) {
        for i in 0..=p.len() {
            let mut q = p.clone();
            q.insert(i, k - 1);
            out.push(q);
        }
    }
    out
}

/// Best slot order of `group` (servo indices) on segment `i`: (cost, slot per
/// member, first-tendon angle, misfit per member).
fn group_cost(
    i: usize,
    group: &[usize],
    seg: &SceneSegment,
    rms: &[Vec<f64>],
    theta: &[Vec<f64>],
    s: &IdentifySettings,
) -> (f64, Vec<usize>, f64, Vec<f64>) {
    let pos: f64 = group
        .iter()
        .map(|&v| (rms[v][i] / s.model_error_m).powi(2))
        .sum();
    let sig = s.angle_sigma_deg.to_radians();
    let mut best = (f64::INFINITY, Vec::new(), 0.0, Vec::new());
    for perm in permutations(group.len()) {
        let d: Vec<f64> = group
            .iter()
            .zip(&perm)
            .map(|(&v, &k)| wrap(theta[v][i] - (seg.angles[k] - seg.angles[0])))
            .collect();
        let beta = d
            .iter()
            .map(|x| x.sin())
            .sum::<f64>()
            .atan2(d.iter().map(|x| x.cos()).sum());
        let mis: Vec<f64> = d.iter().map(|x| wrap(x - beta)).collect();
        let c = pos + mis.iter().map(|x| (x / sig).powi(2)).sum::<f64>();
        // equally spaced tendons: cyclic relabelings cost the same (the tip cannot
        // tell which tendon is "first"); keep the one closest to the scene's angles
        let tie = (c - best.0).abs() <= 1e-9 * c.abs().max(1.0)
            && wrap(beta - seg.angles[0]).abs() < wrap(best.2 - seg.angles[0]).abs();
        if c < best.0 - 1e-9 * c.abs().max(1.0) || tie {
            best = (c, perm, beta, mis);
        }
    }
    best
}

/// Identify the mapping of `rec`'s servos onto `scene`'s driven tendons.
pub fn identify_recording(
    scene: &Scene,
    rec: &PullRecording,
    settings: &IdentifySettings,
) -> Result<IdentifyResult, IdentifyError> {
    let segs = scene_segments(scene)?;
    let ntend: usize = segs.iter().map(|s| s.cables.len()).sum();
    let mismatch = |why: String| IdentifyError::Mismatch {
        file: rec.file.clone(),
        why,
    };
    if rec.servos.len() != ntend {
        return Err(mismatch(format!(
            "{} servo columns ({}) but the scene drives {ntend} tendons",
            rec.servos.len(),
            rec.servos.join(", ")
        )));
    }
    if ntend > 16 {
        return Err(mismatch(format!(
            "{ntend} tendons: the exhaustive assignment handles at most 16"
        )));
    }
    let (frame, offset) = match &scene.calibration {
        Some(c) => (
            RigidTransform::from_spec(&c.capture_to_base),
            Vector3::from(c.marker_offset_m),
        ),
        None => (
            RigidTransform::from_vector(&Vector3::zeros(), &Vector3::zeros()),
            Vector3::zeros(),
        ),
    };
    let patterns = rec.patterns(settings)?;
    let rows: Vec<ServoRows> = servo_rows(
        rec,
        &patterns,
        settings,
        &frame.rotation,
        &frame.translation,
    )?;
    let q_lo = rows
        .iter()
        .flat_map(|r| r.q.iter())
        .fold(f64::INFINITY, |a, &b| a.min(b));
    let q_hi = rows
        .iter()
        .flat_map(|r| r.q.iter())
        .fold(f64::NEG_INFINITY, |a, &b| a.max(b));
    let mut slack: Vec<f64> = rows.iter().map(|r| r.slack_m).collect();
    slack.sort_by(f64::total_cmp);
    let grid = model_grid(
        scene,
        &segs,
        (q_lo, q_hi),
        slack[slack.len() / 2],
        &offset,
        settings.grid_step_m,
    )?;
    // step 3: every servo against every segment
    let ns = segs.len();
    let mut rms = vec![vec![0.0; ns]; ntend];
    let mut theta = vec![vec![0.0; ns]; ntend];
    for (v, r) in rows.iter().enumerate() {
        for (i, seg) in segs.iter().enumerate() {
            let p: Vec<Vector3<f64>> = r.q.iter().map(|&q| grid.at(i, q)).collect();
            let (phi, e) = procrustes_z(&p, &r.tip);
            rms[v][i] = e;
            theta[v][i] = wrap(seg.angles[0] + phi);
        }
    }
    // step 4: dynamic programming over servo subsets, segments in order
    let full = (1usize << ntend) - 1;
    let mut layer: Vec<(usize, f64, Vec<usize>)> = vec![(0, 0.0, Vec::new())];
    for (i, seg) in segs.iter().enumerate() {
        let m = seg.cables.len();
        let mut next: std::collections::HashMap<usize, (f64, Vec<usize>)> = Default::default();
        for (mask, cost, groups) in &layer {
            let free = full & !mask;
            let mut g = free;
            while g > 0 {
                if g.count_ones() as usize == m {
                    let members: Vec<usize> = (0..ntend).filter(|b| g >> b & 1 == 1).collect();
                    let c = cost + group_cost(i, &members, seg, &rms, &theta, settings).0;
                    let key = mask | g;
                    if next.get(&key).is_none_or(|e| c < e.0) {
                        let mut gs = groups.clone();
                        gs.push(g);
                        next.insert(key, (c, gs));
                    }
                }
                g = (g - 1) & free;
            }
        }
        layer = next.into_iter().map(|(k, (c, g))| (k, c, g)).collect();
    }
    let (_, cost, groups) = layer
        .into_iter()
        .find(|(k, _, _)| *k == full)
        .ok_or_else(|| mismatch("no complete assignment".into()))?;
    let members = |g: usize| -> Vec<usize> { (0..ntend).filter(|b| g >> b & 1 == 1).collect() };
    let mut servos: Vec<ServoEvidence> = rows
        .iter()
        .enumerate()
        .map(|(v, r)| ServoEvidence {
            column: rec.servos[v].clone(),
            labels: r.labels.clone(),
            rows: r.q.len(),
            linear: linear_response(r),
            rms_m: rms[v].clone(),
            angle_deg: theta[v].iter().map(|t| t.to_degrees()).collect(),
            segment: 0,
            cable: 0,
            angle_misfit_deg: 0.0,
            next_best: None,
        })
        .collect();
    let mut segments = Vec::new();
    let mut readings = vec![None; scene.robot.cables.len()];
    let mut angles = vec![None; scene.robot.cables.len()];
    let mut group_costs = Vec::new();
    for (i, (seg, &g)) in segs.iter().zip(&groups).enumerate() {
        let mem = members(g);
        let (c, perm, beta, mis) = group_cost(i, &mem, seg, &rms, &theta, settings);
        group_costs.push(c);
        let mut per_cable = vec![0; seg.cables.len()];
        for ((&v, &k), d) in mem.iter().zip(&perm).zip(&mis) {
            per_cable[k] = v;
            let j = seg.cables[k];
            servos[v].segment = i;
            servos[v].cable = j;
            servos[v].angle_misfit_deg = d.to_degrees();
            readings[j] = Some(rec.servos[v].clone());
            angles[j] = Some((beta + seg.angles[k] - seg.angles[0]).to_degrees());
        }
        segments.push(SegmentProposal {
            section: seg.section,
            cables: seg.cables.clone(),
            servos: per_cable,
            first_angle_deg: beta.to_degrees(),
            scene_first_angle_deg: seg.angles[0].to_degrees(),
            offset_deg: wrap(beta - seg.angles[0]).to_degrees(),
        });
    }
    for s in servos.iter_mut() {
        let a = s.segment;
        s.next_best = (0..ns)
            .filter(|&i| i != a)
            .min_by(|&x, &y| s.rms_m[x].total_cmp(&s.rms_m[y]))
            .map(|i| (i, s.rms_m[i] / s.rms_m[a].max(f64::MIN_POSITIVE)));
    }
    let mut swaps = Vec::new();
    for i in 0..ns {
        for j in i + 1..ns {
            if segs[i].cables.len() != segs[j].cables.len() {
                continue;
            }
            let (gi, gj) = (members(groups[i]), members(groups[j]));
            let swapped = group_cost(i, &gj, &segs[i], &rms, &theta, settings).0
                + group_cost(j, &gi, &segs[j], &rms, &theta, settings).0;
            swaps.push(SwapMargin {
                segments: (i, j),
                margin: swapped - group_costs[i] - group_costs[j],
            });
        }
    }
    Ok(IdentifyResult {
        file: rec.file.clone(),
        servos,
        segments,
        cost,
        swaps,
        readings,
        angles_deg: angles,
    })
}

/// Identify from CSV text: columns and units from the scene (`[readings] scale_m`
/// for the servos; `[calibration]` marker columns and unit, else `[readings]
/// measured_tip`, for the tip).
pub fn identify(
    scene: &Scene,
    file: &str,
    text: &str,
    settings: &IdentifySettings,
) -> Result<IdentifyResult, IdentifyError> {
    let servo_scale = scene.readings.as_ref().map_or(1.0, |r| r.scale_m);
    let (cols, tip_scale) = match (&settings.tip_columns, &scene.calibration, &scene.readings) {
        (Some(c), cal, _) => (c.clone(), cal.as_ref().map_or(1.0, |c| c.unit.to_m())),
        (None, Some(c), _) => (c.marker_columns.clone(), c.unit.to_m()),
        (None, None, Some(r)) if r.measured_tip.is_some() => {
            (r.measured_tip.clone().expect("checked"), r.measured_scale_m)
        }
        _ => (["tip_x".into(), "tip_y".into(), "tip_z".into()], 1.0),
    };
    let rec = PullRecording::parse_str(file, text, settings, &cols, servo_scale, tip_scale)?;
    identify_recording(scene, &rec, settings)
}

/// [`identify`] on a file.
pub fn identify_file(
    scene: &Scene,
    path: &std::path::Path,
    settings: &IdentifySettings,
) -> Result<IdentifyResult, IdentifyError> {
    let text = std::fs::read_to_string(path).map_err(|e| IdentifyError::Io {
        path: path.display().to_string(),
        why: e.to_string(),
    })?;
    identify(scene, &path.display().to_string(), &text, settings)
}
