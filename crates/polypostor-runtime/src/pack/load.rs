//! Loading a pack, validating everything: a damaged or forged pack gives a clear error, never
//! a panic, a hang or an allocation beyond what the pack really holds (every number is
//! checked for range and finiteness, every size computed with checked arithmetic, every
//! file read is a regular file of the size and checksum the manifest lists, and the decoded
//! textures are bounded before anything is decoded).

use std::path::{Path, PathBuf};

use super::format::{Checksums, FORMAT_NAME, FORMAT_VERSION, Manifest, OLDEST_FORMAT_VERSION, PackCamera};
use crate::limits::{
    MAX_FPS, MAX_FRAMES, MAX_LOADED_TEXTURE_BYTES, MAX_PARTS, MAX_RESOLUTION, MAX_VIEWS, MIN_RESOLUTION,
};
use crate::texture::{BcFormat, CompressedImage};

/// Why a pack or representations folder could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum PackError {
    /// A file of the folder could not be opened or read (missing, no permission, an I/O
    /// failure).
    #[error("cannot read '{path}': {message}")]
    Io {
        /// The file that could not be read.
        path: PathBuf,
        /// The operating system's error text.
        message: String,
    },
    /// The manifest is not JSON, or lacks a field or has one of the wrong type.
    #[error("{file} is not a valid manifest: {message}")]
    Manifest {
        /// The manifest's file name (`manifest.json`, `representations.json`).
        file: &'static str,
        /// The JSON parser's error, with its line and column.
        message: String,
    },
    /// The manifest's `format` names another kind of file: the folder is not of the kind
    /// asked for.
    #[error("{file} is not a polypostor manifest (format '{found}')")]
    NotAPack {
        /// The manifest's file name.
        file: &'static str,
        /// The `format` string it holds.
        found: String,
    },
    /// The manifest was written by a newer build, in a format version this one cannot read.
    #[error("{file} has version {found}, newer than this build reads ({current})")]
    Version {
        /// The manifest's file name.
        file: &'static str,
        /// The version the manifest holds.
        found: u32,
        /// The only version this build reads.
        current: u32,
    },
    /// The manifest is of an older format version, which this build no longer reads: the
    /// folder has to be baked again.
    #[error("{file} has version {found}, older than this build reads ({current}): re-bake it")]
    OldVersion {
        /// The manifest's file name.
        file: &'static str,
        /// The version the manifest holds.
        found: u32,
        /// The only version this build reads.
        current: u32,
    },
    /// The message starts with the file it concerns.
    #[error("damaged {0}")]
    Damaged(String),
}

/// One view's data, checked.
#[derive(Debug)]
pub struct LoadedView {
    /// The decoded colour atlas ([`ManifestView::atlas`](crate::pack::ManifestView::atlas)),
    /// `atlas_size` pixels.
    pub atlas: image::RgbaImage,
    /// Half the atlas size in each direction.
    pub normals: image::RgbaImage,
    /// The colour atlas's BC7 blocks when the pack stores it so (`.ktx2`): what a renderer
    /// uploads where the adapter samples BC7; [`LoadedView::atlas`] is their decoding.
    pub atlas_blocks: Option<CompressedImage>,
    /// The normal atlas's BC7 blocks when the pack stores it so.
    pub normal_blocks: Option<CompressedImage>,
}

/// A validated pack in memory.
#[derive(Debug)]
pub struct LoadedPack {
    /// The manifest, every number, range and file name in it checked.
    pub manifest: Manifest,
    /// `vertices.bin` decoded to [0, 1], each block as UVs then positions frame by frame (2
    /// values per vertex; format 7's boxes and bytes decoded: the manifest's vertex offsets
    /// kept here point into this, not the file). See [`LoadedPack::part_vertices`] for
    /// view-plane positions.
    pub vertices: Vec<f32>,
    /// `indices.bin`: every key's triangles as u16 vertex numbers local to its block, each
    /// checked to be below the block's vertex count.
    pub indices: Vec<u16>,
    /// Each view's decoded atlases, indexed like the manifest's views.
    pub views: Vec<LoadedView>,
}

