//! The representations the Polypostor is measured against, baked with the same views,
//! resolution and frame rate so every comparison is fair (Polypostor paper section 4; the
//! NP3D paper; `../shared/DESIGN.md` "Run time"):
//!
//! - **classic animated impostors**: per view, one colour and one normal image per frame,
//!   tiled into one sheet per view;
//! - **NP3D impostors**: the mesh simplified once (about 400 triangles, meshoptimizer) and
//!   skinned to every frame (so consecutive frames share their topology and can be
//!   interpolated), textured by projecting per-view key-frame images onto it;
//! - **rigid meshes**: the full mesh pre-skinned at every frame (positions + normals).
//!
//! GPU-skinned meshes need nothing baked: they read the character itself.
//!
//! On disk, beside a pack or alone: `representations.json` ([`RepsManifest`]) plus
//! `impostor_color_NNN.png` / `impostor_normal_NNN.png` per view, `np3d.bin` and
//! `np3d_color.png`, and `rigid.bin` (little-endian throughout).

use std::path::Path;

use serde::{Deserialize, Serialize};

pub use crate::gpu::inputs::{FrameVertices, ImpostorData, Np3dData, ViewFrame};
use crate::pack::{PackCamera, PackError};

/// File name of the manifest of a representations folder ([`RepsManifest`]).
pub use crate::limits::REPS_FILE;
/// The [`RepsManifest::format`] of every representations manifest; a manifest with another
/// is refused.
pub use crate::limits::REPS_FORMAT_NAME as REPS_FORMAT;
/// Version 2 added [`RepsManifest::checksums`], version 3 the clip table ([`RepsManifest::clips`]),
/// version 4 the far impostors ([`RepsManifest::far_impostor`]), version 5 BC7 colour sheets
/// in KTX2 files (`impostor_color_NNN.ktx2`), version 6 BC7 normal sheets
/// (`impostor_normal_NNN.ktx2`, opaque) with the body parts beside them
/// (`impostor_part_NNN.png`, one grey level per part) and NP3D's key images in BC7
/// (`np3d_color.ktx2`); versions 4 and 5 are read as they are; older folders are refused with "re-bake".
pub const REPS_VERSION: u32 = 6;
/// The oldest representations version this build reads (4: the same, every sheet PNG).
pub const OLDEST_REPS_VERSION: u32 = 4;

/// Which representations a bake produces.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct RepSet {
    /// The Polypostor pack.
    pub polypostor: bool,
    /// Classic animated impostor sheets (with their far sheets).
    pub impostor: bool,
    /// NP3D impostors.
    pub np3d: bool,
    /// Rigid meshes, the full mesh pre-skinned at every frame.
    pub rigid: bool,
}

impl RepSet {
    /// Every representation.
    pub const ALL: RepSet = RepSet {
        polypostor: true,
        impostor: true,
        np3d: true,
        rigid: true,
    };
    /// The Polypostor pack alone.
    pub const POLYPOSTOR: RepSet = RepSet {
        polypostor: true,
        impostor: false,
        np3d: false,
        rigid: false,
    };

    /// Parses `polypostor|impostor|np3d|rigid|all`, comma-separated.
    pub fn parse(text: &str) -> Result<Self, String> {
        let mut set = RepSet::default();
        for word in text.split(',').map(str::trim).filter(|w| !w.is_empty()) {
            match word.to_ascii_lowercase().as_str() {
                "polypostor" => set.polypostor = true,
                "impostor" => set.impostor = true,
                "np3d" => set.np3d = true,
                "rigid" => set.rigid = true,
                "all" => set = RepSet::ALL,
                other => {
                    return Err(format!(
                        "unknown representation '{other}' (choose from polypostor, impostor, np3d, rigid, all)"
                    ));
                }
            }
        }
        if set == RepSet::default() {
            return Err("no representation given (choose from polypostor, impostor, np3d, rigid, all)".into());
        }
        Ok(set)
    }

    /// The set as [`RepSet::parse`] reads it: `all`, or the names comma-separated
    /// (`polypostor,np3d`); `polypostor` for the empty set, which parse refuses.
    pub fn words(&self) -> String {
        if *self == RepSet::ALL {
            return "all".into();
        }
        let names: Vec<&str> = [
            (self.polypostor, "polypostor"),
            (self.impostor, "impostor"),
            (self.np3d, "np3d"),
            (self.rigid, "rigid"),
        ]
        .into_iter()
        .filter_map(|(on, name)| on.then_some(name))
        .collect();
        if names.is_empty() {
            "polypostor".into()
        } else {
            names.join(",")
        }
    }

    /// Anything besides the Polypostor pack.
    pub fn any_other(&self) -> bool {
        self.impostor || self.np3d || self.rigid
    }
}

/// One view, as in the pack (same direction, same orthographic camera).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RepView {
    /// Unit direction from the character towards the camera.
    pub direction: [f32; 3],
    /// The orthographic camera the view's images were rendered with.
    pub camera: PackCamera,
}

/// Classic animated impostors: per view a colour and a normal sheet of `columns × rows`
/// tiles of `resolution²` pixels, frame `f` at column `f % columns`, row `f / columns`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ImpostorInfo {
    /// Tiles per row of each sheet.
    pub columns: u32,
    /// Rows of tiles: enough for every frame, with no row left empty.
    pub rows: u32,
}

/// The far impostors the three-level mix draws its distant characters with, baked beside the
/// full sheets: `far_impostor_color_NNN.png` at `1 / color_factor` of the resolution and
/// `far_impostor_normal_NNN.png` at `1 / normal_factor`, `columns × rows` tiles holding the
/// timeline frames `frames` (all of them, or every other frame of each clip for a timeline
/// of more than [`FAR_HALF_RATE_ABOVE`] frames, [`far_frames`]). The factors come from the
/// switch distance ([`far_factor`]): impostors are drawn below a quarter of a screen pixel
/// per baked texel, so a quarter of the texels still gives one texel a pixel.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FarImpostorInfo {
    /// Tiles per row of each far sheet.
    pub columns: u32,
    /// Rows of tiles: enough for `frames`, with no row left empty.
    pub rows: u32,
    /// How many times smaller the colour tiles are than `resolution` on each side: a power
    /// of two that divides it (tiles of `resolution / color_factor` texels per side).
    pub color_factor: u32,
    /// As `color_factor`, for the normal sheets (`color_factor` or twice it).
    pub normal_factor: u32,
    /// The timeline frame each tile holds, tile by tile: every frame, or the ones
    /// [`far_frames`] keeps.
    pub frames: Vec<u32>,
}

