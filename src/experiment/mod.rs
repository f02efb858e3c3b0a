//! Experiments: the serde model of `experiments/*.toml`, references, and the runner.
//!
//! What lives here: [`config`] (the experiment file model, `[[strategy]]` tables and sweeps,
//! validated against the strategy [`crate::strategy::Registry`]), [`run`](mod@run) (the plan of cells,
//! preparation, passes and checkpoints, the cell cache, shards and merge, run directories),
//! [`reference`](mod@reference) (converged reference images), [`render`](mod@render) (one image
//! by any strategy: `bench render`), [`map_error`] (`bench map-error`). What does not:
//! rendering algorithms (strategies) and report formatting (the runner calls
//! [`crate::report`] with rows and the run directory).

pub mod config;
pub mod map_error;
pub mod reference;
pub mod render;
pub mod run;

pub use config::Experiment;
pub use run::{Shard, merge, run, run_shard};
