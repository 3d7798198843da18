//! The manifest: what `manifest.json` holds (serde).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

/// The [`Manifest::format`] of every pack; a manifest with another is refused as not a pack.
pub use crate::limits::PACK_FORMAT_NAME as FORMAT_NAME;
/// Version 3 added [`Manifest::checksums`], version 5 the clip table ([`Manifest::clips`]:
/// several clips in one pack), version 6 BC7 textures, version 7 8-bit positions (see
/// [`ManifestPart::vertex_offset`]); older packs are refused with "re-bake".
pub const FORMAT_VERSION: u32 = 7;
/// The oldest format version this build reads (5: the same manifest, textures only as PNG,
/// positions as u16 like the UVs).
pub const OLDEST_FORMAT_VERSION: u32 = 5;

/// Size and CRC-32 (IEEE, as zlib and PNG compute it) of one file of a pack or
/// representations folder.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct FileSum {
    /// Size of the file in bytes.
    pub bytes: u64,
    /// CRC-32 of the file's whole content.
    pub crc32: u32,
}

impl FileSum {
    /// The size and CRC-32 of a file holding `bytes`.
    pub fn of(bytes: &[u8]) -> Self {
        Self {
            bytes: bytes.len() as u64,
            crc32: crc32fast::hash(bytes),
        }
    }
}

/// Every data file of a folder by name, with its size and checksum.
pub type Checksums = BTreeMap<String, FileSum>;

/// The orthographic camera of a view: a world point maps to view-plane coordinates
/// `((p - center)·right, (p - center)·up) / half_size`, in [-1, 1] inside the frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PackCamera {
    /// World point at the middle of the view frame (the camera's target), view-plane (0, 0).
    pub center: [f32; 3],
    /// Unit world direction of the view plane's +x axis.
    pub right: [f32; 3],
    /// Unit world direction of the view plane's +y axis.
    pub up: [f32; 3],
    /// Towards the camera.
    pub forward: [f32; 3],
    /// Half the side of the view frame in world units: the world distance from `center`
    /// that maps to ±1 on the view plane (positive; 1 for a perspective bake camera).
    pub half_size: f32,
}

impl PackCamera {
    /// The view's frame as the renderers take it.
    pub fn view_frame(&self) -> crate::gpu::inputs::ViewFrame {
        crate::gpu::inputs::ViewFrame {
            center: self.center,
            right: self.right,
            up: self.up,
            forward: self.forward,
            half_size: self.half_size,
        }
    }

    /// The pack form of an orthographic bake camera (a perspective one gets half size 1).
    pub fn from_camera(cam: &crate::gpu::Camera) -> Self {
        let view_m = cam.view_from_world();
        let row = |i: usize| [view_m.row(i).x, view_m.row(i).y, view_m.row(i).z];
        let half_size = match cam.projection {
            crate::gpu::Projection::Orthographic { half_height } => half_height,
            crate::gpu::Projection::Perspective { .. } => 1.0,
        };
        Self {
            center: cam.target.to_array(),
            right: row(0),
            up: row(1),
            forward: row(2),
            half_size,
        }
    }

    /// Back to an orthographic camera looking at `center` from `distance` along `forward`,
    /// seeing depths `near..far` from the eye.
    pub fn to_camera(&self, distance: f32, near: f32, far: f32) -> crate::gpu::Camera {
        let c = glam::Vec3::from(self.center);
        crate::gpu::Camera {
            eye: c + glam::Vec3::from(self.forward) * distance,
            target: c,
            up: glam::Vec3::from(self.up),
            projection: crate::gpu::Projection::Orthographic {
                half_height: self.half_size,
            },
            near,
            far,
        }
    }
}

