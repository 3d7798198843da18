//! The Polypostor pack: a versioned, documented on-disk format (see `docs/PACK_FORMAT.md`)
//! and a loader that validates everything it reads (the writer is the studio's).
//!
//! A pack is a folder: `manifest.json`, `vertices.bin` (little-endian normalised u16 atlas
//! UVs, and view-plane positions as bytes inside each block's box: [`quant`]), `indices.bin` (little-endian u16 triangles) and, per view,
//! a colour atlas PNG holding every part's key images and a normal atlas at half its size.

mod format;
mod load;
pub use crate::quant;

pub use format::{
    Checksums, FORMAT_NAME, FORMAT_VERSION, FileSum, MAX_KEYS, Manifest, ManifestKey, ManifestPart, ManifestView,
    OLDEST_FORMAT_VERSION, PackCamera, put_file,
};
pub use load::valid_order;
pub(crate) use load::{
    FolderReader, check_camera, check_direction, check_resolution_views, check_texture_budget, check_timing,
    parse_manifest,
};
pub use load::{LoadedPack, LoadedView, MAX_ATLAS_SIDE, MAX_PART_VERTICES, PackError, atlas_area_bound, load_pack};
