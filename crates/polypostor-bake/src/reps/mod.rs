//! The representations the papers compare against, baked beside the Polypostor: the runtime
//! crate's formats and loaders ([`polypostor_runtime::reps`], re-exported here), their bake,
//! the side-by-side comparison and the quality sheet.

pub use polypostor_runtime::reps::*;

pub mod bake;
pub mod compare;
pub mod quality;