/// One part in one view.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ManifestPart {
    /// First value (u16) of this part's block in `vertices.bin`. The block holds
    /// `vertex_count` UVs (atlas-normalised, 2 normalised u16 values each: `x / 65535`), then
    /// the block's position box (4 u16: lower corner x, y and size x, y, see
    /// [`crate::quant::PositionBox`]), then `frames × vertex_count` positions, each one
    /// u16 slot holding two bytes (x then y) inside the box (view-plane coordinates
    /// `(x + 1) / 2, (y + 1) / 2`). Format 5 and 6 packs have no box and store each position
    /// as two normalised u16 values.
    pub vertex_offset: u64,
    /// Vertices of the part's polygon (3 to [`crate::pack::MAX_PART_VERTICES`]): one UV each,
    /// and one position per frame.
    pub vertex_count: u32,
    /// First u16 of this part's triangles in `indices.bin` (indices local to the part).
    pub index_offset: u64,
    /// Indices of the part's triangles in `indices.bin`, three per triangle (a non-zero
    /// multiple of 3).
    pub index_count: u32,
    /// First u16 of the part's coarse triangles in `indices.bin` (format 7): the polygon
    /// simplified to about half its vertices by the same deformation-aware rule, drawn for
    /// characters small on screen. Indices local to the block, like `index_offset`'s.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub coarse_index_offset: u64,
    /// Indices of the coarse triangles, a multiple of 3; 0: none (the run time thins the
    /// polygon itself).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub coarse_index_count: u32,
    /// The bounding box of the part's image in the colour atlas, pixels `[x, y, w, h]` (the
    /// image is cut to the texels its polygon samples, so two boxes may overlap where their
    /// texels do not; for tools).
    pub atlas_rect: [u32; 4],
    /// The part's image is stored transposed in the atlas (for tools; the UVs already say so,
    /// and also whether it is turned half round, which is not recorded).
    #[serde(default)]
    pub transposed: bool,
    /// The frame this key image is of (the view's key frame).
    #[serde(default)]
    pub key_frame: u32,
    /// The part's further key images in this view (the bake's key choice).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub extra_keys: Vec<ManifestKey>,
    /// Per frame, the key it is drawn from: 0 this entry's image, `k` `extra_keys[k - 1]`.
    /// Empty when the part has one key. Where two consecutive frames differ, the run time
    /// cross-fades the two keys' warped images over the interval.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub frame_keys: Vec<u8>,
}

/// A part's key image after its first, and its polygon.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ManifestKey {
    /// The frame this key image is of (below [`Manifest::frames`]).
    pub key_frame: u32,
    /// As [`ManifestPart::vertex_offset`], but the block holds `frame_count` frames of
    /// positions, from `frame_start` round the loop (the frames this key's polygon was fitted
    /// to; every frame it draws and their neighbours).
    pub vertex_offset: u64,
    /// Vertices of this key's polygon, as [`ManifestPart::vertex_count`].
    pub vertex_count: u32,
    /// First u16 of this key's triangles in `indices.bin` (indices local to the key's block).
    pub index_offset: u64,
    /// Indices of this key's triangles, a non-zero multiple of 3.
    pub index_count: u32,
    /// As [`ManifestPart::coarse_index_offset`], for this key's polygon.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub coarse_index_offset: u64,
    /// As [`ManifestPart::coarse_index_count`].
    #[serde(default, skip_serializing_if = "is_zero")]
    pub coarse_index_count: u32,
    /// This key image's bounding box in the view's colour atlas, pixels `[x, y, w, h]`, as
    /// [`ManifestPart::atlas_rect`].
    pub atlas_rect: [u32; 4],
    /// The image is stored transposed in the atlas, as [`ManifestPart::transposed`].
    #[serde(default)]
    pub transposed: bool,
    /// The first frame of the block's positions (below [`Manifest::frames`]); the frames
    /// after it wrap from the pack's last frame to frame 0.
    pub frame_start: u32,
    /// Frames of positions the block holds (1 to [`Manifest::frames`]).
    pub frame_count: u32,
}

/// One view.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ManifestView {
    /// Unit direction from the character towards the camera.
    pub direction: [f32; 3],
    /// The orthographic camera the view was baked with: the frame of the parts' view-plane
    /// positions (its `forward` is `direction`).
    pub camera: PackCamera,
    /// Colour atlas PNG file name (in the pack folder).
    pub atlas: String,
    /// Normal atlas PNG file name: the colour atlas's layout at half resolution.
    pub normal_atlas: String,
    /// Colour atlas size (even); the normal atlas is half of it in each direction.
    pub atlas_size: [u32; 2],
    /// Parts in drawing order, back to front.
    pub order: Vec<u32>,
    /// Per part (indexed like `Manifest::parts`); `None` when not drawn in this view.
    pub parts: Vec<Option<ManifestPart>>,
}