impl LoadedPack {
    /// The pack as the Polypostor renderer draws it ([`crate::gpu::GpuPolypostors::new`]):
    /// borrowed, nothing copied but the part tables.
    pub fn gpu_input(&self) -> crate::gpu::inputs::PolypostorInput<'_> {
        use crate::gpu::inputs::{KeyBlock, PolypostorInput, PolypostorPart, PolypostorView};
        let m = &self.manifest;
        let views = m
            .views
            .iter()
            .zip(&self.views)
            .map(|(v, loaded)| PolypostorView {
                frame: v.camera.view_frame(),
                atlas_size: v.atlas_size,
                order: &v.order,
                parts: v
                    .parts
                    .iter()
                    .map(|p| {
                        p.as_ref().map(|p| PolypostorPart {
                            keys: std::iter::once(KeyBlock {
                                vertex_offset: p.vertex_offset,
                                vertex_count: p.vertex_count,
                                index_offset: p.index_offset,
                                index_count: p.index_count,
                                coarse_index_offset: p.coarse_index_offset,
                                coarse_index_count: p.coarse_index_count,
                                frame_start: 0,
                                frame_count: m.frames.max(1),
                            })
                            .chain(p.extra_keys.iter().map(|k| KeyBlock {
                                vertex_offset: k.vertex_offset,
                                vertex_count: k.vertex_count,
                                index_offset: k.index_offset,
                                index_count: k.index_count,
                                coarse_index_offset: k.coarse_index_offset,
                                coarse_index_count: k.coarse_index_count,
                                frame_start: k.frame_start,
                                frame_count: k.frame_count,
                            }))
                            .collect(),
                            frame_keys: &p.frame_keys,
                        })
                    })
                    .collect(),
                atlas: &loaded.atlas,
                atlas_blocks: loaded.atlas_blocks.as_ref(),
                normals: &loaded.normals,
                normal_blocks: loaded.normal_blocks.as_ref(),
            })
            .collect();
        PolypostorInput {
            part_count: m.parts.len(),
            frames: m.frames,
            vertices: &self.vertices,
            indices: &self.indices,
            views,
        }
    }
}

/// Most bytes of `vertices.bin` + `indices.bin` a pack may declare.
pub const MAX_VERTEX_FILE_BYTES: u64 = 1 << 30;
/// Largest manifest read.
pub const MAX_MANIFEST_BYTES: u64 = 64 << 20;
/// Most vertices of one part in one view (the bake writes 3 to 40).
pub const MAX_PART_VERTICES: u32 = 1024;
/// Largest atlas side.
pub const MAX_ATLAS_SIDE: u32 = 16384;

/// Most texels a view's colour atlas of `keys` key images of `tile`² pixels may hold: the
/// packer's cut-outs, each at most the tile and its padding rounded up to the packer's cells
/// (a power of two, at most `tile / 64 + 2` texels) and the atlas's sides to whole blocks
/// (8 texels), laid in a grid with one row of them left over (`⌈√keys⌉` more: eleven whole
/// tiles within the loader's sides take a 4 × 3 grid, not one column of 11). The writer's own
/// packing (`polypostor::pack::atlas`) stays within it for every tile size (tested there, down
/// to key images covering their whole tiles).
pub fn atlas_area_bound(tile: u64, keys: u64) -> u64 {
    let side = tile.saturating_add(2 + 2 + 8).saturating_add(tile / 64);
    let keys = keys.max(1);
    let spare = (keys as f64).sqrt().ceil() as u64;
    side.saturating_mul(keys.saturating_add(spare).saturating_mul(side))
}

fn damaged(m: String) -> PackError {
    PackError::Damaged(m)
}

fn fs_error(e: crate::safe_fs::FsError) -> PackError {
    match e {
        crate::safe_fs::FsError::Io { path, message } => PackError::Io { path, message },
        other => PackError::Damaged(other.to_string()),
    }
}

/// A file name inside the pack folder (no paths, no parent references).
pub(crate) fn member(dir: &Path, name: &str) -> Result<PathBuf, PackError> {
    if name.is_empty()
        || name.contains('/')
        || name.contains('\\')
        || name == ".."
        || name == "."
        || name.contains('\0')
    {
        return Err(damaged(format!(
            "file name '{name}' is not a plain name in the pack folder"
        )));
    }
    Ok(dir.join(name))
}

/// Parses a manifest: its format and version first (so an old or foreign file is named as
/// such, not as a parse error), then the whole of it.
pub(crate) fn parse_manifest<T: serde::de::DeserializeOwned>(
    dir: &Path,
    file: &'static str,
    format: &str,
    versions: std::ops::RangeInclusive<u32>,
) -> Result<T, PackError> {
    let version = *versions.end();
    let bytes = crate::safe_fs::read_regular(&dir.join(file), MAX_MANIFEST_BYTES, "a manifest").map_err(fs_error)?;
    #[derive(serde::Deserialize)]
    struct Head {
        format: String,
        version: u32,
    }
    let bad = |e: serde_json::Error| PackError::Manifest {
        file,
        message: e.to_string(),
    };
    let head: Head = serde_json::from_slice(&bytes).map_err(bad)?;
    if head.format != format {
        return Err(PackError::NotAPack {
            file,
            found: head.format,
        });
    }
    if head.version > version {
        return Err(PackError::Version {
            file,
            found: head.version,
            current: version,
        });
    }
    if head.version < *versions.start() {
        return Err(PackError::OldVersion {
            file,
            found: head.version,
            current: version,
        });
    }
    serde_json::from_slice(&bytes).map_err(bad)
}

