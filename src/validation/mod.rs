//! Validation layer: the thesis experiments (tables 4.1-4.5) as scenes, and
//! least-squares calibration of named scene parameters.