/// `manifest.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// Always [`FORMAT_NAME`].
    pub format: String,
    /// The format version the pack was written in; this build reads [`OLDEST_FORMAT_VERSION`](super::OLDEST_FORMAT_VERSION) to [`FORMAT_VERSION`](super::FORMAT_VERSION).
    pub version: u32,
    /// Name of the character baked.
    pub character: String,
    /// The file the character was baked from, as the bake found it (absolute), so that
    /// `compare` and the crowd find it without being told; absent in packs written by the
    /// library alone and before it was recorded. Only a hint: whoever loads it checks that the
    /// character's clips, frames and size are the baked ones.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub character_path: Option<String>,
    /// Which of that file's axes the bake read as up (absent: glTF's +y); loaders import the
    /// file the same way ([`crate::import::ImportOptions::up`]).
    #[serde(default, skip_serializing_if = "crate::character::UpAxis::is_default")]
    pub character_up: crate::character::UpAxis,
    /// The first clip's name (`None`: the rest pose).
    pub clip: Option<String>,
    /// Frames per second every clip was sampled at ([`crate::limits::MIN_FPS`] to
    /// [`crate::limits::MAX_FPS`]).
    pub fps: f32,
    /// Frames of every clip together ([`Manifest::clips`]).
    pub frames: u32,
    /// The clips, one after another in the frame sequence: name, first frame, frame count,
    /// whether it loops, measured ground speed ([`crate::timeline`]). Every frame-indexed
    /// table of the pack (positions, frame keys) runs over all of them; each clip loops over
    /// its own frames. Every view's key images serve every clip.
    pub clips: Vec<crate::timeline::ClipSpan>,
    /// The bake's key frame (below `frames`); a part's own key image may be of another frame
    /// ([`ManifestPart::key_frame`]).
    pub key_frame: u32,
    /// Pixels per side of the square part images the bake rendered and cut the atlas images
    /// from ([`crate::limits::MIN_RESOLUTION`] to [`crate::limits::MAX_RESOLUTION`]).
    pub resolution: u32,
    /// Body part names, by part number (1 to [`crate::limits::MAX_PARTS`]); every view's
    /// `parts` and `order` index into this list.
    pub parts: Vec<String>,
    /// The baked viewpoints; a view's index is its position in this list.
    pub views: Vec<ManifestView>,
    /// File name of the vertex data in the pack folder (`vertices.bin`): little-endian
    /// normalised u16 values ([`ManifestPart::vertex_offset`]).
    pub vertex_file: String,
    /// Size of the vertex file in bytes (even: whole u16 values).
    pub vertex_bytes: u64,
    /// File name of the triangle indices in the pack folder (`indices.bin`): little-endian
    /// u16 values, local to each key's vertex block.
    pub index_file: String,
    /// Size of the index file in bytes (even: whole u16 values).
    pub index_bytes: u64,
    /// Size and CRC-32 of every file the pack's data lives in (`vertices.bin`,
    /// `indices.bin`, every atlas); the loader reads nothing that is not listed here.
    #[serde(default)]
    pub checksums: Checksums,
}

impl Manifest {
    /// The frame after `f` as its clip plays (a clip's last frame is followed by its first).
    pub fn next_frame(&self, f: usize) -> usize {
        crate::timeline::next_frame(&self.clips, f)
    }
}

fn is_zero<T: Default + PartialEq>(x: &T) -> bool {
    *x == T::default()
}

/// Most key images per part and view the format and the renderer take.
pub const MAX_KEYS: usize = 8;

/// Writes `bytes` as `name` into `dir` and records its checksum.
pub fn put_file(dir: &std::path::Path, name: &str, bytes: &[u8], sums: &mut Checksums) -> Result<(), String> {
    let path = dir.join(name);
    std::fs::write(&path, bytes).map_err(|e| format!("{}: {e}", path.display()))?;
    sums.insert(name.to_string(), FileSum::of(bytes));
    Ok(())
}