/// Frame rate, frame count and key frame of a manifest.
pub(crate) fn check_timing(file: &str, fps: f32, frames: u32, key_frame: u32) -> Result<(), PackError> {
    if frames == 0 || frames as usize > MAX_FRAMES {
        return Err(damaged(format!(
            "{file}: frame count {frames} is out of range (1 to {MAX_FRAMES})"
        )));
    }
    if key_frame >= frames {
        return Err(damaged(format!(
            "{file}: key frame {key_frame} is not below the frame count {frames}"
        )));
    }
    if !(fps.is_finite() && fps >= crate::limits::MIN_FPS && fps <= MAX_FPS) {
        return Err(damaged(format!(
            "{file}: frame rate {fps} is out of range ({} to {MAX_FPS})",
            crate::limits::MIN_FPS
        )));
    }
    Ok(())
}

/// Resolution and view count of a manifest.
pub(crate) fn check_resolution_views(file: &str, resolution: u32, views: usize) -> Result<(), PackError> {
    if !(MIN_RESOLUTION..=MAX_RESOLUTION).contains(&resolution) {
        return Err(damaged(format!(
            "{file}: resolution {resolution} is out of range ({MIN_RESOLUTION} to {MAX_RESOLUTION})"
        )));
    }
    if views == 0 || views > MAX_VIEWS {
        return Err(damaged(format!(
            "{file}: {views} views, out of range (1 to {MAX_VIEWS})"
        )));
    }
    Ok(())
}

fn unit(v: [f32; 3]) -> bool {
    v.iter().all(|x| x.is_finite()) && (glam::Vec3::from(v).length() - 1.0).abs() < 1e-3
}

/// A view direction: a finite unit vector.
pub(crate) fn check_direction(what: &str, d: [f32; 3]) -> Result<(), PackError> {
    if !unit(d) {
        return Err(damaged(format!("{what}: direction {d:?} is not a unit vector")));
    }
    Ok(())
}

/// An orthographic view camera: finite, an orthonormal frame whose forward axis is the view
/// direction, a positive finite half size.
pub(crate) fn check_camera(what: &str, cam: &PackCamera, direction: [f32; 3]) -> Result<(), PackError> {
    let bad = |why: &str| damaged(format!("{what}: camera {why}"));
    if !cam.center.iter().all(|x| x.is_finite() && x.abs() < 1e12) {
        return Err(bad("centre is not a finite point"));
    }
    if !(unit(cam.right) && unit(cam.up) && unit(cam.forward)) {
        return Err(bad("axes are not unit vectors"));
    }
    let (r, u, f) = (
        glam::Vec3::from(cam.right),
        glam::Vec3::from(cam.up),
        glam::Vec3::from(cam.forward),
    );
    if r.dot(u).abs() > 1e-3 || r.dot(f).abs() > 1e-3 || u.dot(f).abs() > 1e-3 {
        return Err(bad("axes are not perpendicular"));
    }
    if (r.cross(u) - f).length() > 1e-3 {
        return Err(bad("axes are not a right-handed frame"));
    }
    if (f - glam::Vec3::from(direction)).length() > 1e-3 {
        return Err(bad("does not look along the view direction"));
    }
    if !(cam.half_size.is_finite() && cam.half_size > 1e-9 && cam.half_size < 1e12) {
        return Err(bad(&format!(
            "half size {:e} is out of range (above 1e-9 and below 1e12 scene units)",
            cam.half_size
        )));
    }
    Ok(())
}

/// Reads the data files of a pack or representations folder: plain names listed in the
/// manifest's checksums, regular files of exactly the listed size and checksum.
pub(crate) struct FolderReader<'a> {
    pub dir: &'a Path,
    pub manifest_file: &'static str,
    pub checksums: &'a Checksums,
}

