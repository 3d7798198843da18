//! The Polypostor pack's writer and atlas packing; the format and its validating loader are
//! the runtime crate's ([`polypostor_runtime::pack`], re-exported here).

pub use polypostor_runtime::pack::*;

mod atlas;
pub mod bc;
mod write;

pub use atlas::{Atlas, AtlasRect, dilate, fill_background, pack_atlas};
pub use write::{PackStats, write_folder_atomic, write_pack, write_pack_with};