/// NP3D impostors: `np3d.bin` holds `index_count` u16 indices, then `vertex_count` u32
/// source vertex numbers (which character vertex each one is), then per frame
/// `vertex_count` × (position xyz f32, normal xyz f32); `np3d_color.png` tiles one
/// key-frame colour image per view (`columns` per row, `resolution²` each).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Np3dInfo {
    /// Vertices of the simplified mesh (3 to 65535: the indices are u16).
    pub vertex_count: u32,
    /// Indices of its triangles, three per triangle.
    pub index_count: u32,
    /// Key-frame images per row of `np3d_color.png` (1 to the number of views).
    pub columns: u32,
}

/// Rigid meshes: `rigid.bin` holds per frame `vertex_count` × (position xyz f32, normal xyz
/// f32) of the character's full mesh, pre-skinned.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RigidInfo {
    /// Vertices of the character's full mesh, stored once per frame (at least 3).
    pub vertex_count: u32,
}

/// `representations.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RepsManifest {
    /// Always [`REPS_FORMAT`].
    pub format: String,
    /// The format version the folder was written in; this build reads [`OLDEST_REPS_VERSION`] to [`REPS_VERSION`].
    pub version: u32,
    /// Name of the character baked.
    pub character: String,
    /// The glTF the representations were baked from (meshes draw from it).
    pub character_path: Option<String>,
    /// Which of that file's axes the bake read as up (absent: glTF's +y).
    #[serde(default, skip_serializing_if = "crate::character::UpAxis::is_default")]
    pub character_up: crate::character::UpAxis,
    /// The first clip's name (`None`: the rest pose).
    pub clip: Option<String>,
    /// Frames per second every clip was sampled at, as in the pack.
    pub fps: f32,
    /// Frames of every clip together.
    pub frames: u32,
    /// The clips one after another ([`crate::timeline`]), as in the pack.
    pub clips: Vec<crate::timeline::ClipSpan>,
    /// The texture key-frame (NP3D images; the pack's key frame when one was baked).
    pub key_frame: u32,
    /// Pixels per side of each square image baked: every full impostor tile and every NP3D
    /// key-frame image ([`crate::limits::MIN_RESOLUTION`] to
    /// [`crate::limits::MAX_RESOLUTION`]).
    pub resolution: u32,
    /// The baked viewpoints; every per-view file and image is in this order.
    pub views: Vec<RepView>,
    /// The classic impostor sheets' layout (`None`: not baked).
    pub impostor: Option<ImpostorInfo>,
    /// Present whenever `impostor` is.
    #[serde(default)]
    pub far_impostor: Option<FarImpostorInfo>,
    /// The NP3D mesh and image sheet layout (`None`: not baked).
    pub np3d: Option<Np3dInfo>,
    /// The rigid meshes' layout (`None`: not baked).
    pub rigid: Option<RigidInfo>,
    /// Size and CRC-32 of every data file (filled in by [`write_representations`]); the
    /// loader reads nothing that is not listed here.
    #[serde(default)]
    pub checksums: crate::pack::Checksums,
}

impl FrameVertices {
    /// Frames held: `positions.len() / vertex_count` (the positions' count for a mesh of no
    /// vertices).
    pub fn frames(&self) -> usize {
        self.positions.len() / self.vertex_count.max(1)
    }
}

impl ImpostorData {
    /// The sheets at `1/factor` of their resolution, for far characters (the three-level
    /// mix draws impostors only below a quarter of a screen pixel per baked texel, so a
    /// quarter of the texels loses nothing there). Each `factor × factor` block becomes one
    /// texel: colour averaged with premultiplied alpha (coverage is the block's mean alpha,
    /// so the silhouette keeps where at least half the block is covered); normals averaged
    /// over the block's covered texels and renormalised; the body part in the normal's alpha
    /// is the one most of the covered texels have (a part number is not averaged). Sheets
    /// whose sides `factor` does not divide, or a factor below 2, are kept as they are.
    pub fn downsampled(&self, factor: u32) -> ImpostorData {
        self.downsampled_split(factor, factor)
    }

    /// The sheets holding only the frames `keep` (in that order), re-tiled as the bake tiles
    /// that many frames. Frames past the sheets are left out.
    pub fn frames_subset(&self, keep: &[usize]) -> ImpostorData {
        let frames = (self.columns * self.rows) as usize;
        let keep: Vec<usize> = keep.iter().copied().filter(|&f| f < frames).collect();
        let columns = sheet_columns(keep.len());
        let rows = (keep.len() as u32).div_ceil(columns).max(1);
        let cut = |sheets: &[image::RgbaImage]| -> Vec<image::RgbaImage> {
            sheets
                .iter()
                .map(|sheet| {
                    let (tw, th) = (sheet.width() / self.columns.max(1), sheet.height() / self.rows.max(1));
                    let mut out = image::RgbaImage::new(columns * tw, rows * th);
                    for (i, &f) in keep.iter().enumerate() {
                        let tile = sheet_tile_rect(sheet, f as u32, self.columns, tw, th);
                        let (x, y) = ((i as u32 % columns) * tw, (i as u32 / columns) * th);
                        image::imageops::replace(&mut out, &tile, x as i64, y as i64);
                    }
                    out
                })
                .collect()
        };
        ImpostorData {
            color_blocks: Vec::new(),
            normal_blocks: Vec::new(),
            columns,
            rows,
            color: cut(&self.color),
            normal: cut(&self.normal),
        }
    }

    /// [`ImpostorData::downsampled`] with the colour sheets at `1/color_factor` and the normal
    /// sheets at `1/normal_factor` (lighting is smoother than colour; the shader samples both
    /// by texture coordinate, so they need not match). Where either factor does not divide
    /// the sheets, both are kept as they are.
    pub fn downsampled_split(&self, color_factor: u32, normal_factor: u32) -> ImpostorData {
        let ok = |f: u32| {
            self.color
                .iter()
                .chain(&self.normal)
                .all(|i| f >= 1 && i.width() % f == 0 && i.height() % f == 0 && i.width() >= f)
        };
        if !ok(color_factor) || !ok(normal_factor) {
            return self.clone();
        }
        let c = self.downsampled_both(color_factor);
        if normal_factor == color_factor {
            return c;
        }
        let n = self.downsampled_both(normal_factor);
        ImpostorData {
            normal: n.normal,
            normal_blocks: Vec::new(),
            ..c
        }
    }