impl FolderReader<'_> {
    /// The bytes of `name`, checked against its size and checksum.
    pub fn read(&self, name: &str) -> Result<Vec<u8>, PackError> {
        let path = member(self.dir, name)?;
        let sum = self.checksums.get(name).ok_or_else(|| {
            damaged(format!(
                "{}: no checksum listed for {name} (every data file must be)",
                self.manifest_file
            ))
        })?;
        let bytes =
            crate::safe_fs::read_regular(&path, sum.bytes, "this file (the size its manifest lists)").map_err(|e| {
                match e {
                    crate::safe_fs::FsError::TooLarge { len, .. } => damaged(format!(
                        "{name} is {len} bytes, {} says {}",
                        self.manifest_file, sum.bytes
                    )),
                    other => fs_error(other),
                }
            })?;
        if bytes.len() as u64 != sum.bytes {
            return Err(damaged(format!(
                "{name} is {} bytes, {} says {}",
                bytes.len(),
                self.manifest_file,
                sum.bytes
            )));
        }
        if crc32fast::hash(&bytes) != sum.crc32 {
            return Err(damaged(format!(
                "{name}: its content does not match the checksum in {} (the file is damaged; re-bake)",
                self.manifest_file
            )));
        }
        Ok(bytes)
    }

    /// Reads the texture `name`: a KTX2 file of BC7 blocks (`.ktx2`, in `format`; decoded to
    /// RGBA8 too, the blocks kept for adapters that sample BC7) or a PNG. Its size is checked
    /// against `size` before anything is decoded.
    pub fn texture(
        &self,
        name: &str,
        size: [u32; 2],
        format: BcFormat,
    ) -> Result<(image::RgbaImage, Option<CompressedImage>), PackError> {
        if name.ends_with(".ktx2") {
            let bytes = self.read(name)?;
            let c = crate::texture::read_ktx2(name, &bytes, size, format).map_err(damaged)?;
            Ok((c.decode(), Some(c)))
        } else {
            Ok((self.png(name, size)?, None))
        }
    }

    /// Decodes the PNG `name` and checks its size against `size` before decoding.
    pub fn png(&self, name: &str, size: [u32; 2]) -> Result<image::RgbaImage, PackError> {
        let bytes = self.read(name)?;
        decode_png(name, &bytes, size)
    }
}

/// Decodes PNG bytes that must hold an image of `size`; the header is checked before any
/// pixel is decoded.
pub(crate) fn decode_png(name: &str, bytes: &[u8], size: [u32; 2]) -> Result<image::RgbaImage, PackError> {
    let reader = || image::ImageReader::with_format(std::io::Cursor::new(bytes), image::ImageFormat::Png);
    let (w, h) = reader()
        .into_dimensions()
        .map_err(|e| damaged(format!("{name}: {e}")))?;
    if [w, h] != size {
        return Err(damaged(format!(
            "{name}: {w}×{h} pixels, the manifest says {}×{}",
            size[0], size[1]
        )));
    }
    let mut r = reader();
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(size[0]);
    limits.max_image_height = Some(size[1]);
    // RGBA16 at most, plus the RGBA8 copy.
    limits.max_alloc = Some(u64::from(w) * u64::from(h) * 8 + (1 << 20));
    r.limits(limits);
    let img = r.decode().map_err(|e| damaged(format!("{name}: {e}")))?.to_rgba8();
    Ok(img)
}

/// Checks that decoding images of these sizes stays within [`MAX_LOADED_TEXTURE_BYTES`].
pub(crate) fn check_texture_budget(file: &str, sizes: impl Iterator<Item = [u32; 2]>) -> Result<(), PackError> {
    let mut total = 0u64;
    for [w, h] in sizes {
        total = total.saturating_add(u64::from(w).saturating_mul(u64::from(h)).saturating_mul(4));
    }
    if total > MAX_LOADED_TEXTURE_BYTES {
        return Err(damaged(format!(
            "{file}: its textures would take {} decoded, more than the limit of {}",
            crate::limits::human_bytes(total),
            crate::limits::human_bytes(MAX_LOADED_TEXTURE_BYTES)
        )));
    }
    Ok(())
}

/// One key's vertex, index and atlas ranges, checked against the data they point into.
struct KeyBlock {
    vertex_offset: u64,
    vertex_count: u32,
    index_offset: u64,
    index_count: u32,
    coarse: (u64, u32),
    atlas_rect: [u32; 4],
    /// Frames of positions the block holds.
    frames: u64,
}

