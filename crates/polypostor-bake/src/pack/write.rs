//! Writing a pack from a bake, atomically: everything goes to a temporary folder beside the
//! target, which is renamed into place only when complete.

use std::path::{Path, PathBuf};

use super::atlas::{Atlas, AtlasItem, pack_atlas};
use crate::bake::pipeline::{Bake, TextureEncoding};
pub use crate::bake::report::PackStats;
use crate::pack::{
    Checksums, FORMAT_NAME, FORMAT_VERSION, Manifest, ManifestKey, ManifestPart, ManifestView, PackCamera, put_file,
};
use polypostor_runtime::quant::PositionBox;
use polypostor_runtime::texture::BcFormat;

fn io(path: &Path, e: impl std::fmt::Display) -> String {
    format!("{}: {e}", path.display())
}

/// Writes the pack of `bake` to the folder `out` (replacing it only once the new pack is
/// complete).
pub fn write_pack(bake: &Bake, character: &str, clip: Option<&str>, out: &Path) -> Result<PackStats, String> {
    write_pack_with(bake, character, clip, out, &|_, _| Ok(()))
}

/// [`write_pack`], with `extra(folder, stats)` writing more files (a report, debug images)
/// into the pack folder before it is moved into place.
pub fn write_pack_with(
    bake: &Bake,
    character: &str,
    clip: Option<&str>,
    out: &Path,
    extra: &dyn Fn(&Path, &PackStats) -> Result<(), String>,
) -> Result<PackStats, String> {
    write_folder_atomic(out, &|tmp| {
        let stats = write_into(bake, character, clip, tmp)?;
        extra(tmp, &stats)?;
        Ok(stats)
    })
}

/// Writes a folder with `fill(temporary folder)` beside `out`, then moves it into place,
/// replacing `out` only once `fill` succeeded (on failure nothing the user had is touched).
///
/// `out` must pass [`crate::safe_fs::check_bake_output`] (new, empty, or a folder this tool
/// wrote), checked again right before the replacement. The staging folders are
/// `.NAME.writing-PID` and `.NAME.old-PID` beside `out`; those that killed writers left are
/// removed first.
pub fn write_folder_atomic<T>(out: &Path, fill: &dyn Fn(&Path) -> Result<T, String>) -> Result<T, String> {
    let out = &crate::safe_fs::without_missing_dotdot(out);
    crate::safe_fs::check_bake_output(out, &[])?;
    let parent = out
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .map(Path::to_owned)
        .unwrap_or_else(|| PathBuf::from("."));
    std::fs::create_dir_all(&parent).map_err(|e| io(&parent, e))?;
    crate::safe_fs::clean_stale_staging(&parent);
    let name = out
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "pack".into());
    let pid = std::process::id();
    let tmp = parent.join(crate::safe_fs::staging_name(&name, "writing", pid));
    let _ = std::fs::remove_dir_all(&tmp);
    std::fs::create_dir_all(&tmp).map_err(|e| io(&tmp, e))?;
    let filled = fill(&tmp).and_then(|value| {
        // The folder may have changed during a long bake: check again before replacing it.
        crate::safe_fs::check_bake_output(out, &[])?;
        Ok(value)
    });
    match filled {
        Ok(value) => {
            let old = parent.join(crate::safe_fs::staging_name(&name, "old", pid));
            let had_old = std::fs::symlink_metadata(out).is_ok();
            if had_old && let Err(e) = std::fs::rename(out, &old) {
                let _ = std::fs::remove_dir_all(&tmp);
                return Err(io(out, e));
            }
            if let Err(e) = std::fs::rename(&tmp, out) {
                if had_old {
                    let _ = std::fs::rename(&old, out);
                }
                let _ = std::fs::remove_dir_all(&tmp);
                return Err(io(out, e));
            }
            if had_old {
                let _ = std::fs::remove_dir_all(&old);
            }
            Ok(value)
        }
        Err(e) => {
            let _ = std::fs::remove_dir_all(&tmp);
            Err(e)
        }
    }
}

/// Where one key's block, triangles and coarse triangles went, and their bytes.
struct WrittenKey {
    vertex_offset: u64,
    index_offset: u64,
    /// 0 when the polygon has no coarse level.
    coarse_offset: u64,
    coarse_count: u32,
    bytes: u64,
}