    fn downsampled_both(&self, factor: u32) -> ImpostorData {
        let f = factor.max(1);
        let divides = |i: &image::RgbaImage| i.width() % f == 0 && i.height() % f == 0 && i.width() >= f;
        if f < 2 || !self.color.iter().chain(&self.normal).all(divides) {
            return self.clone();
        }
        let mut color = Vec::with_capacity(self.color.len());
        let mut normal = Vec::with_capacity(self.normal.len());
        for (c, n) in self.color.iter().zip(&self.normal) {
            let (w, h) = (c.width() / f, c.height() / f);
            let mut co = image::RgbaImage::new(w, h);
            let mut no = image::RgbaImage::new(w, h);
            for y in 0..h {
                for x in 0..w {
                    let mut rgb = [0.0f32; 3];
                    let mut alpha = 0.0f32;
                    let mut nrm = [0.0f32; 3];
                    let mut parts = [0u32; 256];
                    let mut covered = 0u32;
                    for dy in 0..f {
                        for dx in 0..f {
                            let (sx, sy) = (x * f + dx, y * f + dy);
                            let p = c.get_pixel(sx, sy).0;
                            let a = p[3] as f32 / 255.0;
                            for k in 0..3 {
                                rgb[k] += p[k] as f32 * a;
                            }
                            alpha += a;
                            if p[3] >= 128 && sx < n.width() && sy < n.height() {
                                let q = n.get_pixel(sx, sy).0;
                                for k in 0..3 {
                                    nrm[k] += q[k] as f32 / 127.5 - 1.0;
                                }
                                parts[q[3] as usize] += 1;
                                covered += 1;
                            }
                        }
                    }
                    let nn = (f * f) as f32;
                    let out_rgb = if alpha > 0.0 {
                        rgb.map(|v| (v / alpha).round().clamp(0.0, 255.0) as u8)
                    } else {
                        [0; 3]
                    };
                    let a = (alpha / nn * 255.0).round().clamp(0.0, 255.0) as u8;
                    co.put_pixel(x, y, image::Rgba([out_rgb[0], out_rgb[1], out_rgb[2], a]));
                    if covered > 0 {
                        let len = (nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]).sqrt().max(1e-6);
                        let enc = nrm.map(|v| ((v / len + 1.0) * 127.5).round().clamp(0.0, 255.0) as u8);
                        // The most frequent part; the lowest number on a tie.
                        let part = (0..256).max_by_key(|&i| (parts[i], std::cmp::Reverse(i))).unwrap_or(0) as u8;
                        no.put_pixel(x, y, image::Rgba([enc[0], enc[1], enc[2], part]));
                    }
                }
            }
            color.push(co);
            normal.push(no);
        }
        ImpostorData {
            color_blocks: Vec::new(),
            normal_blocks: Vec::new(),
            columns: self.columns,
            rows: self.rows,
            color,
            normal,
        }
    }
}

impl Representations {
    /// Every view's frame, as the image-based renderers take them.
    pub fn view_frames(&self) -> Vec<ViewFrame> {
        self.manifest.views.iter().map(|v| v.camera.view_frame()).collect()
    }
}

/// Representations in memory.
#[derive(Clone, Debug)]
pub struct Representations {
    /// The manifest the data was loaded with, or will be written with.
    pub manifest: RepsManifest,
    /// The full-resolution sheets (`None` when not baked, or not loaded:
    /// [`load_representations_far`]).
    pub impostor: Option<ImpostorData>,
    /// The far impostors' sheets ([`FarImpostorInfo`]).
    pub far_impostor: Option<ImpostorData>,
    /// The NP3D mesh and images (`None` when not baked).
    pub np3d: Option<Np3dData>,
    /// The full mesh pre-skinned at every frame (`None` when not baked).
    pub rigid: Option<FrameVertices>,
}

/// Bytes of each representation, uncompressed and with block-compressed textures (BC1 for
/// colour without alpha is not enough for cut-outs: BC3/DXT5 at one byte per texel, as the
/// pack's own figure).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct RepBytes {
    /// Bytes of the textures, uncompressed RGBA8.
    pub texture: u64,
    /// Bytes of the vertex and index data.
    pub geometry: u64,
    /// `texture + geometry`.
    pub total: u64,
    /// `total` with the textures block-compressed at one byte per texel (a quarter of
    /// `texture`).
    pub total_bc: u64,
}

impl RepBytes {
    fn new(texture: u64, geometry: u64) -> Self {
        Self {
            texture,
            geometry,
            total: texture + geometry,
            total_bc: texture / 4 + geometry,
        }
    }
}

impl Representations {
    /// Memory of the impostors as stored (colour + normal RGBA8 per view per frame).
    pub fn impostor_bytes(&self) -> Option<RepBytes> {
        // From the manifest: the sheets may not be loaded ([`load_representations_far`]).
        self.manifest.impostor.as_ref()?;
        let r = self.manifest.resolution as u64;
        let tiles = self.manifest.views.len() as u64 * self.manifest.frames as u64;
        Some(RepBytes::new(tiles * r * r * 4 * 2, 0))
    }

    /// NP3D: per-view key-frame colour images + the simplified mesh at every frame.
    pub fn np3d_bytes(&self) -> Option<RepBytes> {
        let n = self.np3d.as_ref()?;
        let r = self.manifest.resolution as u64;
        let texture = self.manifest.views.len() as u64 * r * r * 4;
        // On the GPU: u32 indices, a part per vertex, 16 bytes per vertex per frame.
        let geometry = n.indices.len() as u64 * 4 + n.source.len() as u64 * 4 + n.frames.positions.len() as u64 * 16;
        Some(RepBytes::new(texture, geometry))
    }

    /// Rigid: the full mesh at every frame (positions + normals as stored), plus the
    /// character's own textures and static attributes, given by the caller.
    pub fn rigid_bytes(&self, character_static: RepBytes) -> Option<RepBytes> {
        let r = self.rigid.as_ref()?;
        Some(RepBytes::new(
            character_static.texture,
            // On the GPU: 16 bytes per vertex per frame (position + packed normal).
            character_static.geometry + r.positions.len() as u64 * 16,
        ))
    }
}

/// Static bytes of a character mesh on the GPU: base-colour textures (RGBA8 with mips, ×4/3)
/// and the vertex attributes (UV, colour, joints, weights: 40 bytes) and u32 indices. The
/// skinned mesh adds its bind-pose positions + normals; see [`skinned_bytes`].
pub fn character_static_bytes(c: &crate::Character) -> RepBytes {
    let (texture, geometry) = crate::gpu::gpu_data::mesh_static_bytes(c);
    RepBytes::new(texture, geometry)
}

/// The GPU-skinned mesh: static data + bind-pose positions and normals + the clip's joint
/// transforms (three rows of a matrix, 48 bytes per joint per sample) of the joints that move
/// some vertex ([`crate::Character::used_bone_count`]: a crowd carries no IK targets or
/// controls).
pub fn skinned_bytes(c: &crate::Character, joint_samples: usize) -> RepBytes {
    let s = character_static_bytes(c);
    // Animated morph targets: each vertex's offsets at every joint sample (16 bytes).
    let morphs = if c.morphs.is_empty() {
        0
    } else {
        (joint_samples as u64)
            .saturating_mul(c.vertices.len() as u64)
            .saturating_mul(16)
    };
    RepBytes::new(
        s.texture,
        s.geometry + c.vertices.len() as u64 * 24 + (joint_samples * c.used_bone_count()) as u64 * 48 + morphs,
    )
}