impl KeyBlock {
    fn check(
        &self,
        w: &str,
        version: u32,
        vertex_values: u64,
        index_values: u64,
        [aw, ah]: [u32; 2],
    ) -> Result<(), PackError> {
        let vc = u64::from(self.vertex_count);
        if vc < 3 || self.vertex_count > MAX_PART_VERTICES || self.index_count == 0 || self.index_count % 3 != 0 {
            return Err(damaged(format!("{w}: {vc} vertices and {} indices", self.index_count)));
        }
        let end = block_values(version, vc, self.frames)
            .and_then(|n| self.vertex_offset.checked_add(n))
            .ok_or_else(|| damaged(format!("{w}: vertex range overflows")))?;
        if end > vertex_values {
            return Err(damaged(format!(
                "{w}: vertices {}..{end} lie past the end of the vertex data ({vertex_values})",
                self.vertex_offset
            )));
        }
        let iend = self
            .index_offset
            .checked_add(u64::from(self.index_count))
            .ok_or_else(|| damaged(format!("{w}: index range overflows")))?;
        if iend > index_values {
            return Err(damaged(format!(
                "{w}: indices {}..{iend} lie past the end of the index data ({index_values})",
                self.index_offset
            )));
        }
        let (coarse_offset, coarse_count) = self.coarse;
        let cend = coarse_offset
            .checked_add(u64::from(coarse_count))
            .ok_or_else(|| damaged(format!("{w}: coarse index range overflows")))?;
        if coarse_count % 3 != 0 || (coarse_count > 0 && cend > index_values) {
            return Err(damaged(format!(
                "{w}: coarse indices {coarse_offset}..{cend} are not whole triangles inside the index data ({index_values})"
            )));
        }
        let [x, y, rw, rh] = self.atlas_rect;
        if rw == 0
            || rh == 0
            || u64::from(x) + u64::from(rw) > u64::from(aw)
            || u64::from(y) + u64::from(rh) > u64::from(ah)
        {
            return Err(damaged(format!(
                "{w}: atlas rectangle {:?} lies outside the {aw}×{ah} atlas",
                self.atlas_rect
            )));
        }
        Ok(())
    }
}

/// u16 values of a vertex block of `vc` vertices and `frames` frames of positions in a pack
/// of format `version` ([`Manifest`]'s `vertex_offset` docs).
fn block_values(version: u32, vc: u64, frames: u64) -> Option<u64> {
    if version >= 7 {
        vc.checked_mul(2)?.checked_add(4)?.checked_add(vc.checked_mul(frames)?)
    } else {
        vc.checked_mul(2)?.checked_mul(frames.checked_add(1)?)
    }
}

/// Decodes one format-7 vertex block (UVs, box, byte positions) from `words` at `offset`,
/// appending UVs then positions as values in [0, 1] to `out` (the layout
/// [`LoadedPack::vertices`] holds); returns where it starts in `out`.
fn decode_block(
    words: &[u16],
    what: &str,
    (offset, vc, frames): (u64, u32, u64),
    out: &mut Vec<f32>,
) -> Result<u64, PackError> {
    let vc = u64::from(vc);
    let n = block_values(7, vc, frames).ok_or_else(|| damaged(format!("{what}: vertex range overflows")))?;
    // In range: KeyBlock::check ran on every block.
    let w = &words[offset as usize..(offset + n) as usize];
    let uv = 2 * vc as usize;
    let start = out.len() as u64;
    out.extend(w[..uv].iter().map(|&x| f32::from(x) / 65535.0));
    let words4 = [w[uv], w[uv + 1], w[uv + 2], w[uv + 3]];
    let bx = crate::quant::PositionBox::from_words(words4).ok_or_else(|| {
        damaged(format!(
            "{what}: position box {words4:?} is empty or runs past the view"
        ))
    })?;
    for slot in &w[uv + 4..] {
        let [x, y] = slot.to_le_bytes();
        out.push(bx.value(0, x));
        out.push(bx.value(1, y));
    }
    Ok(start)
}

