//! Tendon mechanics of a tendon-driven continuum robot (TDCR): how each cable is
//! actuated, its stretch and pretension, slack, capstan friction and its own routing.
//!
//! A displacement-driven tendon is pulled by a position-controlled actuator whose
//! encoder reads `q` (m, positive = pulled). The reading sets the tendon's free
//! (unstretched) length `L_f = L0 - q` between the actuator and the termination disk.
//! With the path `l(shape)` through the holes (thesis 3.8.1) or along a continuous
//! path (below), an axial stiffness `EA_t` and a series spring `k_s` at the actuator,
//! a taut tendon carries
//!
//! ```text
//! l = L_f (1 + T/EA_t) + T/k_s          <=>  T = (l - L_f) / (L_f/EA_t + 1/k_s)
//! ```
//!
//! (for `k_s = inf` this is the issue's `T = EA_t (l - L_f)/L_f`), and a tendon whose
//! path is shorter than its free length is slack: `T = 0` and its reading says
//! nothing about the path. Both cases are the complementarity condition
//! `0 <= T  _|_  L_f (1 + T/EA_t) + T/k_s - l >= 0`, solved by a semi-smooth Newton
//! method on the tensions around the shooting solve ([`TendonWorkspace`]), with the
//! exact derivatives `dl/dT` of the path lengths (implicit differentiation of the
//! shooting problem, [`crate::Workspace::length_sensitivities`]) on the taut side and
//! the identity on the slack side.
//!
//! The pretension `T0` at `q = 0` fixes `L0`: the robot is solved with every
//! displacement-driven tendon at `T0` under the scene's loads, and `L0 = (l_ref -
//! T0/k_s) / (1 + T0/EA_t)`.
//!
//! **Continuous routing.** A displacement-driven tendon may also run on a continuous
//! path (`routing = "continuous"`, [`crate::robot::TendonPath`]): then `l` is the
//! path's length `int_0^{s_e} |p_i'| ds`, integrated along the shooting pass (RW 2011
//! section III, `statics::pass::continuous`), with its exact derivatives from the same dual
//! sweep, and everything above holds unchanged (`L0` from the reference at `T0`,
//! stretch, series spring, slack). Refused: capstan friction (`robot.friction` with
//! `mu > 0`: a per-disk wrap-angle model, [`capstan_factors`]) on such a tendon.
//! Multiple shooting never runs for a readings solve (its tensions are load
//! parameters, which `statics::multiple` does not take), continuous tendon or not.
//!
//! Rucker & Webster 2011 ("Statics and dynamics of continuum robots with general
//! tendon routing and external loading", IEEE T-RO 27(6)) treat tendons as
//! inextensible with given tensions; stretch, pretension and slack are what the
//! position-controlled hardware adds (see `data/hardware/ftdcr_v4/`).

pub mod fold;
pub(crate) mod ift;
mod scene;
mod solve;

// The tendon's description, mechanics and capstan friction belong to the robot
// (`crate::robot`); re-exported here under their established paths.
pub use crate::robot::{
    capstan_factors, Actuation, FrictionLaw, FrictionSpec, RoutingSpec, TendonMechanics, TendonSpec,
};
pub use fold::{FoldPoint, FoldProbe};
pub use solve::{TendonReport, TendonSettings, TendonWorkspace};