/// A key block's positions (pixels of `r`² tiles, frame by frame) as (x + 1) / 2, (y + 1) / 2
/// of view-plane coordinates, one byte each inside the block's box (format 7).
fn quantised_block(positions: &[Vec<[f32; 2]>], r: f32) -> (PositionBox, Vec<u8>) {
    let values: Vec<f32> = positions
        .iter()
        .flatten()
        .flat_map(|q| [q[0] / r, 1.0 - q[1] / r])
        .collect();
    let bx = PositionBox::around(&values);
    let bytes = bx.quantise_all(&values);
    (bx, bytes)
}

/// The texture coordinates of a key block (pixels of the key tile), moved with the positions'
/// rounding where every frame of the block draws the key image itself (a still part: its
/// positions are the texture coordinates): stored as bytes of the block's box, those
/// positions land up to half a step (a fifth of a pixel for a part the size of the view) off,
/// and the key image would be drawn that far off its own texels, every colour edge blended
/// with its neighbour. Moving the texture coordinates by the same rounding draws it exactly.
/// Not where other frames move: their own rounding is independent of the key frame's, and
/// the two would add (measured: SimpleSkin's animated plane −0.44 dB).
fn key_aligned_uvs(
    fit: &crate::bake::part_fit::PartFit,
    positions: &[Vec<[f32; 2]>],
    bx: &PositionBox,
    bytes: &[u8],
    r: f32,
) -> Vec<[f32; 2]> {
    let uvs = fit.uvs();
    if positions.is_empty() || positions.iter().any(|p| *p != uvs) {
        return uvs;
    }
    let n = uvs.len();
    let decoded: Vec<f32> = bx.values(&bytes[..2 * n]).collect();
    decoded
        .chunks_exact(2)
        .map(|xy| [xy[0] * r, (1.0 - xy[1]) * r])
        .collect()
}

/// One key's block before it is written: its positions as bytes in their box, its texture
/// coordinates (tile pixels) and its coarse level.
struct PreparedKey {
    bx: PositionBox,
    bytes: Vec<u8>,
    uvs: Vec<[f32; 2]>,
    triangles: Vec<[usize; 3]>,
    coarse: Vec<[usize; 3]>,
}

impl PreparedKey {
    /// The key `fit` over `count` frames from `start` (of a timeline of `frames`), for `r`²
    /// tiles.
    fn new(fit: &crate::bake::part_fit::PartFit, start: usize, count: usize, frames: usize, r: f32) -> Self {
        let positions: Vec<Vec<[f32; 2]>> = (0..count).map(|s| fit.positions((start + s) % frames)).collect();
        let (bx, bytes) = quantised_block(&positions, r);
        let uvs = key_aligned_uvs(fit, &positions, &bx, &bytes, r);
        let coarse = crate::bake::part_fit::coarse_of(fit, &positions);
        Self {
            bx,
            bytes,
            uvs,
            triangles: fit.triangles.clone(),
            coarse,
        }
    }

    /// Every triangle (tile pixels) the run time may draw the key's image with: the
    /// polygon's, its coarse level's, and the crowd's thinned levels over every second and
    /// fourth outline vertex ([`polypostor_runtime::triangulate::thinned`], over the outline
    /// the run time finds, [`polypostor_runtime::triangulate::outline_len`]). Each chord of a
    /// thinned level also brings the fan from its first vertex over the outline it cuts off,
    /// so the texels stay kept where the run time, from the UVs as rounded in the pack, finds
    /// a thinned polygon simple that the bake, from these, did not.
    fn sampled_triangles(&self) -> Vec<[[f32; 2]; 3]> {
        let n = self.uvs.len();
        let words: Vec<u16> = self.triangles.iter().flatten().map(|&i| i as u16).collect();
        let outline = &self.uvs[..polypostor_runtime::triangulate::outline_len(&words, n).min(n)];
        let m = outline.len();
        let mut out: Vec<[usize; 3]> = self.triangles.iter().chain(&self.coarse).copied().collect();
        for step in [2usize, 4] {
            if m < 4 * step {
                continue;
            }
            out.extend(
                polypostor_runtime::triangulate::thinned(outline, step)
                    .into_iter()
                    .flatten(),
            );
            out.extend(chord_fans(m, step));
        }
        out.into_iter()
            .filter(|t| t.iter().all(|&i| i < n))
            .map(|t| t.map(|i| self.uvs[i]))
            .collect()
    }
}