fn damaged(m: String) -> PackError {
    PackError::Damaged(m)
}

/// Bytes of `vertex_count × frames` (position, normal) records, if that fits the limit.
fn frame_vertex_len(vertex_count: u32, frames: u32) -> Option<u64> {
    u64::from(vertex_count)
        .checked_mul(u64::from(frames))?
        .checked_mul(24)
        .filter(|&n| n <= MAX_FRAME_VERTEX_BYTES)
}

/// Most bytes of `np3d.bin` or `rigid.bin`.
pub const MAX_FRAME_VERTEX_BYTES: u64 = 2 << 30;

fn frame_vertices(bytes: &[u8], vertex_count: usize, frames: usize, what: &str) -> Result<FrameVertices, PackError> {
    let want = vertex_count.checked_mul(frames).and_then(|n| n.checked_mul(24));
    if want != Some(bytes.len()) {
        return Err(damaged(format!(
            "{what} has {} bytes of vertex data, {vertex_count} vertices × {frames} frames need {}",
            bytes.len(),
            want.map_or("more than can be stored".to_string(), |w| w.to_string())
        )));
    }
    let f: Vec<f32> = bytes
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    if let Some(bad) = f.iter().position(|x| !x.is_finite() || x.abs() > 1e15) {
        return Err(damaged(format!(
            "{what}: value {bad} is not a finite number of sensible size"
        )));
    }
    let mut out = FrameVertices {
        vertex_count,
        positions: Vec::with_capacity(vertex_count * frames),
        normals: Vec::with_capacity(vertex_count * frames),
    };
    for v in f.chunks_exact(6) {
        out.positions.push([v[0], v[1], v[2]]);
        out.normals.push([v[3], v[4], v[5]]);
    }
    Ok(out)
}

fn frame_vertex_bytes(v: &FrameVertices) -> Vec<u8> {
    let mut out = Vec::with_capacity(v.positions.len() * 24);
    for (p, n) in v.positions.iter().zip(&v.normals) {
        for x in p.iter().chain(n) {
            out.extend_from_slice(&x.to_le_bytes());
        }
    }
    out
}

/// A `w × h` tile of a sheet (`columns` per row).
fn sheet_tile_rect(sheet: &image::RgbaImage, index: u32, columns: u32, w: u32, h: u32) -> image::RgbaImage {
    let (x, y) = ((index % columns.max(1)) * w, (index / columns.max(1)) * h);
    image::imageops::crop_imm(sheet, x, y, w, h).to_image()
}

/// Far impostors of a long timeline play at half the frame rate: the frames kept (every
/// other frame of each clip, from its first) and, per frame of the timeline, the kept frame
/// drawn for it (the kept frame at or before it in its clip). `None` for a timeline of at
/// most [`FAR_HALF_RATE_ABOVE`] frames (kept whole).
pub fn far_frames(clips: &[crate::timeline::ClipSpan], frames: usize) -> Option<(Vec<usize>, Vec<u32>)> {
    if frames <= FAR_HALF_RATE_ABOVE || clips.is_empty() {
        return None;
    }
    let mut keep = Vec::new();
    let mut map = vec![0u32; frames];
    for c in clips {
        let r = c.range();
        for f in r.clone() {
            let local = f - r.start;
            if local % 2 == 0 {
                keep.push(f);
            }
            if let Some(m) = map.get_mut(f) {
                // The kept frame at or before it in its clip: the last one kept so far.
                *m = (keep.len() - 1) as u32;
            }
        }
    }
    Some((keep, map))
}

/// Timelines longer than this many frames get far impostors at half the frame rate
/// ([`far_frames`]): their sheets grow with every clip's frames, and far characters are a few
/// dozen pixels tall.
pub const FAR_HALF_RATE_ABOVE: usize = 32;

/// The factor the far impostors' colour sheets are reduced by for a mix that switches to
/// impostors below `impostor_below` screen pixels per baked texel: the largest power of two
/// at most `1 / impostor_below` (and at most 16) that divides `resolution` and leaves tiles
/// of at least 8 texels; 1 where none does.
pub fn far_factor(impostor_below: f32, resolution: u32) -> u32 {
    let most = if impostor_below.is_finite() && impostor_below > 0.0 {
        (1.0 / impostor_below).floor().clamp(1.0, 16.0) as u32
    } else {
        1
    };
    let mut f = 1;
    while f * 2 <= most && resolution % (f * 2) == 0 && resolution / (f * 2) >= 8 {
        f *= 2;
    }
    f
}

/// The far impostors of `full` (every frame of the timeline of `clips`, `frames` long, at
/// `resolution`): the frames [`far_frames`] keeps, colour reduced by `factor` and normals by
/// twice that where it divides (lighting is smoother than colour).
pub fn far_impostor_sheets(
    full: &ImpostorData,
    clips: &[crate::timeline::ClipSpan],
    frames: usize,
    resolution: u32,
    factor: u32,
) -> (FarImpostorInfo, ImpostorData) {
    let (keep, subset) = match far_frames(clips, frames) {
        Some((keep, _)) => {
            let s = full.frames_subset(&keep);
            (keep, Some(s))
        }
        None => ((0..frames).collect(), None),
    };
    let normal_factor = if resolution % (2 * factor) == 0 && resolution / (2 * factor) >= 4 {
        2 * factor
    } else {
        factor
    };
    let data = subset.as_ref().unwrap_or(full).downsampled_split(factor, normal_factor);
    let info = FarImpostorInfo {
        columns: data.columns,
        rows: data.rows,
        color_factor: factor,
        normal_factor,
        frames: keep.iter().map(|&f| f as u32).collect(),
    };
    (info, data)
}

/// Per frame of the timeline, the far impostors' tile drawn for it (`None`: tile = frame).
pub fn far_frame_map(manifest: &RepsManifest) -> Option<Vec<u32>> {
    far_frames(&manifest.clips, manifest.frames as usize).map(|(_, map)| map)
}

/// A tile of a sheet (`columns` per row, `size²` each).
pub fn sheet_tile(sheet: &image::RgbaImage, index: u32, columns: u32, size: u32) -> image::RgbaImage {
    let columns = columns.max(1);
    let (x, y) = ((index % columns) * size, (index / columns) * size);
    image::imageops::crop_imm(sheet, x, y, size, size).to_image()
}

/// Loads `representations.json` and every file it names, validating every number, count,
/// size, index and checksum (a damaged file gives a clear error naming it, never a panic
/// later or an allocation beyond what the folder really holds).
pub fn load_representations(dir: &Path) -> Result<Representations, PackError> {
    load_representations_with(dir, true)
}

