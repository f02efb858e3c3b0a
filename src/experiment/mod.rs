//! Experiments: the serde model of `experiments/*.toml`, references, and the runner.

pub mod config;
pub mod map_error;
pub mod reference;
pub mod run;

pub use config::Experiment;
pub use run::{Shard, merge, run, run_shard};
