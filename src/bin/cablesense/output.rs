//! Shared text/CSV formatting for the commands.

use cablesense::{Pose, Sample};
use std::io::Write;

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
