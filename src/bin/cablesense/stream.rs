//! Shared by `estimate` and `track`: estimator from a scene, one JSON object per sample.

use anyhow::Context;
use cablesense::estimate::{DynModel, Estimate, Estimator};
use cablesense::files::demo::DataRef;
use cablesense::files::measure::{LineError, Sample, StreamParser};
use cablesense::ladder::Rung;
use cablesense::Scene;
use serde_json::{json, Value};
use std::path::Path;

/// The `--model` option of `estimate` and `track`.
pub const MODEL_HELP: &str = "Forward model under the estimator: `scene` (the scene's [numerics], the default) or a rung label of the model ladder such as `cc`, `pcc/point/16`, `kirchhoff/average/rk4-16`, `cosserat/accurate/adaptive-1e-8` (see `solve --model`)";

/// The estimator's model, as a run-time choice.
pub type SceneEstimator = Estimator<DynModel>;

/// Build the estimator of a scene that has an `[estimate]` table, on the rung named
/// by `model` (`scene` or a ladder label).
pub fn estimator(scene_path: &Path, model: &str) -> anyhow::Result<(Scene, SceneEstimator)> {
    let scene = DataRef::parse(scene_path)?.scene()?;
    let spec = scene.estimate.clone().with_context(|| {
        format!(
            "{}: no [estimate] table: nothing to estimate",
            scene_path.display()
        )
    })?;
    let robot = scene.build_robot()?;
    let rung = match model {
        "scene" => Rung::Rod(scene.numerics.clone()),
        "auto" => anyhow::bail!(
            "--model auto picks a rung for one forward solve: run `cablesense solve {} --model auto` and pass the label it picks",
            scene_path.display()
        ),
        label => crate::solve::rung_by_label(&robot, label, "scene")?,
    };
    let est = Estimator::on_rung(robot, scene.loads.clone(), &rung, spec).with_context(|| {
        format!(
            "building the estimator of {} on {}",
            scene_path.display(),
            rung.label()
        )
    })?;
    Ok((scene, est))
}

/// Open an input file (`demo:NAME` for a shipped one) for reading by lines.
pub fn open_input(arg: &Path) -> anyhow::Result<Box<dyn std::io::BufRead>> {
    Ok(match DataRef::parse(arg)? {
        DataRef::Path(p) => Box::new(std::io::BufReader::new(open_file(&p)?)),
        DataRef::Demo(f) => Box::new(std::io::Cursor::new(f.text.as_bytes())),
    })
}

/// Open a file of rows for reading. A directory is refused here: `File::open`
/// accepts one on Linux and every read of it then fails, so a stream reading it
/// line by line would report an unreadable line forever.
pub fn open_file(p: &Path) -> anyhow::Result<std::fs::File> {
    let file = std::fs::File::open(p).with_context(|| format!("cannot open {}", p.display()))?;
    if file.metadata().is_ok_and(|m| m.is_dir()) {
        anyhow::bail!("{} is a directory, not a file of rows", p.display());
    }
    Ok(file)
}

/// Whether an input gave any line with more than white space (shared with the
/// [`Watched`] reader that records it).
pub type Content = std::rc::Rc<std::cell::Cell<bool>>;

/// A reader that records in a [`Content`] flag whether any line it gave had more
/// than white space (a line that is not UTF-8 counts as content).
pub struct Watched<R> {
    inner: R,
    content: Content,
}

impl<R: std::io::BufRead> Watched<R> {
    /// Watch `inner`; the flag to read after the stream.
    pub fn new(inner: R) -> (Self, Content) {
        let content = Content::default();
        (
            Self {
                inner,
                content: content.clone(),
            },
            content,
        )
    }
}

impl<R: std::io::BufRead> std::io::Read for Watched<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        if buf[..n].iter().any(|b| !b.is_ascii_whitespace()) {
            self.content.set(true);
        }
        Ok(n)
    }
}

impl<R: std::io::BufRead> std::io::BufRead for Watched<R> {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        self.inner.fill_buf()
    }
    fn consume(&mut self, amt: usize) {
        self.inner.consume(amt)
    }
    // `Lines` reads through `read_line`: look at each line here
    fn read_line(&mut self, buf: &mut String) -> std::io::Result<usize> {
        let start = buf.len();
        let n = self.inner.read_line(buf).inspect_err(|e| {
            if e.kind() == std::io::ErrorKind::InvalidData {
                self.content.set(true);
            }
        })?;
        if !buf[start..].trim().is_empty() {
            self.content.set(true);
        }
        Ok(n)
    }
}