/// [`load_representations`] without the full-resolution impostor sheets where far ones were
/// baked (what the three-level mix draws with; a fraction of the memory and load time): the
/// full sheets load later with [`load_full_impostors`].
pub fn load_representations_far(dir: &Path) -> Result<Representations, PackError> {
    load_representations_with(dir, false)
}

/// The full-resolution impostor sheets of a folder loaded by [`load_representations_far`]
/// (`None` when none were baked), checked against the manifest as the loader checks them.
pub fn load_full_impostors(dir: &Path, manifest: &RepsManifest) -> Result<Option<ImpostorData>, PackError> {
    let files = crate::pack::FolderReader {
        dir,
        manifest_file: REPS_FILE,
        checksums: &manifest.checksums,
    };
    read_impostor_sheets(&files, manifest)
}

/// A colour sheet of view `v` (`kind` `color` or `far_color`): BC7 in KTX2 when the
/// folder lists that file, else PNG.
fn color_sheet(
    files: &crate::pack::FolderReader,
    kind: &str,
    v: u32,
    size: [u32; 2],
) -> Result<(image::RgbaImage, Option<crate::texture::CompressedImage>), PackError> {
    let ktx2 = impostor_file_as(kind, v, "ktx2");
    if files.checksums.contains_key(&ktx2) {
        files.texture(&ktx2, size, crate::texture::BcFormat::Bc7Srgb)
    } else {
        Ok((files.png(&impostor_file(kind, v), size)?, None))
    }
}

/// A normal sheet of view `v` (`kind` `normal` or `far_normal`) with the body part of each
/// texel in its alpha: BC7 normals in KTX2 plus the lossless part numbers
/// (`impostor_part_NNN.png`) when the folder lists them, else one PNG holding both.
fn normal_sheet(
    files: &crate::pack::FolderReader,
    kind: &str,
    v: u32,
    size: [u32; 2],
) -> Result<(image::RgbaImage, Option<crate::texture::CompressedImage>), PackError> {
    let ktx2 = impostor_file_as(kind, v, "ktx2");
    if !files.checksums.contains_key(&ktx2) {
        return Ok((files.png(&impostor_file(kind, v), size)?, None));
    }
    let (mut normal, blocks) = files.texture(&ktx2, size, crate::texture::BcFormat::Bc7Unorm)?;
    let parts = files.png(&impostor_file(&kind.replace("normal", "part"), v), size)?;
    for (n, p) in normal.pixels_mut().zip(parts.pixels()) {
        n[3] = p[0];
    }
    Ok((normal, blocks))
}

fn read_impostor_sheets(
    files: &crate::pack::FolderReader,
    manifest: &RepsManifest,
) -> Result<Option<ImpostorData>, PackError> {
    let Some(info) = &manifest.impostor else {
        return Ok(None);
    };
    let r = manifest.resolution;
    let size = [info.columns * r, info.rows * r];
    let views = manifest.views.len() as u32;
    read_sheets(files, "", views, (size, size), (info.columns, info.rows)).map(Some)
}

/// Every view's colour and normal sheet of one impostor level (`prefix` `""` or `far_`), at
/// `sizes` (colour, normal); the blocks kept only where every view has them.
fn read_sheets(
    files: &crate::pack::FolderReader,
    prefix: &str,
    views: u32,
    (color_size, normal_size): ([u32; 2], [u32; 2]),
    (columns, rows): (u32, u32),
) -> Result<ImpostorData, PackError> {
    let mut color = Vec::new();
    let mut normal = Vec::new();
    let mut color_blocks = Vec::new();
    let mut normal_blocks = Vec::new();
    for v in 0..views {
        let (c, blocks) = color_sheet(files, &format!("{prefix}color"), v, color_size)?;
        color.push(c);
        color_blocks.extend(blocks);
        let (n, blocks) = normal_sheet(files, &format!("{prefix}normal"), v, normal_size)?;
        normal.push(n);
        normal_blocks.extend(blocks);
    }
    if color_blocks.len() != color.len() {
        color_blocks.clear();
    }
    if normal_blocks.len() != normal.len() {
        normal_blocks.clear();
    }
    Ok(ImpostorData {
        color_blocks,
        normal_blocks,
        columns,
        rows,
        color,
        normal,
    })
}

