//! The integration tests in one test binary (`cargo test --release --test
//! integration`; one file with `cargo test --release --test integration thesis_tables::`).
//!
//! Why one binary: each test crate compiles its own copies of the library's generic
//! code and links the library on its own; as 55 crates they took 144 s of a 2-core
//! machine's wall time to build (`touch tests/*.rs`, `cargo test --release
//! --workspace --no-run`). The files keep their
//! names and their proptest regression files. The tests that need a process to
//! themselves stay separate crates (`Cargo.toml`, `[[test]]`): the four with a
//! counting `#[global_allocator]` (`estimate_alloc`, `estimate_tendon_alloc`,
//! `estimate_joint`, `estimate_ladder`) and `fuzz_regressions` (it reads the fuzz
//! targets' bodies through `#[path]`).

mod calibrate_common;
mod common;
mod estimate_common;

mod arc_coupling;
mod auto_readings;
mod bad_input_catalogue;
mod budget;
mod calibrate_cli;
mod calibrate_conditioning;
mod calibrate_crossval;
mod calibrate_exact_sensitivities;
mod calibrate_failed_rows;
mod calibrate_friction;
mod calibrate_identifiability;
mod calibrate_identify;
mod calibrate_jacobian;
mod calibrate_lm;
mod calibrate_recordings;
mod calibrate_roundtrip;
mod calibrate_roundtrip_tdcr;
mod calibrate_sensitivities;
mod calibrate_tendons;
mod cli_anywhere;
mod cli_broken_pipe;
mod continuous_routing;
mod daru_order;
mod estimate_bounds;
mod estimate_noise;
mod estimate_roundtrip;
mod estimate_tendon_loads;
mod experiments_pareto;
mod experiments_stability;
mod forward_closed_form;
mod forward_invariants;
mod forward_jacobian;
mod hardware_ftdcr;
mod ik;
mod ladder;
mod ladder_displacement;
mod measuring_cables;
mod reach_3d;
mod reach_cables;
mod reach_cli;
mod reach_elastica;
mod reach_follower;
mod repro_reliability;
mod rollback;
mod scene_errors;
mod scene_limits;
mod settings_matrix;
mod soak_faults;
mod soft_arm;
mod stability;
mod svg_shape;
mod tendon_cold;
mod tendon_continuous;
mod tendon_derivatives;
mod tendon_tolerance;
mod tendons;
mod thesis_loo;
mod thesis_tables;
mod validate_hardware;
mod workspace;
