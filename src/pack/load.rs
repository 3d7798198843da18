//! Loading a pack, validating everything: a damaged or forged pack gives a clear error, never
//! a panic or an out-of-bounds read later (every offset, count and index is checked here).

use std::path::{Path, PathBuf};

use super::format::{FORMAT_NAME, FORMAT_VERSION, Manifest};

#[derive(Debug, thiserror::Error)]
pub enum PackError {
    #[error("cannot read '{path}': {message}")]
    Io { path: PathBuf, message: String },
    #[error("manifest.json is not a valid pack manifest: {0}")]
    Manifest(String),
    #[error("not a polypostor pack (format '{0}')")]
    NotAPack(String),
    #[error("pack version {0} is not supported (this build reads version {FORMAT_VERSION})")]
    Version(u32),
    #[error("damaged pack: {0}")]
    Damaged(String),
}

/// One view's data, checked.
#[derive(Debug)]
pub struct LoadedView {
    pub atlas: image::RgbaImage,
    /// Half the atlas size in each direction.
    pub normals: image::RgbaImage,
}

/// A validated pack in memory.
#[derive(Debug)]
pub struct LoadedPack {
    pub manifest: Manifest,
    /// `vertices.bin` decoded to [0, 1] (see [`LoadedPack::part_vertices`] for view-plane
    /// positions).
    pub vertices: Vec<f32>,
    pub indices: Vec<u16>,
    pub views: Vec<LoadedView>,
}

/// Largest file the loader reads.
const MAX_FILE: u64 = 1 << 32;

pub(crate) fn read(path: &Path, limit: u64) -> Result<Vec<u8>, PackError> {
    let io = |e: std::io::Error| PackError::Io {
        path: path.to_owned(),
        message: e.to_string(),
    };
    let len = std::fs::metadata(path).map_err(io)?.len();
    if len > limit {
        return Err(PackError::Damaged(format!(
            "{} is {len} bytes, more than the {limit} expected",
            path.display()
        )));
    }
    std::fs::read(path).map_err(io)
}

/// A file name inside the pack folder (no paths, no parent references).
pub(crate) fn member(dir: &Path, name: &str) -> Result<PathBuf, PackError> {
    if name.is_empty() || name.contains('/') || name.contains('\\') || name == ".." || name == "." {
        return Err(PackError::Damaged(format!(
            "file name '{name}' is not a plain name in the pack folder"
        )));
    }
    Ok(dir.join(name))
}