fn load_representations_with(dir: &Path, full_impostors: bool) -> Result<Representations, PackError> {
    use crate::pack::{FolderReader, check_camera, check_direction, check_resolution_views, check_timing};
    const FILE: &str = REPS_FILE;
    let mut manifest: RepsManifest =
        crate::pack::parse_manifest(dir, FILE, REPS_FORMAT, OLDEST_REPS_VERSION..=REPS_VERSION)?;
    check_timing(FILE, manifest.fps, manifest.frames, manifest.key_frame)?;
    crate::timeline::printable_names(&mut manifest.clips);
    crate::timeline::validate(&manifest.clips, manifest.frames as usize)
        .map_err(|e| damaged(format!("{FILE}: {e}")))?;
    check_resolution_views(FILE, manifest.resolution, manifest.views.len())?;
    for (v, view) in manifest.views.iter().enumerate() {
        let what = format!("{FILE}: view {v}");
        check_direction(&what, view.direction)?;
        check_camera(&what, &view.camera, view.direction)?;
    }
    let (frames, r, views) = (
        manifest.frames as usize,
        manifest.resolution,
        manifest.views.len() as u32,
    );
    let side_ok = |tiles: u32| u64::from(tiles) * u64::from(r) <= u64::from(crate::pack::MAX_ATLAS_SIDE);
    // Every size from the manifest first, then the texture budget, then the files.
    let mut textures: Vec<[u32; 2]> = Vec::new();
    if let Some(info) = &manifest.impostor {
        let tiles = u64::from(info.columns) * u64::from(info.rows);
        if info.columns == 0
            || info.rows == 0
            || tiles < u64::from(manifest.frames)
            || tiles >= u64::from(manifest.frames) + u64::from(info.columns)
            || !side_ok(info.columns)
            || !side_ok(info.rows)
        {
            return Err(damaged(format!(
                "{FILE}: impostor sheets of {}×{} tiles of {r}² do not fit {} frames",
                info.columns, info.rows, manifest.frames
            )));
        }
        let size = [info.columns * r, info.rows * r];
        textures.extend(std::iter::repeat_n(size, 2 * views as usize));
    }
    let far_sizes = match (&manifest.impostor, &manifest.far_impostor) {
        (None, None) => None,
        (Some(_), None) => {
            return Err(damaged(format!(
                "{FILE}: impostors without their far sheets (far_impostor)"
            )));
        }
        (None, Some(_)) => return Err(damaged(format!("{FILE}: far impostors without impostors"))),
        (Some(_), Some(far)) => {
            let want: Vec<u32> = match far_frames(&manifest.clips, frames) {
                Some((keep, _)) => keep.iter().map(|&f| f as u32).collect(),
                None => (0..manifest.frames).collect(),
            };
            if far.frames != want {
                return Err(damaged(format!(
                    "{FILE}: far impostors hold frames {:?}…, the clip table asks for {:?}…",
                    &far.frames[..far.frames.len().min(4)],
                    &want[..want.len().min(4)]
                )));
            }
            let n = want.len() as u64;
            let tiles = u64::from(far.columns) * u64::from(far.rows);
            let factor_ok = |f: u32| f.is_power_of_two() && f <= 64 && r % f == 0;
            if far.columns == 0
                || far.rows == 0
                || tiles < n
                || tiles >= n + u64::from(far.columns)
                || !side_ok(far.columns)
                || !side_ok(far.rows)
                || !factor_ok(far.color_factor)
                || !factor_ok(far.normal_factor)
            {
                return Err(damaged(format!(
                    "{FILE}: far impostor sheets of {}×{} tiles reduced {}× / {}× do not fit {n} frames of {r}²",
                    far.columns, far.rows, far.color_factor, far.normal_factor
                )));
            }
            let size = |f: u32| [far.columns * (r / f), far.rows * (r / f)];
            textures.extend(std::iter::repeat_n(size(far.color_factor), views as usize));
            textures.extend(std::iter::repeat_n(size(far.normal_factor), views as usize));
            Some((size(far.color_factor), size(far.normal_factor)))
        }
    };
    let np3d_layout = match &manifest.np3d {
        None => None,
        Some(info) => {
            let (vc, ic) = (info.vertex_count, info.index_count);
            if vc < 3 || vc > u32::from(u16::MAX) || ic == 0 || ic % 3 != 0 || ic > 3 << 20 {
                return Err(damaged(format!(
                    "{FILE}: NP3D mesh of {vc} vertices / {ic} indices is out of range"
                )));
            }
            let columns = info.columns;
            if columns == 0 || columns > views || !side_ok(columns) || !side_ok(views.div_ceil(columns)) {
                return Err(damaged(format!(
                    "{FILE}: NP3D image sheet of {columns} columns does not fit {views} views of {r}²"
                )));
            }
            let frame_bytes = frame_vertex_len(vc, manifest.frames).ok_or_else(|| {
                damaged(format!(
                    "{FILE}: NP3D mesh of {vc} vertices × {} frames is larger than the limit",
                    manifest.frames
                ))
            })?;
            let bytes = u64::from(ic) * 2 + u64::from(vc) * 4 + frame_bytes;
            textures.push([columns * r, views.div_ceil(columns) * r]);
            Some((vc as usize, ic as usize, columns, bytes))
        }
    };
    if let Some(info) = &manifest.rigid
        && (info.vertex_count < 3 || frame_vertex_len(info.vertex_count, manifest.frames).is_none())
    {
        return Err(damaged(format!(
            "{FILE}: rigid mesh of {} vertices × {} frames is out of range",
            info.vertex_count, manifest.frames
        )));
    }
    crate::pack::check_texture_budget(FILE, textures.into_iter())?;
    let files = FolderReader {
        dir,
        manifest_file: FILE,
        checksums: &manifest.checksums,
    };
    let impostor = if full_impostors {
        read_impostor_sheets(&files, &manifest)?
    } else {
        None
    };
    let far_impostor = match (far_sizes, &manifest.far_impostor) {
        (Some((cs, ns)), Some(far)) => Some(read_sheets(&files, "far_", views, (cs, ns), (far.columns, far.rows))?),
        _ => None,
    };
    let np3d = match np3d_layout {
        None => None,
        Some((vc, ic, columns, want)) => {
            let bytes = files.read("np3d.bin")?;
            if bytes.len() as u64 != want {
                return Err(damaged(format!(
                    "np3d.bin has {} bytes, {vc} vertices and {ic} indices over {frames} frames need {want}",
                    bytes.len()
                )));
            }
            let indices: Vec<u16> = bytes[..ic * 2]
                .chunks_exact(2)
                .map(|c| u16::from_le_bytes([c[0], c[1]]))
                .collect();
            if let Some(i) = indices.iter().find(|&&i| i as usize >= vc) {
                return Err(damaged(format!("np3d.bin: index {i} is past the {vc} vertices")));
            }
            let rest = &bytes[ic * 2..];
            let source: Vec<u32> = rest[..vc * 4]
                .chunks_exact(4)
                .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                .collect();
            let frames = frame_vertices(&rest[vc * 4..], vc, frames, "np3d.bin")?;
            let size = [columns * r, views.div_ceil(columns) * r];
            let (sheet, blocks) = if files.checksums.contains_key("np3d_color.ktx2") {
                files.texture("np3d_color.ktx2", size, crate::texture::BcFormat::Bc7Srgb)?
            } else {
                (files.png("np3d_color.png", size)?, None)
            };
            let images = (0..views).map(|v| sheet_tile(&sheet, v, columns, r)).collect();
            // Each view's blocks cut from the sheet's (whole blocks: the writer encodes BC7
            // only where the resolution is a multiple of 4).
            let image_blocks = blocks
                .and_then(|b| {
                    (0..views)
                        .map(|v| b.crop((v % columns.max(1)) * r, (v / columns.max(1)) * r, r, r))
                        .collect::<Option<Vec<_>>>()
                })
                .unwrap_or_default();
            Some(Np3dData {
                indices,
                source,
                frames,
                images,
                image_blocks,
            })
        }
    };
    let rigid = match &manifest.rigid {
        None => None,
        Some(info) => {
            let bytes = files.read("rigid.bin")?;
            Some(frame_vertices(&bytes, info.vertex_count as usize, frames, "rigid.bin")?)
        }
    };
    Ok(Representations {
        manifest,
        impostor,
        far_impostor,
        np3d,
        rigid,
    })
}

/// `impostor_{kind}_NNN.png`; the far sheets are `far_impostor_{color,normal}_NNN.png`.
fn impostor_file(kind: &str, view: u32) -> String {
    impostor_file_as(kind, view, "png")
}

/// [`impostor_file`] with extension `ext` (`ktx2`: a colour sheet in BC7).
fn impostor_file_as(kind: &str, view: u32, ext: &str) -> String {
    match kind.strip_prefix("far_") {
        Some(k) => format!("far_impostor_{k}_{view:03}.{ext}"),
        None => format!("impostor_{kind}_{view:03}.{ext}"),
    }
}

/// Writes the representations into `dir` (an existing folder, e.g. the pack's temporary
/// folder before it is moved into place), with the checksum of every file in the manifest.
/// Returns the bytes written. Every sheet is PNG; see [`write_representations_with`].
pub fn write_representations(reps: &Representations, dir: &Path) -> Result<u64, String> {
    write_representations_with(reps, dir, None)
}

