//! What the experiment binaries (`src/bin/`) share: timing and memory measurement
//! ([`measure`]), running child processes and the JAX reference ([`child`]), and report output
//! — verdicts, table cells, JSON files ([`report`]) — the scene files of a benchmark set
//! ([`scene_set`]) and planning a set under several variants ([`plan_set`]).
//!
//! Run an experiment with `cargo run --release -p experiments --bin NAME -- ARGS`; the binaries
//! are `safety`, `ablation`, `accuracy_vs_time`, `routes`, `roughness`, `speed_vs_jax`, `table`,
//! `suite`, `plan_speed` and `fit`.

pub mod child;
pub mod measure;
pub mod plan_set;
pub mod report;
pub mod scene_set;