/// Under each chord of the outline thinned to every `step`-th of its `m` vertices, the fan
/// from the chord's first vertex over the outline the chord cuts off: with the polygon's own
/// triangles, it covers the thinned polygon wherever its notches are seen whole from their
/// first vertex (a notch of every other vertex is one triangle).
fn chord_fans(m: usize, step: usize) -> Vec<[usize; 3]> {
    let mut out = Vec::new();
    for i in (0..m).step_by(step.max(1)) {
        for j in i + 1..(i + step).min(m) {
            out.push([i, j, (j + 1) % m]);
        }
    }
    out
}

/// A view's keys prepared for writing (every part's first key, then every extra key, part
/// by part), per part where its extra keys are in that list, and the atlas of their images
/// (which keeps the texels their triangles, at every level, can sample).
fn pack_view(
    view: &crate::bake::pipeline::ViewResult,
    frames: usize,
    r: f32,
) -> (Vec<Option<PreparedKey>>, Vec<Vec<usize>>, Atlas) {
    // Each key with its images, in that order.
    let mut keys: Vec<Option<(PreparedKey, &image::RgbaImage, &image::RgbaImage)>> = view
        .parts
        .iter()
        .map(|p| {
            let f = p.fit.as_ref()?;
            Some((PreparedKey::new(f, 0, frames, frames, r), &p.key_color, &p.key_normal))
        })
        .collect();
    let mut extra_item: Vec<Vec<usize>> = Vec::with_capacity(view.parts.len());
    for p in &view.parts {
        let mut list = Vec::new();
        for e in p.extra.iter().filter(|_| p.fit.is_some()) {
            list.push(keys.len());
            let key = PreparedKey::new(&e.fit, e.span.start, e.span.count, frames, r);
            keys.push(Some((key, &e.key_color, &e.key_normal)));
        }
        extra_item.push(list);
    }
    let items: Vec<Option<AtlasItem<'_>>> = keys
        .iter()
        .map(|k| {
            k.as_ref().map(|(k, color, normal)| AtlasItem {
                color,
                normal,
                triangles: k.sampled_triangles(),
            })
        })
        .collect();
    let keys = keys.into_iter().map(|k| k.map(|k| k.0)).collect();
    let atlas = pack_atlas(&items);
    (keys, extra_item, atlas)
}

