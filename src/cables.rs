//! Cable lengths from guide transforms (thesis 3.8.1).
//!
//! Each hole `d_j` (local, in the disk plane) is carried to the world by the disk's
//! homogeneous transform `T(s_i) = [R(s_i) r(s_i); 0 1]`: `p_ij = r(s_i) + R(s_i) d_j`.
//! A cable's length is the sum of straight chords between consecutive holes, from
//! the base plate hole (`s = 0`, fixed to the base frame) to the disk where it ends.
//! The thesis's sum (`L = sum_{i=2}^{n-1} ||T_i d_i - T_{i-1} d_{i-1}||`) has index
//! typos; here every chord from the base plate to the termination disk is counted.

use crate::math::Real;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// Length of one cable and of each of its chords.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CableLength {
    /// Cable name.
    pub name: String,
    /// Total length from the base plate to the termination disk (m).
    pub total_m: f64,
    /// Chord lengths: base plate -> disk 1, disk 1 -> disk 2, ... (m).
    pub segments_m: Vec<f64>,
}

/// Sum of chord lengths along `base, holes[0], holes[1], ...` (m).
pub fn path_length(base: &Vector3<f64>, holes: &[Vector3<f64>]) -> f64 {
    let mut prev = base;
    let mut total = 0.0;
    for p in holes {
        total += (p - prev).norm();
        prev = p;
    }
    total
}

/// Chord lengths along `base, holes[0], ...`.
pub fn segments(base: &Vector3<f64>, holes: &[Vector3<f64>]) -> Vec<f64> {
    let mut prev = base;
    holes
        .iter()
        .map(|p| {
            let l = (p - prev).norm();
            prev = p;
            l
        })
        .collect()
}

/// [`path_length`] over any scalar (dual numbers give exact length derivatives).
pub fn path_length_t<T: Real>(base: &Vector3<T>, holes: &[Vector3<T>]) -> T {
    let mut prev = base;
    let mut total = T::zero();
    for p in holes {
        let d = p - prev;
        total += d.dot(&d).sqrt();
        prev = p;
    }
    total
}
