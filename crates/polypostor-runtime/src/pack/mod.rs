//! The Polypostor pack: a versioned, documented on-disk format (see `docs/PACK_FORMAT.md`)
//! with a writer and a loader that validates everything it reads.
//!
//! A pack is a folder: `manifest.json`, `vertices.bin` (little-endian f32), `indices.bin`
//! (little-endian u16) and one atlas PNG per view holding every part's key-frame colour
//! (left half) and normal (right half) images.

mod format;
mod load;

pub use format::{
    Checksums, FORMAT_NAME, FORMAT_VERSION, FileSum, MAX_KEYS, Manifest, ManifestKey, ManifestPart, ManifestView,
    PackCamera, put_file,
};
pub use load::valid_order;
pub(crate) use load::{
    FolderReader, check_camera, check_direction, check_resolution_views, check_texture_budget, check_timing,
    parse_manifest,
};
pub use load::{LoadedPack, LoadedView, MAX_ATLAS_SIDE, MAX_PART_VERTICES, PackError, load_pack};