/// Turns a sheet into a KTX2 file of BC7 blocks in the format given (`None`: keep it PNG).
pub type SheetEncoder<'a> = &'a (dyn Fn(&image::RgbaImage, crate::texture::BcFormat) -> Option<Vec<u8>> + Sync);

/// [`write_representations`], with the impostor sheets (full and far) and NP3D's key images
/// written by `encode` as `.ktx2` files where it gives one: colour as sRGB BC7, normals as
/// linear BC7 (opaque) with each texel's body part (the normal sheet's alpha, an exact
/// number) beside it as a lossless greyscale `impostor_part_NNN.png`.
pub fn write_representations_with(
    reps: &Representations,
    dir: &Path,
    encode: Option<SheetEncoder>,
) -> Result<u64, String> {
    use crate::texture::BcFormat;
    let mut sums = crate::pack::Checksums::new();
    let mut put = |name: &str, bytes: &[u8]| crate::pack::put_file(dir, name, bytes, &mut sums);
    let png_bytes = |img: &image::RgbaImage| crate::safe_fs::encode_png(img, png::Compression::Balanced);
    // Every colour sheet, encoded on all cores (BC7 encoding is most of the write).
    let mut sheets: Vec<(&str, u32, &image::RgbaImage, BcFormat)> = Vec::new();
    for (kind, data) in [("color", &reps.impostor), ("far_color", &reps.far_impostor)] {
        if let Some(i) = data {
            sheets.extend(
                i.color
                    .iter()
                    .enumerate()
                    .map(|(v, c)| (kind, v as u32, c, BcFormat::Bc7Srgb)),
            );
        }
    }
    for (kind, data) in [("normal", &reps.impostor), ("far_normal", &reps.far_impostor)] {
        if let Some(i) = data {
            sheets.extend(
                i.normal
                    .iter()
                    .enumerate()
                    .map(|(v, n)| (kind, v as u32, n, BcFormat::Bc7Unorm)),
            );
        }
    }
    let mut encoded: Vec<Option<Vec<u8>>> = vec![None; sheets.len()];
    if let Some(encode) = encode {
        let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).max(1);
        let chunk = sheets.len().div_ceil(threads).max(1);
        std::thread::scope(|scope| {
            for (out, jobs) in encoded.chunks_mut(chunk).zip(sheets.chunks(chunk)) {
                scope.spawn(move || {
                    for (o, (_, _, img, format)) in out.iter_mut().zip(jobs) {
                        *o = encode(img, *format);
                    }
                });
            }
        });
    }
    for ((kind, v, img, format), bytes) in sheets.into_iter().zip(encoded) {
        match bytes {
            Some(bytes) => {
                put(&impostor_file_as(kind, v, "ktx2"), &bytes)?;
                if format == BcFormat::Bc7Unorm {
                    // The part numbers, exact, beside the BC7 normals.
                    let parts = image::GrayImage::from_fn(img.width(), img.height(), |x, y| {
                        image::Luma([img.get_pixel(x, y)[3]])
                    });
                    let bytes = crate::safe_fs::encode_gray_png(&parts, png::Compression::Balanced)?;
                    put(&impostor_file(&kind.replace("normal", "part"), v), &bytes)?;
                }
            }
            None => put(&impostor_file(kind, v), &png_bytes(img)?)?,
        }
    }
    let mut put = |name: &str, bytes: &[u8]| crate::pack::put_file(dir, name, bytes, &mut sums);
    if let Some(n) = &reps.np3d {
        let mut bytes: Vec<u8> = n.indices.iter().flat_map(|i| i.to_le_bytes()).collect();
        bytes.extend(n.source.iter().flat_map(|i| i.to_le_bytes()));
        bytes.extend(frame_vertex_bytes(&n.frames));
        put("np3d.bin", &bytes)?;
        let columns = reps.manifest.np3d.as_ref().map_or(1, |i| i.columns.max(1));
        let r = reps.manifest.resolution;
        let rows = (n.images.len() as u32).div_ceil(columns);
        let mut sheet = image::RgbaImage::new(columns * r, rows.max(1) * r);
        for (v, img) in n.images.iter().enumerate() {
            let v = v as u32;
            image::imageops::replace(&mut sheet, img, ((v % columns) * r) as i64, ((v / columns) * r) as i64);
        }
        // BC7 where the views' images are whole blocks (each view cut from the sheet's blocks
        // at load), else PNG.
        match encode.filter(|_| r % 4 == 0).and_then(|e| e(&sheet, BcFormat::Bc7Srgb)) {
            Some(bytes) => put("np3d_color.ktx2", &bytes)?,
            None => put("np3d_color.png", &png_bytes(&sheet)?)?,
        }
    }
    if let Some(r) = &reps.rigid {
        put("rigid.bin", &frame_vertex_bytes(r))?;
    }
    let mut manifest = reps.manifest.clone();
    manifest.checksums = sums;
    let written: u64 = manifest.checksums.values().map(|s| s.bytes).sum();
    let text = serde_json::to_string_pretty(&manifest).map_err(|e| e.to_string())?;
    let path = dir.join(REPS_FILE);
    std::fs::write(&path, &text).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(written + text.len() as u64)
}

