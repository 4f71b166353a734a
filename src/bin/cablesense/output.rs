//! Shared text/CSV formatting for the commands.

use cablesense::{Pose, Sample};
use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};

/// Set by the panic hook of [`quiet_on_broken_pipe`] when `print!`/`println!` failed
/// because stdout is a closed pipe.
static STDOUT_CLOSED: AtomicBool = AtomicBool::new(false);

/// Text of the OS errors that mean "the reader of this pipe is gone" (EPIPE on Unix;
/// ERROR_BROKEN_PIPE and ERROR_NO_DATA on Windows), as `std::io::Error` prints them.
fn broken_pipe_texts() -> Vec<String> {
    let codes: &[i32] = if cfg!(windows) { &[109, 232] } else { &[32] };
    codes
        .iter()
        .map(|&c| std::io::Error::from_raw_os_error(c).to_string())
        .collect()
}

/// Install a panic hook that keeps quiet about the panic of `print!`/`println!` on a
/// closed stdout (`cablesense validate | head`: std panics with "failed printing to
/// stdout: Broken pipe (os error 32)") and records it for [`stdout_was_closed`]; every
/// other panic goes to the default hook. The panic still unwinds (open files are
/// flushed and closed); `main` turns it into a quiet exit with code 0, as for a
/// stream command that got the closed pipe as an error ([`is_broken_pipe`]).
pub fn quiet_on_broken_pipe() {
    let texts = broken_pipe_texts();
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let payload = info.payload();
        let msg = payload
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| payload.downcast_ref::<&str>().copied())
            .unwrap_or("");
        if msg.starts_with("failed printing to stdout") && texts.iter().any(|t| msg.contains(t)) {
            STDOUT_CLOSED.store(true, Ordering::SeqCst);
        } else {
            default(info);
        }
    }));
}

/// Whether a `print!` on a closed stdout panicked (see [`quiet_on_broken_pipe`]).
pub fn stdout_was_closed() -> bool {
    STDOUT_CLOSED.load(Ordering::SeqCst)
}

/// Whether an error comes from writing to a closed pipe (`io::ErrorKind::BrokenPipe`
/// anywhere in its chain).
pub fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

/// `x y z` in mm with 3 decimals.
pub fn mm(v: &cablesense::nalgebra::Vector3<f64>) -> String {
    format!("{:10.3} {:10.3} {:10.3}", v.x * 1e3, v.y * 1e3, v.z * 1e3)
}

/// Local z axis (tangent) of a pose.
pub fn tangent(p: &Pose) -> String {
    let t = p.rotation.column(2);
    format!("{:8.5} {:8.5} {:8.5}", t.x, t.y, t.z)
}

/// Write backbone samples as CSV (SI units in the header).
pub fn write_samples_csv(path: &std::path::Path, samples: &[Sample]) -> anyhow::Result<()> {
    let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(f, "s_m,x_m,y_m,z_m,tx,ty,tz,nx_n,ny_n,nz_n,mx_nm,my_nm,mz_nm,ux_per_m,uy_per_m,uz_per_m,vx,vy,vz")?;
    for s in samples {
        let t = s.rotation.column(2);
        writeln!(
            f,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            s.s,
            s.r.x,
            s.r.y,
            s.r.z,
            t.x,
            t.y,
            t.z,
            s.n.x,
            s.n.y,
            s.n.z,
            s.m.x,
            s.m.y,
            s.m.z,
            s.u.x,
            s.u.y,
            s.u.z,
            s.v.x,
            s.v.y,
            s.v.z
        )?;
    }
    Ok(())
}