/// Loads the pack in the folder `dir`: `manifest.json` and every file it names, validating
/// all of it before anything is decoded (see the module docs). A damaged, forged, foreign or
/// old pack gives a [`PackError`] naming the file and the fault.
pub fn load_pack(dir: &Path) -> Result<LoadedPack, PackError> {
    const FILE: &str = "manifest.json";
    let mut manifest: Manifest = parse_manifest(dir, FILE, FORMAT_NAME, OLDEST_FORMAT_VERSION..=FORMAT_VERSION)?;
    check_timing(FILE, manifest.fps, manifest.frames, manifest.key_frame)?;
    crate::timeline::printable_names(&mut manifest.clips);
    crate::timeline::validate(&manifest.clips, manifest.frames as usize)
        .map_err(|e| damaged(format!("{FILE}: {e}")))?;
    check_resolution_views(FILE, manifest.resolution, manifest.views.len())?;
    let parts = manifest.parts.len();
    if parts == 0 || parts > MAX_PARTS {
        return Err(damaged(format!(
            "{FILE}: {parts} parts, out of range (1 to {MAX_PARTS})"
        )));
    }
    if manifest.vertex_bytes.saturating_add(manifest.index_bytes) > MAX_VERTEX_FILE_BYTES {
        return Err(damaged(format!(
            "{FILE}: {} bytes of vertex and index data, more than the limit of {}",
            manifest.vertex_bytes.saturating_add(manifest.index_bytes),
            crate::limits::human_bytes(MAX_VERTEX_FILE_BYTES)
        )));
    }
    if manifest.vertex_bytes % 2 != 0 || manifest.index_bytes % 2 != 0 {
        return Err(damaged(format!(
            "{FILE}: vertex and index data must be whole 16-bit values"
        )));
    }
    let frames = u64::from(manifest.frames);
    let vertex_values = manifest.vertex_bytes / 2;
    let index_values = manifest.index_bytes / 2;
    let r = u64::from(manifest.resolution);
    let mut names = std::collections::BTreeSet::new();
    // Everything the manifest says is checked before any data file is read.
    for (v, view) in manifest.views.iter().enumerate() {
        let what = format!("{FILE}: view {v}");
        check_direction(&what, view.direction)?;
        check_camera(&what, &view.camera, view.direction)?;
        if view.parts.len() != parts {
            return Err(damaged(format!(
                "{what}: {} part entries for {parts} parts",
                view.parts.len()
            )));
        }
        if !crate::pack::valid_order(&view.order.iter().map(|&o| o as usize).collect::<Vec<_>>(), parts) {
            return Err(damaged(format!(
                "{what}: drawing order {:?} is not a permutation of the {parts} parts",
                view.order
            )));
        }
        for name in [&view.atlas, &view.normal_atlas] {
            member(dir, name)?;
            let ktx2 = name.ends_with(".ktx2");
            if !(name.ends_with(".png") || (ktx2 && manifest.version >= 6)) {
                return Err(damaged(format!(
                    "{what}: the texture {name} is neither a PNG nor (format 6 on) a KTX2 file"
                )));
            }
            if ktx2 && !(view.atlas_size[0].is_multiple_of(8) && view.atlas_size[1].is_multiple_of(8)) {
                return Err(damaged(format!(
                    "{what}: a {}×{} atlas in KTX2 files: BC7 atlases are multiples of 8 texels a side",
                    view.atlas_size[0], view.atlas_size[1]
                )));
            }
            if !names.insert(name.clone()) {
                return Err(damaged(format!("{what}: the file {name} is named twice")));
            }
        }
        let [aw, ah] = view.atlas_size;
        let present = view
            .parts
            .iter()
            .flatten()
            .map(|p| 1 + p.extra_keys.len())
            .sum::<usize>()
            .max(1) as u64;
        let most = atlas_area_bound(r, present);
        if aw < 2
            || ah < 2
            || aw > MAX_ATLAS_SIDE
            || ah > MAX_ATLAS_SIDE
            || aw % 2 != 0
            || ah % 2 != 0
            || u64::from(aw) * u64::from(ah) > most
        {
            return Err(damaged(format!(
                "{what}: atlas size {aw}×{ah} is not valid for {present} parts of {r}² pixels"
            )));
        }
        for (p, part) in view.parts.iter().enumerate() {
            let Some(part) = part else { continue };
            let w = format!("{what} part {p}");
            if u64::from(part.key_frame) >= frames {
                return Err(damaged(format!(
                    "{w}: key frame {} is past the {frames} frames",
                    part.key_frame
                )));
            }
            let first = KeyBlock {
                vertex_offset: part.vertex_offset,
                vertex_count: part.vertex_count,
                index_offset: part.index_offset,
                index_count: part.index_count,
                coarse: (part.coarse_index_offset, part.coarse_index_count),
                atlas_rect: part.atlas_rect,
                frames,
            };
            first.check(&w, manifest.version, vertex_values, index_values, [aw, ah])?;
            if part.extra_keys.len() + 1 > crate::pack::MAX_KEYS {
                return Err(damaged(format!(
                    "{w}: {} key images, more than {}",
                    part.extra_keys.len() + 1,
                    crate::pack::MAX_KEYS
                )));
            }
            if part.extra_keys.is_empty() != part.frame_keys.is_empty() {
                return Err(damaged(format!(
                    "{w}: {} extra keys but {} frame keys",
                    part.extra_keys.len(),
                    part.frame_keys.len()
                )));
            }
            if !part.frame_keys.is_empty() && part.frame_keys.len() as u64 != frames {
                return Err(damaged(format!(
                    "{w}: {} frame keys for {frames} frames",
                    part.frame_keys.len()
                )));
            }
            for (k, key) in part.extra_keys.iter().enumerate() {
                let wk = format!("{w} key {}", k + 1);
                if u64::from(key.key_frame) >= frames
                    || u64::from(key.frame_start) >= frames
                    || key.frame_count == 0
                    || u64::from(key.frame_count) > frames
                {
                    return Err(damaged(format!(
                        "{wk}: key frame {}, frames {} from {} do not fit the {frames} frames",
                        key.key_frame, key.frame_count, key.frame_start
                    )));
                }
                KeyBlock {
                    vertex_offset: key.vertex_offset,
                    vertex_count: key.vertex_count,
                    index_offset: key.index_offset,
                    index_count: key.index_count,
                    coarse: (key.coarse_index_offset, key.coarse_index_count),
                    atlas_rect: key.atlas_rect,
                    frames: u64::from(key.frame_count),
                }
                .check(&wk, manifest.version, vertex_values, index_values, [aw, ah])?;
            }
            for (f, &k) in part.frame_keys.iter().enumerate() {
                let k = k as usize;
                if k > part.extra_keys.len() {
                    return Err(damaged(format!("{w}: frame {f} names key {k}, which it does not have")));
                }
                if k > 0 {
                    // The run time interpolates each frame's polygon towards both neighbours in
                    // its clip.
                    let key = &part.extra_keys[k - 1];
                    let inside =
                        |g: u64| (g + frames - u64::from(key.frame_start)) % frames < u64::from(key.frame_count);
                    let (next, prev) = (
                        crate::timeline::next_frame(&manifest.clips, f) as u64,
                        crate::timeline::prev_frame(&manifest.clips, f) as u64,
                    );
                    let f = f as u64;
                    if !inside(f) || !inside(next) || !inside(prev) {
                        return Err(damaged(format!(
                            "{w}: frame {f} is drawn from key {k}, whose polygon does not cover it and both its neighbours"
                        )));
                    }
                }
            }
        }
    }
    check_texture_budget(
        FILE,
        manifest
            .views
            .iter()
            .flat_map(|v| [v.atlas_size, [v.atlas_size[0] / 2, v.atlas_size[1] / 2]]),
    )?;
    let checksums = manifest.checksums.clone();
    let files = FolderReader {
        dir,
        manifest_file: FILE,
        checksums: &checksums,
    };
    for name in [&manifest.vertex_file, &manifest.index_file] {
        member(dir, name)?;
    }
    if manifest.vertex_file == manifest.index_file {
        return Err(damaged(format!("{FILE}: vertices and indices name the same file")));
    }
    let vbytes = files.read(&manifest.vertex_file)?;
    let ibytes = files.read(&manifest.index_file)?;
    for (name, got, want) in [
        (&manifest.vertex_file, vbytes.len() as u64, manifest.vertex_bytes),
        (&manifest.index_file, ibytes.len() as u64, manifest.index_bytes),
    ] {
        if got != want {
            return Err(damaged(format!("{name} has {got} bytes, {FILE} says {want}")));
        }
    }
    let words: Vec<u16> = vbytes
        .chunks_exact(2)
        .map(|b| u16::from_le_bytes([b[0], b[1]]))
        .collect();
    let mut manifest = manifest;
    let vertices: Vec<f32> = if manifest.version >= 7 {
        // Every block decoded into the format-6 layout; the offsets kept in memory point there.
        // Blocks may not share values: decoding one value many times would multiply the
        // memory a small file asks for.
        let frames = u64::from(manifest.frames);
        let name = manifest.vertex_file.clone();
        let mut ranges: Vec<(u64, u64)> = Vec::new();
        for part in manifest.views.iter().flat_map(|v| v.parts.iter().flatten()) {
            let blocks = std::iter::once((part.vertex_offset, part.vertex_count, frames)).chain(
                part.extra_keys
                    .iter()
                    .map(|k| (k.vertex_offset, k.vertex_count, u64::from(k.frame_count))),
            );
            for (offset, vc, f) in blocks {
                let n = block_values(7, u64::from(vc), f).unwrap_or(u64::MAX);
                ranges.push((offset, offset.saturating_add(n)));
            }
        }
        ranges.sort_unstable();
        if let Some(w) = ranges.windows(2).find(|w| w[1].0 < w[0].1) {
            return Err(damaged(format!(
                "{name}: vertex blocks overlap (values {}..{} and {}..{})",
                w[0].0, w[0].1, w[1].0, w[1].1
            )));
        }
        let mut out = Vec::new();
        for (v, view) in manifest.views.iter_mut().enumerate() {
            for (p, part) in view.parts.iter_mut().enumerate() {
                let Some(part) = part else { continue };
                let what = format!("{name}: view {v} part {p}");
                part.vertex_offset =
                    decode_block(&words, &what, (part.vertex_offset, part.vertex_count, frames), &mut out)?;
                for (k, key) in part.extra_keys.iter_mut().enumerate() {
                    let block = (key.vertex_offset, key.vertex_count, u64::from(key.frame_count));
                    let what = format!("{what} key {}", k + 1);
                    key.vertex_offset = decode_block(&words, &what, block, &mut out)?;
                }
            }
        }
        out
    } else {
        words.iter().map(|&x| f32::from(x) / 65535.0).collect()
    };
    let indices: Vec<u16> = ibytes
        .chunks_exact(2)
        .map(|b| u16::from_le_bytes([b[0], b[1]]))
        .collect();
    for (v, view) in manifest.views.iter().enumerate() {
        for (p, part) in view.parts.iter().enumerate() {
            let Some(part) = part else { continue };
            let blocks = [
                (part.index_offset, part.index_count, part.vertex_count),
                (part.coarse_index_offset, part.coarse_index_count, part.vertex_count),
            ]
            .into_iter()
            .chain(part.extra_keys.iter().flat_map(|k| {
                [
                    (k.index_offset, k.index_count, k.vertex_count),
                    (k.coarse_index_offset, k.coarse_index_count, k.vertex_count),
                ]
            }));
            for (offset, count, vc) in blocks.filter(|b| b.1 > 0) {
                let range = offset as usize..(offset + u64::from(count)) as usize;
                if let Some(bad) = indices[range].iter().find(|&&i| u32::from(i) >= vc) {
                    return Err(damaged(format!(
                        "{}: view {v} part {p}: index {bad} refers past its {vc} vertices",
                        manifest.index_file
                    )));
                }
            }
        }
    }
    let mut views = Vec::with_capacity(manifest.views.len());
    for view in &manifest.views {
        let [aw, ah] = view.atlas_size;
        let (atlas, atlas_blocks) = files.texture(&view.atlas, [aw, ah], BcFormat::Bc7Srgb)?;
        let (normals, normal_blocks) = files.texture(&view.normal_atlas, [aw / 2, ah / 2], BcFormat::Bc7Unorm)?;
        views.push(LoadedView {
            atlas,
            normals,
            atlas_blocks,
            normal_blocks,
        });
    }
    Ok(LoadedPack {
        manifest,
        vertices,
        indices,
        views,
    })
}

