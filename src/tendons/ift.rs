//! The joint residual's Jacobian `F_z` at a converged readings solve, for the
//! implicit function theorem (calibration sensitivities, `calibrate::readings_model`,
//! and inverse kinematics, `crate::command`).
//!
//! A converged row is a zero of `F(z; q) = [r(x, T); G(x, T; q)]` in `z = [x; T]`
//! (scaled shooting unknowns, driven tensions), with per taut tendon
//! `G_i = L_f,i (1 + T_i/EA_t,i) + e_i(T_i) - l_i(x, T)`, `L_f,i = L0_i - q_i`, `e_i`
//! the series spring's extension (module docs of `crate::tendons`;
//! `TendonMechanics::covered`), and per slack tendon the row `T_i = 0`. Its
//! derivative in `T_i` is the tangent compliance
//! (`TendonMechanics::tangent_compliance`: `L_f/EA_t + de/dT`). With the active set
//! held, `F_z dz = -F_q dq`; `F_q` has one entry per taut tendon,
//! `dG_i/dq_i = -(1 + T_i / EA_t,i)` (the free length's derivative of `G_i`; the
//! spring's extension does not depend on it), and none for a slack one: a slack
//! tendon's reading does not move the robot.

use super::TendonMechanics;

/// Fill `a` (`m x m` row-major, `m = nx + p`) with `F_z` from the dual sweep's
/// `jac_s` (`nx x w`) and `jac_m` (`cables x w`, `w >= m`; columns `[x; T; ...]`):
/// the shooting rows, then per driven tendon `i` (cable `driven[i]`, free length
/// `free[i]` m, tension `t[i]` N) the taut row `c_i e_{nx+i} - dl_i/dz` (`c_i` the
/// tangent compliance at `t[i]`) or the slack row `e_{nx+i}`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn assemble_joint_jacobian(
    nx: usize,
    w: usize,
    jac_s: &[f64],
    jac_m: &[f64],
    driven: &[usize],
    mech: &[TendonMechanics],
    free: impl Fn(usize) -> f64,
    t: &[f64],
    taut: &[bool],
    a: &mut [f64],
) {
    let m = nx + driven.len();
    for r in 0..nx {
        a[r * m..(r + 1) * m].copy_from_slice(&jac_s[r * w..r * w + m]);
    }
    for (ti, &j) in driven.iter().enumerate() {
        let row_a = &mut a[(nx + ti) * m..(nx + ti + 1) * m];
        if taut[ti] {
            let c = mech[ti].tangent_compliance(free(ti), t[ti], 1.0);
            for (col, v) in row_a.iter_mut().enumerate() {
                *v = -jac_m[j * w + col];
            }
            row_a[nx + ti] += c;
        } else {
            row_a.fill(0.0);
            row_a[nx + ti] = 1.0;
        }
    }
}

/// `-dG_i/dq_i` of a taut tendon at tension `t` (N): `1 + T/EA_t` (0 for a slack
/// one). `dz/dq_i = F_z^-1 e_{nx+i} (1 + T_i/EA_t,i)`.
pub(crate) fn reading_gain(mech: &TendonMechanics, t: f64, taut: bool) -> f64 {
    if taut {
        1.0 + t / mech.stiffness_n
    } else {
        0.0
    }
}