/// Open an input file (`demo:NAME` for a shipped one) for reading by lines, with
/// the flag that says whether it had any content (see [`no_rows`]).
pub fn open_watched(arg: &Path) -> anyhow::Result<(Box<dyn std::io::BufRead>, Content)> {
    let (r, content) = Watched::new(open_input(arg)?);
    Ok((Box::new(r), content))
}

/// The error for an input that gave no row at all (`rows` counts good and bad
/// rows): an empty file or stream, or one with a header and nothing after it. Fatal
/// like a bad stream header (exit code 1), for a named file and for standard input
/// alike, since a run over nothing would look like a clean one.
pub fn no_rows(arg: &Path, rows: usize, content: &Content) -> Option<String> {
    (rows == 0).then(|| {
        if content.get() {
            format!(
                "{}: no rows: a header (or comments) and no data row after it",
                arg.display()
            )
        } else {
            format!("{}: no rows: the file is empty", arg.display())
        }
    })
}

/// A line of a row stream: a line that is not UTF-8 is reported and skipped (the
/// stream goes on, `Ok(Err(..))`); any other read error stops the stream, since
/// reading on would fail the same way for every later line.
pub fn stream_line(
    line: std::io::Result<String>,
    line_no: usize,
) -> anyhow::Result<Result<String, std::io::Error>> {
    match line {
        Ok(l) => Ok(Ok(l)),
        Err(e) if e.kind() == std::io::ErrorKind::InvalidData => Ok(Err(e)),
        Err(e) => Err(anyhow::Error::new(e).context(format!("reading line {line_no}"))),
    }
}

/// A parser for the scene's cable names.
pub fn parser(scene: &Scene, est: &SceneEstimator) -> StreamParser {
    let names = scene
        .robot
        .cables
        .iter()
        .enumerate()
        .map(|(j, c)| c.name.clone().unwrap_or_else(|| format!("cable{j}")))
        .collect();
    let _ = est;
    StreamParser::new(names, None)
}

/// Tick one sample and snapshot it.
pub fn process(est: &mut SceneEstimator, s: &Sample) -> Estimate {
    est.tick(&s.changes_m, s.sigma_m.as_deref());
    est.estimate()
}

/// JSON line of an estimate.
pub fn estimate_json(s: &Sample, e: &Estimate) -> Value {
    let values: serde_json::Map<String, Value> = e
        .names
        .iter()
        .zip(&e.values)
        .map(|(n, v)| (n.clone(), json!(v)))
        .collect();
    let std: serde_json::Map<String, Value> = e
        .names
        .iter()
        .zip(&e.std_dev)
        .map(|(n, v)| (n.clone(), json!(v)))
        .collect();
    json!({
        "line": s.line,
        "t_s": s.t_s,
        "status": e.status,
        "fit": e.fit,
        "rms_sigma": e.rms_sigma,
        "redundancy": e.redundancy,
        "estimate": values,
        "std_dev": std,
        "covariance": e.covariance,
        "rank": e.rank,
        "condition": if e.condition.is_finite() { json!(e.condition) } else { json!(null) },
        "unobservable": e.unobservable,
        "tip_position_m": [e.tip.position.x, e.tip.position.y, e.tip.position.z],
        "tip_tangent": [e.tip.rotation[(0, 2)], e.tip.rotation[(1, 2)], e.tip.rotation[(2, 2)]],
        "section_tips_m": e.section_tips.iter().map(|p| [p.position.x, p.position.y, p.position.z]).collect::<Vec<_>>(),
        "measured_m": e.measured_m,
        "predicted_m": e.predicted_m,
        "residual_m": e.residual_m,
        "iterations": e.iterations,
        "jacobian_evals": e.jacobian_evals,
        "elapsed_s": e.elapsed_s,
    })
}

/// JSON line of a bad input line.
pub fn error_json(e: &LineError) -> Value {
    json!({"line": e.line, "error": e.to_string(), "field": e.field, "fatal": e.fatal})
}