impl LoadedPack {
    /// As [`LoadedPack::part_vertices`] for the part's key image `key` (0 its first, `k` its
    /// `extra_keys[k - 1]`); `None` where that key's polygon was not fitted to `frame`.
    pub fn key_vertices(&self, v: usize, p: usize, key: usize, frame: usize) -> Option<(Vec<f32>, Vec<f32>)> {
        if key == 0 {
            return self.part_vertices(v, p, frame);
        }
        let part = self.manifest.views.get(v)?.parts.get(p)?.as_ref()?;
        let k = part.extra_keys.get(key - 1)?;
        let frames = self.manifest.frames as usize;
        let g = (frame + frames - k.frame_start as usize % frames.max(1)) % frames.max(1);
        if frame >= frames || g >= k.frame_count as usize {
            return None;
        }
        let vc = k.vertex_count as usize;
        let base = k.vertex_offset as usize;
        let uv = self.vertices.get(base..base + vc * 2)?;
        let start = base + vc * 2 * (1 + g);
        let pos = self.vertices.get(start..start + vc * 2)?;
        Some((uv.to_vec(), pos.iter().map(|x| x * 2.0 - 1.0).collect()))
    }

    /// Part `p` of view `v` from its first key image: its UVs (atlas-normalised) and its
    /// positions at `frame` (view-plane coordinates in [-1, 1]), as interleaved x, y values.
    /// A frame past the end gives the last frame; `None` where the view or part does not
    /// exist or the part is not drawn in that view.
    pub fn part_vertices(&self, v: usize, p: usize, frame: usize) -> Option<(Vec<f32>, Vec<f32>)> {
        let part = self.manifest.views.get(v)?.parts.get(p)?.as_ref()?;
        let vc = part.vertex_count as usize;
        let base = part.vertex_offset as usize;
        let uv = self.vertices.get(base..base + vc * 2)?;
        let start = base + vc * 2 * (1 + frame.min(self.manifest.frames as usize - 1));
        let pos = self.vertices.get(start..start + vc * 2)?;
        Some((uv.to_vec(), pos.iter().map(|x| x * 2.0 - 1.0).collect()))
    }
}
/// `order` if it lists every part of `0..parts` exactly once.
pub fn valid_order(order: &[usize], parts: usize) -> bool {
    let mut seen = vec![false; parts];
    order.len() == parts
        && order
            .iter()
            .all(|&p| p < parts && !std::mem::replace(&mut seen[p], true))
}