pub fn load_pack(dir: &Path) -> Result<LoadedPack, PackError> {
    let text = read(&dir.join("manifest.json"), 64 << 20)?;
    let manifest: Manifest = serde_json::from_slice(&text).map_err(|e| PackError::Manifest(e.to_string()))?;
    if manifest.format != FORMAT_NAME {
        return Err(PackError::NotAPack(manifest.format.clone()));
    }
    if manifest.version != FORMAT_VERSION {
        return Err(PackError::Version(manifest.version));
    }
    let damaged = |m: String| PackError::Damaged(m);
    if manifest.frames == 0 || manifest.frames > 10_000 {
        return Err(damaged(format!("frame count {} is out of range", manifest.frames)));
    }
    if manifest.key_frame >= manifest.frames {
        return Err(damaged(format!(
            "key frame {} is not below the frame count {}",
            manifest.key_frame, manifest.frames
        )));
    }
    if !(manifest.fps.is_finite() && manifest.fps > 0.0) {
        return Err(damaged(format!("frame rate {} is not a positive number", manifest.fps)));
    }
    if manifest.views.is_empty() {
        return Err(damaged("the pack has no views".into()));
    }
    let vbytes = read(&member(dir, &manifest.vertex_file)?, MAX_FILE)?;
    let ibytes = read(&member(dir, &manifest.index_file)?, MAX_FILE)?;
    if vbytes.len() as u64 != manifest.vertex_bytes || vbytes.len() % 2 != 0 {
        return Err(damaged(format!(
            "{} has {} bytes, the manifest says {}",
            manifest.vertex_file,
            vbytes.len(),
            manifest.vertex_bytes
        )));
    }
    if ibytes.len() as u64 != manifest.index_bytes || ibytes.len() % 2 != 0 {
        return Err(damaged(format!(
            "{} has {} bytes, the manifest says {}",
            manifest.index_file,
            ibytes.len(),
            manifest.index_bytes
        )));
    }
    let vertices: Vec<f32> = vbytes
        .chunks_exact(2)
        .map(|b| u16::from_le_bytes([b[0], b[1]]) as f32 / 65535.0)
        .collect();
    let indices: Vec<u16> = ibytes
        .chunks_exact(2)
        .map(|b| u16::from_le_bytes([b[0], b[1]]))
        .collect();
    let parts = manifest.parts.len();
    let frames = manifest.frames as u64;
    let mut views = Vec::with_capacity(manifest.views.len());
    for (v, view) in manifest.views.iter().enumerate() {
        let what = format!("view {v}");
        let cam = &view.camera;
        let finite = cam
            .center
            .iter()
            .chain(&cam.right)
            .chain(&cam.up)
            .chain(&cam.forward)
            .all(|x| x.is_finite());
        if !finite || !(cam.half_size.is_finite() && cam.half_size > 0.0) {
            return Err(damaged(format!("{what}: camera values are not valid")));
        }
        if view.parts.len() != parts {
            return Err(damaged(format!(
                "{what}: {} part entries for {parts} parts",
                view.parts.len()
            )));
        }
        let mut seen = vec![false; parts];
        for &o in &view.order {
            let o = o as usize;
            if o >= parts || std::mem::replace(&mut seen[o], true) {
                return Err(damaged(format!(
                    "{what}: drawing order {:?} is not a permutation of the parts",
                    view.order
                )));
            }
        }
        if view.order.len() != parts {
            return Err(damaged(format!(
                "{what}: drawing order lists {} of {parts} parts",
                view.order.len()
            )));
        }
        let [aw, ah] = view.atlas_size;
        if aw < 2 || ah < 2 || aw > 16384 || ah > 16384 || aw % 2 != 0 || ah % 2 != 0 {
            return Err(damaged(format!("{what}: atlas size {aw}×{ah} is not valid")));
        }
        for (p, part) in view.parts.iter().enumerate() {
            let Some(part) = part else { continue };
            let w = format!("{what} part {p}");
            let vc = part.vertex_count as u64;
            if vc < 3 || part.index_count == 0 || part.index_count % 3 != 0 {
                return Err(damaged(format!("{w}: {vc} vertices and {} indices", part.index_count)));
            }
            let floats = vc
                .checked_mul(2 * (1 + frames))
                .ok_or_else(|| damaged(format!("{w}: vertex count overflows")))?;
            let end = part
                .vertex_offset
                .checked_add(floats)
                .ok_or_else(|| damaged(format!("{w}: vertex range overflows")))?;
            if end > vertices.len() as u64 {
                return Err(damaged(format!(
                    "{w}: vertices {}..{end} lie past the end of the vertex data ({})",
                    part.vertex_offset,
                    vertices.len()
                )));
            }
            let iend = part
                .index_offset
                .checked_add(part.index_count as u64)
                .ok_or_else(|| damaged(format!("{w}: index range overflows")))?;
            if iend > indices.len() as u64 {
                return Err(damaged(format!(
                    "{w}: indices {}..{iend} lie past the end of the index data ({})",
                    part.index_offset,
                    indices.len()
                )));
            }
            if let Some(bad) = indices[part.index_offset as usize..iend as usize]
                .iter()
                .find(|&&i| i as u64 >= vc)
            {
                return Err(damaged(format!("{w}: index {bad} refers past its {vc} vertices")));
            }
            let [x, y, rw, rh] = part.atlas_rect;
            if rw == 0 || rh == 0 || x as u64 + rw as u64 > aw as u64 || y as u64 + rh as u64 > ah as u64 {
                return Err(damaged(format!(
                    "{w}: atlas rectangle {:?} lies outside the {aw}×{ah} atlas",
                    part.atlas_rect
                )));
            }
        }
        let atlas = png(dir, &view.atlas, [aw, ah])?;
        let normals = png(dir, &view.normal_atlas, [aw / 2, ah / 2])?;
        views.push(LoadedView { atlas, normals });
    }
    Ok(LoadedPack {
        manifest,
        vertices,
        indices,
        views,
    })
}

/// Decodes the PNG `name` of the pack folder and checks its size.
pub(crate) fn png(dir: &Path, name: &str, size: [u32; 2]) -> Result<image::RgbaImage, PackError> {
    let path = member(dir, name)?;
    let bytes = read(&path, 256 << 20)?;
    let mut reader = image::ImageReader::with_format(std::io::Cursor::new(bytes), image::ImageFormat::Png);
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(16384);
    limits.max_image_height = Some(16384);
    reader.limits(limits);
    let img = reader
        .decode()
        .map_err(|e| PackError::Damaged(format!("{}: {e}", path.display())))?
        .to_rgba8();
    if [img.width(), img.height()] != size {
        return Err(PackError::Damaged(format!(
            "{}: {}×{} pixels, the manifest says {}×{}",
            path.display(),
            img.width(),
            img.height(),
            size[0],
            size[1]
        )));
    }
    Ok(img)
}

impl LoadedPack {
    /// Part `p` of view `v`: UVs (atlas-normalised) and the positions at `frame` (view-plane
    /// coordinates in [-1, 1]), as interleaved x, y values.
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