fn write_into(bake: &Bake, character: &str, clip: Option<&str>, dir: &Path) -> Result<PackStats, String> {
    let r = bake.options.resolution as f32;
    let frames = bake.frame_times.len();
    let mut vertices: Vec<u16> = Vec::new();
    // Everything in vertices.bin is a number in [0, 1] stored as a normalised u16.
    let unorm = |x: f32| (x.clamp(0.0, 1.0) * 65535.0).round() as u16;
    let mut indices: Vec<u16> = Vec::new();
    let mut views = Vec::new();
    let mut stats = PackStats::default();
    let mut sums = Checksums::new();
    let mut triangles = 0usize;
    // Every view's keys and atlas, a few views at a time in parallel (so that no more than
    // a few views' atlases are held at once), written in order.
    let chunk = 2 * rayon::current_num_threads().max(1);
    let packed = bake.views.chunks(chunk).flat_map(|views| {
        use rayon::prelude::*;
        let done: Vec<(Vec<Option<PreparedKey>>, Vec<Vec<usize>>, Atlas)> = views
            .par_iter()
            .map(|view| {
                let _atlas = crate::bake::profile::root("atlas");
                pack_view(view, frames, r)
            })
            .collect();
        done
    });
    for ((v, view), (keys, extra_item, atlas)) in bake.views.iter().enumerate().zip(packed) {
        let most = polypostor_runtime::pack::MAX_ATLAS_SIDE;
        let count = keys.iter().flatten().count();
        let bound = polypostor_runtime::pack::atlas_area_bound(u64::from(bake.options.resolution), count as u64);
        if atlas.width > most || atlas.height > most || u64::from(atlas.width) * u64::from(atlas.height) > bound {
            return Err(format!(
                "view {v}: its {count} key images at {}² need a {}×{} atlas, beyond what the run time loads ({most} texels a side, {bound} in all): lower --resolution or --max-keys",
                bake.options.resolution, atlas.width, atlas.height
            ));
        }
        let ext = bake.options.textures.extension();
        let atlas_name = format!("atlas_{v:03}.{ext}");
        let normal_name = format!("normal_{v:03}.{ext}");
        let textures = [
            (&atlas_name, &atlas.color, BcFormat::Bc7Srgb),
            (&normal_name, &atlas.normal, BcFormat::Bc7Unorm),
        ];
        for (name, img, format) in textures {
            let bytes = crate::bake::profile::in_root("encode", || match bake.options.textures {
                TextureEncoding::Bc7 => super::bc::encode_ktx2(img, format)
                    .ok_or_else(|| format!("{}×{} is not whole 4 × 4 blocks", img.width(), img.height())),
                TextureEncoding::Png => bake.options.png.encode(img),
            })
            .map_err(|e| io(&dir.join(name), &e))?;
            crate::bake::profile::in_root("write", || put_file(dir, name, &bytes, &mut sums))?;
            stats.texture_bytes += img.width() as u64 * img.height() as u64 * 4;
        }
        let (aw, ah) = (atlas.width as f32, atlas.height as f32);
        // One key's block: UVs, then the positions of its frames.
        let write_key = |key: &PreparedKey,
                         rect: &crate::pack::atlas::AtlasRect,
                         vertices: &mut Vec<u16>,
                         indices: &mut Vec<u16>|
         -> WrittenKey {
            let vertex_offset = vertices.len() as u64;
            let index_start = indices.len();
            for &q in &key.uvs {
                let t = rect.to_atlas(q);
                vertices.push(unorm(t[0] / aw));
                vertices.push(unorm(t[1] / ah));
            }
            vertices.extend(key.bx.to_words());
            // x and y of a vertex in one u16 slot.
            vertices.extend(key.bytes.chunks_exact(2).map(|xy| u16::from_le_bytes([xy[0], xy[1]])));
            let index_offset = indices.len() as u64;
            for t in &key.triangles {
                indices.extend(t.iter().map(|&i| i as u16));
            }
            // The coarse level: the polygon simplified on to half its vertices.
            let coarse_offset = indices.len() as u64;
            indices.extend(key.coarse.iter().flatten().map(|&i| i as u16));
            let coarse_count = (key.coarse.len() * 3) as u32;
            WrittenKey {
                vertex_offset,
                index_offset,
                coarse_offset: if coarse_count > 0 { coarse_offset } else { 0 },
                coarse_count,
                bytes: 2 * ((vertices.len() as u64 - vertex_offset) + (indices.len() - index_start) as u64),
            }
        };
        let mut parts = Vec::new();
        for (p, part) in view.parts.iter().enumerate() {
            let (Some(fit), Some(rect), Some(key)) = (&part.fit, atlas.rects[p], keys[p].as_ref()) else {
                parts.push(None);
                continue;
            };
            let first = write_key(key, &rect, &mut vertices, &mut indices);
            // Triangles drawn per character (a part's other keys draw instead of its first).
            triangles += fit.triangles.len();
            let mut extra_keys = Vec::new();
            for (e, &item) in part.extra.iter().zip(&extra_item[p]) {
                let (Some(er), Some(key)) = (atlas.rects[item], keys[item].as_ref()) else {
                    continue;
                };
                let k = write_key(key, &er, &mut vertices, &mut indices);
                stats.extra_key_bytes += 5 * atlas.texels[item] + k.bytes;
                extra_keys.push(ManifestKey {
                    key_frame: e.frame as u32,
                    vertex_offset: k.vertex_offset,
                    vertex_count: e.fit.vertex_count() as u32,
                    index_offset: k.index_offset,
                    index_count: (e.fit.triangles.len() * 3) as u32,
                    coarse_index_offset: k.coarse_offset,
                    coarse_index_count: k.coarse_count,
                    atlas_rect: [er.x, er.y, er.w, er.h],
                    transposed: er.transposed,
                    frame_start: e.span.start as u32,
                    frame_count: e.span.count as u32,
                });
            }
            let frame_keys = if extra_keys.len() == part.extra.len() && !extra_keys.is_empty() {
                part.frame_key.clone()
            } else {
                Vec::new()
            };
            if frame_keys.is_empty() {
                extra_keys.clear();
            }
            parts.push(Some(ManifestPart {
                vertex_offset: first.vertex_offset,
                vertex_count: fit.vertex_count() as u32,
                index_offset: first.index_offset,
                index_count: (fit.triangles.len() * 3) as u32,
                coarse_index_offset: first.coarse_offset,
                coarse_index_count: first.coarse_count,
                atlas_rect: [rect.x, rect.y, rect.w, rect.h],
                transposed: rect.transposed,
                key_frame: fit.key_frame as u32,
                extra_keys,
                frame_keys,
            }));
        }
        views.push(ManifestView {
            direction: view.direction.to_array(),
            camera: PackCamera::from_camera(&view.camera),
            atlas: atlas_name,
            normal_atlas: normal_name,
            atlas_size: [atlas.width, atlas.height],
            order: view.order.iter().map(|&o| o as u32).collect(),
            parts,
        });
    }
    let vbytes: Vec<u8> = vertices.iter().flat_map(|x| x.to_le_bytes()).collect();
    put_file(dir, "vertices.bin", &vbytes, &mut sums)?;
    let ibytes: Vec<u8> = indices.iter().flat_map(|x| x.to_le_bytes()).collect();
    put_file(dir, "indices.bin", &ibytes, &mut sums)?;
    let manifest = Manifest {
        format: FORMAT_NAME.into(),
        version: FORMAT_VERSION,
        character: character.into(),
        character_path: bake.character_path.clone(),
        character_up: bake.character_up,
        clip: clip.map(String::from),
        fps: bake.options.fps,
        frames: frames as u32,
        clips: bake.timeline.spans.clone(),
        key_frame: bake.key_frame as u32,
        resolution: bake.options.resolution,
        parts: bake.segmentation.parts.iter().map(|p| p.name.clone()).collect(),
        views,
        vertex_file: "vertices.bin".into(),
        vertex_bytes: vbytes.len() as u64,
        index_file: "indices.bin".into(),
        index_bytes: ibytes.len() as u64,
        checksums: sums,
    };
    let mpath = dir.join("manifest.json");
    let text = serde_json::to_string_pretty(&manifest).map_err(|e| e.to_string())?;
    std::fs::write(&mpath, text).map_err(|e| io(&mpath, e))?;
    stats.vertex_bytes = vbytes.len() as u64;
    stats.index_bytes = ibytes.len() as u64;
    stats.pack_bytes = stats.texture_bytes + stats.vertex_bytes + stats.index_bytes;
    stats.pack_bytes_bc = stats.texture_bytes / 4 + stats.vertex_bytes + stats.index_bytes;
    stats.file_bytes = std::fs::read_dir(dir)
        .map_err(|e| io(dir, e))?
        .filter_map(|e| e.ok()?.metadata().ok())
        .map(|m| m.len())
        .sum();
    stats.triangles_per_view = triangles as f64 / bake.views.len().max(1) as f64;
    Ok(stats)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bake::part_fit::PartFit;

    fn fit(frames: usize, moved: bool) -> PartFit {
        let key_polygon = vec![[10.3, 20.7], [52.15, 21.9], [48.6, 77.05], [12.2, 70.4]];
        let mut targets = vec![key_polygon.clone(); frames];
        if moved {
            targets[frames - 1] = key_polygon.iter().map(|p| [p[0] + 3.3, p[1] - 1.1]).collect();
        }
        PartFit {
            key_frame: 0,
            key_triangles: vec![[0, 1, 2], [0, 2, 3]],
            targets,
            mappings: vec![vec![0, 1, 2, 3]; frames],
            costs: vec![0.0; frames],
            kept: vec![0, 1, 2, 3],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
            offsets: vec![Vec::new(); frames],
            interior: Vec::new(),
            interior_at: vec![Vec::new(); frames],
            key_polygon,
        }
    }

    /// A still block's texture coordinates follow its positions' rounding exactly (the key
    /// image drawn onto its own texels); a block where any frame moves keeps the fitted
    /// texture coordinates (its frames' roundings are independent).
    #[test]
    fn a_still_block_samples_its_key_image_where_its_rounded_positions_land() {
        let r = 128.0;
        for (moved, frames) in [(false, 1), (false, 5), (true, 5)] {
            let f = fit(frames, moved);
            let positions: Vec<Vec<[f32; 2]>> = (0..frames).map(|s| f.positions(s)).collect();
            let (bx, bytes) = quantised_block(&positions, r);
            let uvs = key_aligned_uvs(&f, &positions, &bx, &bytes, r);
            let decoded: Vec<f32> = bx.values(&bytes[..8]).collect();
            let drawn: Vec<[f32; 2]> = decoded
                .chunks_exact(2)
                .map(|xy| [xy[0] * r, (1.0 - xy[1]) * r])
                .collect();
            if moved {
                assert_eq!(uvs, f.uvs());
            } else {
                let off = uvs
                    .iter()
                    .zip(&drawn)
                    .map(|(a, b)| (a[0] - b[0]).abs().max((a[1] - b[1]).abs()))
                    .fold(0.0f32, f32::max);
                assert!(off < 1e-4, "{off}");
                // The rounding itself is not nothing here (what the alignment is for).
                let before = f
                    .uvs()
                    .iter()
                    .zip(&drawn)
                    .map(|(a, b)| (a[0] - b[0]).abs().max((a[1] - b[1]).abs()))
                    .fold(0.0f32, f32::max);
                assert!(before > 0.01, "{before}");
            }
        }
    }

    /// Even-odd point-in-polygon: the independent answer for what a thinned level covers.
    fn inside(poly: &[[f32; 2]], p: [f32; 2]) -> bool {
        let mut c = false;
        let mut j = poly.len() - 1;
        for i in 0..poly.len() {
            let (a, b) = (poly[i], poly[j]);
            if (a[1] > p[1]) != (b[1] > p[1]) && p[0] < (b[0] - a[0]) * (p[1] - a[1]) / (b[1] - a[1]) + a[0] {
                c = !c;
            }
            j = i;
        }
        c
    }

    fn in_triangle(t: &[[f32; 2]; 3], p: [f32; 2]) -> bool {
        let d = |a: [f32; 2], b: [f32; 2]| (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]);
        let (x, y, z) = (d(t[0], t[1]), d(t[1], t[2]), d(t[2], t[0]));
        let e = 1e-3;
        (x >= -e && y >= -e && z >= -e) || (x <= e && y <= e && z <= e)
    }

    #[test]
    fn the_atlas_keeps_every_point_a_thinned_level_draws() {
        // Spiky outlines (every other vertex pulled in): thinning cuts chords across the
        // notches, outside the polygon itself. Every point of the polygon over every second or
        // fourth vertex (even-odd, whether or not it is simple) must lie in a kept triangle.
        for (n, depth, seed) in [(24usize, 0.5f32, 1u32), (40, 0.8, 2), (33, 0.3, 3), (16, 0.9, 4)] {
            let uvs: Vec<[f32; 2]> = (0..n)
                .map(|k| {
                    let a = k as f32 * std::f32::consts::TAU / n as f32;
                    let wobble = (((k as u32).wrapping_mul(2654435761) ^ seed) % 100) as f32 / 400.0;
                    let r = 30.0 * if k % 2 == 1 { 1.0 - depth } else { 1.0 } + wobble * 10.0;
                    [64.0 + r * a.cos(), 64.0 + r * a.sin()]
                })
                .collect();
            let triangles = polypostor_runtime::triangulate::triangulate(&uvs).expect("a simple star");
            let key = PreparedKey {
                bx: PositionBox::around(&[0.0, 0.0]),
                bytes: Vec::new(),
                uvs: uvs.clone(),
                triangles,
                coarse: Vec::new(),
            };
            let kept = key.sampled_triangles();
            // The fans alone with the polygon (what holds where the bake's thinned level is
            // not simple and the run time's, from rounded UVs, is).
            let fans = |step: usize| -> Vec<[[f32; 2]; 3]> {
                key.triangles
                    .iter()
                    .copied()
                    .chain(chord_fans(n, step))
                    .map(|t| t.map(|i| uvs[i]))
                    .collect()
            };
            for step in [2usize, 4] {
                if n < 4 * step {
                    continue;
                }
                let thin: Vec<[f32; 2]> = uvs.iter().step_by(step).copied().collect();
                let mut checked = 0;
                for y in 0..128 {
                    for x in 0..128 {
                        let p = [x as f32 + 0.37, y as f32 + 0.61];
                        if inside(&thin, p) && !inside(&uvs, p) {
                            checked += 1;
                            assert!(
                                kept.iter().any(|t| in_triangle(t, p)),
                                "n {n} step {step}: {p:?} left out"
                            );
                            assert!(
                                fans(step).iter().any(|t| in_triangle(t, p)),
                                "n {n} step {step}: {p:?} outside the fans"
                            );
                        }
                    }
                }
                assert!(checked > 50, "n {n} step {step}: only {checked} points in the notches");
            }
        }
    }
}
