//! The straight readings path walked by adaptive steps, shared by the workspace
//! examples (`workspace_failures`, `workspace_fold`); the library's own walk is
//! `cablesense::command::workspace::fold_test`.

use cablesense::statics::Start;
use cablesense::tendons::TendonWorkspace;

/// Follow the straight path from `from` to `to` by adaptive steps, each solve warm
/// from the last converged point (a step that fails is halved, down to `1/2560` of
/// the way; one that converges doubled, up to `1/40`), calling `at(w, a, x)` at
/// each converged point `x`, `a` of the way: the fraction of the way reached (1 at
/// the end).
pub fn walk(
    w: &mut TendonWorkspace,
    from: &[f64],
    to: &[f64],
    mut at: impl FnMut(&mut TendonWorkspace, f64, &[f64]),
) -> f64 {
    let (mut a, mut h) = (0.0f64, 1.0 / 40.0);
    let mut x = from.to_vec();
    while a < 1.0 {
        let b = (a + h).min(1.0);
        for ((x, f), t) in x.iter_mut().zip(from).zip(to) {
            *x = f + b * (t - f);
        }
        let ok = w
            .solve_readings_from(&x, Start::Warm)
            .is_ok_and(|r| r.status.is_converged());
        if ok {
            a = b;
            h = (2.0 * h).min(1.0 / 40.0);
            at(w, a, &x);
        } else if h > 1.0 / 2560.0 {
            h *= 0.5;
        } else {
            break;
        }
    }
    a
}