/// Columns of a sheet of `n` tiles: near square, with as few empty tiles as possible (10
/// frames: 5 × 2 rather than 4 × 3).
pub fn sheet_columns(n: usize) -> u32 {
    let n = n.max(1);
    let lo = (n as f64).sqrt().ceil() as usize;
    (lo..=(2 * lo).min(n))
        .min_by_key(|&c| (c * n.div_ceil(c) - n, c))
        .unwrap_or(lo) as u32
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every set reads back from its words (what the editor stores in a project).
    #[test]
    fn a_set_reads_back_from_its_words() {
        for bits in 1..16u8 {
            let set = RepSet {
                polypostor: bits & 1 != 0,
                impostor: bits & 2 != 0,
                np3d: bits & 4 != 0,
                rigid: bits & 8 != 0,
            };
            assert_eq!(RepSet::parse(&set.words()), Ok(set), "{}", set.words());
        }
        assert_eq!(RepSet::ALL.words(), "all");
        assert_eq!(RepSet::default().words(), "polypostor");
    }

    #[test]
    fn far_impostors_are_reduced_as_the_switch_distance_allows() {
        // A quarter of a pixel per texel: a quarter of the texels, on any resolution that
        // divides and keeps tiles of at least 8 texels.
        assert_eq!(far_factor(0.25, 128), 4);
        assert_eq!(far_factor(0.25, 64), 4);
        assert_eq!(far_factor(0.25, 100), 4);
        assert_eq!(far_factor(0.25, 16), 2);
        assert_eq!(far_factor(0.25, 8), 1);
        assert_eq!(far_factor(0.25, 129), 1);
        assert_eq!(far_factor(0.1, 128), 8);
        assert_eq!(far_factor(0.001, 1024), 16);
        for bad in [1.0, 2.0, 0.0, -1.0, f32::NAN, f32::INFINITY] {
            assert_eq!(far_factor(bad, 128), 1, "{bad}");
        }
        // Brute force over small cases: the largest power of two meeting every condition.
        for r in 1..200u32 {
            for below in [0.3f32, 0.2, 0.12] {
                let most = (1.0 / below).floor() as u32;
                let want = (0..5)
                    .map(|k| 1u32 << k)
                    .filter(|&f| f <= most && r % f == 0 && (f == 1 || r / f >= 8))
                    .max()
                    .unwrap();
                assert_eq!(far_factor(below, r), want, "{below} at {r}");
            }
        }
    }

    #[test]
    fn far_impostors_of_a_long_timeline_keep_every_other_frame_of_each_clip() {
        use crate::timeline::ClipSpan;
        let span = |start: u32, frames: u32| ClipSpan {
            name: format!("c{start}"),
            start,
            frames,
            looping: true,
            ground_speed: 0.0,
            secs_per_frame: 0.0,
        };
        // Short timelines are kept whole.
        assert!(far_frames(&[span(0, 10)], 10).is_none());
        // Clips of 10, 7 and 20 frames (37): kept 0,2,..,8 | 10,12,14,16 | 17,19,..,35.
        let clips = [span(0, 10), span(10, 7), span(17, 20)];
        let (keep, map) = far_frames(&clips, 37).unwrap();
        assert_eq!(keep.len(), 5 + 4 + 10);
        for (f, &m) in map.iter().enumerate() {
            // Brute force: the kept frame at or before f in f's clip.
            let c = clips.iter().find(|c| c.range().contains(&f)).unwrap();
            let want = (c.start as usize..=f)
                .rev()
                .find(|g| (g - c.start as usize) % 2 == 0)
                .unwrap();
            assert_eq!(keep[m as usize], want, "frame {f}");
        }
        // The sheets of the kept frames hold exactly those tiles, re-tiled.
        let (columns, rows, t) = (7u32, 6u32, 4u32);
        let mut sheet = image::RgbaImage::new(columns * t, rows * t);
        for f in 0..37u32 {
            let (x, y) = ((f % columns) * t, (f / columns) * t);
            for dy in 0..t {
                for dx in 0..t {
                    sheet.put_pixel(x + dx, y + dy, image::Rgba([f as u8, dx as u8, dy as u8, 255]));
                }
            }
        }
        let data = ImpostorData {
            color_blocks: Vec::new(),
            normal_blocks: Vec::new(),
            columns,
            rows,
            color: vec![sheet.clone()],
            normal: vec![sheet],
        };
        let sub = data.frames_subset(&keep);
        assert_eq!(sub.columns, sheet_columns(keep.len()));
        assert!(sub.columns * sub.rows >= keep.len() as u32);
        for (i, &f) in keep.iter().enumerate() {
            let tile = sheet_tile(&sub.color[0], i as u32, sub.columns, t);
            assert_eq!(tile.get_pixel(1, 2).0, [f as u8, 1, 2, 255], "tile {i}");
            assert_eq!(tile, sheet_tile(&sub.normal[0], i as u32, sub.columns, t));
        }
    }

    /// Against a direct computation on a 4×4 sheet of 2×2-texel blocks: a full block
    /// keeps its mean colour and majority part, a block a quarter covered is transparent, a
    /// block three quarters covered keeps the covered texels' colour (premultiplied).
    #[test]
    fn far_impostor_sheets_average_blocks_and_keep_the_majority_part() {
        let mut c = image::RgbaImage::new(4, 4);
        let mut n = image::RgbaImage::new(4, 4);
        // Block (0, 0): all covered, colours 0/100/200/100 in red, parts 3, 3, 3, 7.
        for (i, (x, y)) in [(0, 0), (1, 0), (0, 1), (1, 1)].into_iter().enumerate() {
            c.put_pixel(x, y, image::Rgba([[0, 100, 200, 100][i], 10, 20, 255]));
            n.put_pixel(x, y, image::Rgba([128, 128, 255, [3, 3, 3, 7][i]]));
        }
        // Block (1, 0): one texel of four covered.
        c.put_pixel(2, 0, image::Rgba([255, 255, 255, 255]));
        n.put_pixel(2, 0, image::Rgba([255, 128, 128, 5]));
        // Block (0, 1): three covered, all colour 90.
        for (x, y) in [(0, 2), (1, 2), (0, 3)] {
            c.put_pixel(x, y, image::Rgba([90, 90, 90, 255]));
            n.put_pixel(x, y, image::Rgba([128, 255, 128, 2]));
        }
        let d = ImpostorData {
            color_blocks: Vec::new(),
            normal_blocks: Vec::new(),
            columns: 1,
            rows: 1,
            color: vec![c.clone()],
            normal: vec![n],
        };
        let half = d.downsampled(2);
        assert_eq!(half.color[0].dimensions(), (2, 2));
        assert_eq!(half.color[0].get_pixel(0, 0).0, [100, 10, 20, 255]);
        assert_eq!(half.normal[0].get_pixel(0, 0).0[3], 3);
        let q = half.color[0].get_pixel(1, 0).0;
        assert!(q[3] < 128, "a quarter-covered block is drawn as empty: {q:?}");
        let t = half.color[0].get_pixel(0, 1).0;
        assert_eq!(t, [90, 90, 90, 191]);
        assert_eq!(half.normal[0].get_pixel(0, 1).0, [128, 255, 128, 2]);
        // An empty block stays empty; factors that do not divide keep the sheets.
        assert_eq!(half.color[0].get_pixel(1, 1).0, [0, 0, 0, 0]);
        assert_eq!(d.downsampled(3).color[0], c);
        assert_eq!(d.downsampled(1).color[0], c);
        // Normals at half the colour's resolution: the whole sheet's majority part (of the
        // eight covered texels three are part 2, three part 3, one 5 and one 7: the lower
        // number wins the tie) and the colour as before.
        let split = d.downsampled_split(2, 4);
        assert_eq!(split.color[0], half.color[0]);
        assert_eq!(split.normal[0].dimensions(), (1, 1));
        assert_eq!(split.normal[0].get_pixel(0, 0).0[3], 2);
        assert_eq!(d.downsampled_split(2, 3).normal[0].dimensions(), (4, 4));
    }

    #[test]
    fn rep_set_parses_lists_and_rejects_unknown_words() {
        assert_eq!(RepSet::parse("all").unwrap(), RepSet::ALL);
        let s = RepSet::parse("polypostor, np3d").unwrap();
        assert!(s.polypostor && s.np3d && !s.impostor && !s.rigid);
        assert!(RepSet::parse("impostors").unwrap_err().contains("impostors"));
        assert!(RepSet::parse("").is_err());
    }
}
