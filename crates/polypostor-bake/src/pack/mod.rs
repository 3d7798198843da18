//! The Polypostor pack's writer and atlas packing; the format and its validating loader are
//! the runtime crate's ([`polypostor_runtime::pack`], re-exported here).

pub use polypostor_runtime::pack::*;

mod atlas;
pub mod bc;
mod write;

pub use atlas::{Atlas, AtlasRect, dilate, pack_atlas};
pub use write::{PackStats, write_folder_atomic, write_pack, write_pack_with};

/// Bytes of the Polypostor's polygons, estimated before they are fitted: per view, part and
/// frame the polygon's positions (2 bytes each), about 10 % more for the extra keys' polygons
/// (they hold only the frames they draw); per view and part the UVs, the position box, the
/// triangles and the coarse level's (about half as many).
pub fn polygon_bytes_estimate(views: usize, frames: usize, parts: usize, vertices: usize) -> u64 {
    let (v, f, p, nv) = (views as u64, frames.max(1) as u64, parts as u64, vertices.max(3) as u64);
    v * p * f * nv * 2 * 11 / 10 + v * p * ((nv - 2) * 3 * 2 * 3 / 2 + nv * 4 + 8)
}
