//! The bake report (`report.json`) and debug images.

use serde::{Deserialize, Serialize};

use crate::bake::pipeline::Bake;

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PartReport {
    pub name: String,
    /// PSNR of the part against its own render, per frame (dB).
    pub psnr: Vec<f64>,
    /// SSIM of the same, per frame ([`crate::metrics`]).
    #[serde(default)]
    pub ssim: Vec<f64>,
    /// Fit error (the DP objective) per frame.
    pub fit_cost: Vec<f64>,
    /// The same per pixel of the frame's target outline (comparable across parts and frames
    /// of different sizes, as PSNR is).
    #[serde(default)]
    pub fit_cost_per_pixel: Vec<f64>,
    pub vertices: usize,
    pub triangles: usize,
    pub problem: Option<String>,
    /// The part's key frames, its first (the view's) first.
    #[serde(default)]
    pub key_frames: Vec<usize>,
    /// Per frame, the index into `key_frames` it is drawn from (empty: all from the first).
    #[serde(default)]
    pub frame_key: Vec<u8>,
    /// How much the extra keys cut the part's error over all frames (dB).
    #[serde(default)]
    pub keys_gain_db: f64,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ViewReport {
    pub index: usize,
    pub direction: [f32; 3],
    /// Composited character PSNR per frame (dB).
    pub psnr: Vec<f64>,
    /// The same for still key-frame polygons (what fitting gains).
    pub psnr_static: Vec<f64>,
    /// Over its frames ([`mean_psnr`]: the PSNR of the mean RMSE).
    pub mean_psnr: f64,
    /// Composited character SSIM per frame, and its mean.
    #[serde(default)]
    pub ssim: Vec<f64>,
    #[serde(default)]
    pub mean_ssim: f64,
    /// Composited silhouette agreement per frame (the pixels both the composite and the
    /// render cover over those either covers), and its mean: what PSNR and SSIM cannot see of
    /// a dark character's shape.
    #[serde(default)]
    pub silhouette_iou: Vec<f64>,
    #[serde(default)]
    pub mean_silhouette_iou: f64,
    pub order: Vec<usize>,
    pub parts: Vec<PartReport>,
    /// This view's texture key frame.
    #[serde(default)]
    pub key_frame: usize,
    /// Every key frame of the view (the first first), with its bytes and what it buys.
    #[serde(default)]
    pub keys: Vec<crate::bake::keys::ViewKey>,
    /// `hidden[a][b]`: pixels of part b hidden by part a, averaged over frames (the
    /// occlusion graph the order comes from).
    #[serde(default)]
    pub hidden: Vec<Vec<f64>>,
    /// The key budget this view's keys were chosen with when the bake's shared budget gave
    /// it more than the settings' (`pipeline::share_key_budget`); re-fits use it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub key_budget: Option<f64>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct WorstView {
    pub view: usize,
    pub mean_psnr: f64,
    #[serde(default)]
    pub mean_ssim: f64,
    pub direction: [f32; 3],
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Settings {
    pub views: usize,
    pub resolution: u32,
    pub fps: f32,
    pub frames: usize,
    pub clip: Option<String>,
    pub exhaustive: bool,
    pub fold_free: bool,
    /// The objective charges target coverage the mapped polygon leaves out (false in
    /// reports written before it did).
    #[serde(default)]
    pub charge_missed_coverage: bool,
    /// Fast mode: error per source pixel above which a frame is searched again from a
    /// coarse global solution (`null`: restarts off).
    pub restart_threshold: Option<f64>,
    /// Drawn vertices placed to fractions of a pixel after the fit (false in reports written
    /// before they were).
    #[serde(default)]
    pub subpixel: bool,
    pub key_vertices: usize,
    pub frame_vertices: usize,
    pub final_vertices: usize,
    /// Most vertices added inside each part's polygon (0 in reports written before there
    /// were any).
    #[serde(default)]
    pub interior_vertices: usize,
    /// How key images were chosen (absent in reports from before several keys: one key).
    #[serde(default)]
    pub keys: Option<crate::bake::keys::KeyOptions>,
    /// How the atlases were written (absent in reports from before BC7: PNG).
    #[serde(default)]
    pub textures: Option<crate::bake::pipeline::TextureEncoding>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Report {
    pub character: String,
    pub adapter: String,
    pub settings: Settings,
    pub seconds_total: f64,
    pub stage_seconds: std::collections::BTreeMap<String, f64>,
    /// CPU seconds per stage, summed over threads (see `bake::profile`): `job` or
    /// `job/stage`, e.g. `part fit/restart`. Filled by the folder bake; empty otherwise.
    #[serde(default)]
    pub cpu_seconds: std::collections::BTreeMap<String, f64>,
    /// How many times each of `cpu_seconds`' stages ran (and events such as
    /// `restart improved >1 %`).
    #[serde(default)]
    pub cpu_counts: std::collections::BTreeMap<String, u64>,
    pub key_frame: usize,
    pub mean_psnr: f64,
    pub worst_psnr: f64,
    pub mean_psnr_static: f64,
    /// Mean and lowest composited SSIM over every view and frame.
    #[serde(default)]
    pub mean_ssim: f64,
    #[serde(default)]
    pub worst_ssim: f64,
    /// Mean composited silhouette agreement over every view and frame.
    #[serde(default)]
    pub mean_silhouette_iou: f64,
    /// How dark the renders are: the mean over views of the mean brightest channel of their
    /// covered pixels (0..1); under [`crate::bake::pipeline::DARK_BRIGHTNESS`] PSNR and SSIM
    /// see little of the shape. 1 in reports written before it was measured.
    #[serde(default = "fully_bright")]
    pub truth_brightness: f64,
    pub pack_bytes: u64,
    pub pack_bytes_bc: u64,
    pub pack_file_bytes: u64,
    /// Classic animated impostors at the same settings: colour + normal RGBA8 per view per frame.
    pub impostor_bytes: u64,
    pub impostor_bytes_bc: u64,
    /// `impostor_bytes / pack_bytes`.
    pub memory_ratio: f64,
    /// Key images after each view's first: how many (over parts and views) and their bytes
    /// (included in `pack_bytes`).
    #[serde(default)]
    pub extra_keys: usize,
    #[serde(default)]
    pub extra_key_bytes: u64,
    pub triangles_per_view: f64,
    /// The views with the lowest mean PSNR, worst first (where the artist should look).
    pub worst_views: Vec<WorstView>,
    pub views: Vec<ViewReport>,
    /// The project's corrections this bake could not apply, by kind.
    #[serde(default)]
    pub dropped_corrections: crate::bake::overrides::DroppedCorrections,
    /// Per clip of the pack (one entry for a one-clip pack): its error and what it costs,
    /// next to classic impostors of that clip alone.
    #[serde(default)]
    pub clips: Vec<ClipReport>,
    /// Views in which no part of the character was traced (it is under a pixel wide, or
    /// cut out, from there): they draw nothing, and their error — measured against the
    /// same empty part images — says nothing, so they are left out of every mean and
    /// worst figure above (and of the clips').
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub empty_views: Vec<usize>,
}

impl Report {
    /// What to say of [`Report::empty_views`]: `None` when every view traced something.
    pub fn empty_views_note(&self) -> Option<String> {
        let e = &self.empty_views;
        if e.is_empty() {
            return None;
        }
        let mut shown: Vec<String> = e.iter().take(8).map(|v| v.to_string()).collect();
        if e.len() > 8 {
            shown.push("…".into());
        }
        let one = e.len() == 1;
        Some(format!(
            "{} of {} views trace no part of the character (view{} {}): from there it is under a pixel wide or cut \
             out at {r}²; {} nothing and {} left out of the means; a higher --resolution keeps {}",
            e.len(),
            self.views.len(),
            if one { "" } else { "s" },
            shown.join(", "),
            if one { "that view draws" } else { "those views draw" },
            if one { "is" } else { "are" },
            if one { "it" } else { "them" },
            r = self.settings.resolution
        ))
    }
}

/// One clip of a (whole-character) pack.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ClipReport {
    pub name: String,
    pub first_frame: usize,
    pub frames: usize,
    /// Measured ground speed at the clip's own rate (world units per second).
    pub ground_speed: f32,
    /// Composited PSNR and SSIM over every view and frame of the clip.
    pub mean_psnr: f64,
    pub worst_psnr: f64,
    pub mean_ssim: f64,
    /// Its vertex animation (polygon positions of its frames, every key, view and part).
    pub animation_bytes: u64,
    /// The pack with this clip alone: the shared key images, UVs and triangles plus its
    /// animation.
    pub alone_bytes: u64,
    /// Classic animated impostors of this clip at the same settings.
    pub impostor_bytes: u64,
    /// `impostor_bytes / alone_bytes`.
    pub memory_ratio: f64,
}

/// Bytes of polygon positions a bake's pack holds for the frames in `range` (2 a vertex a
/// frame: a byte per coordinate inside the block's box, `quant`), over every view, part
/// and key.
pub fn animation_bytes(bake: &Bake, range: std::ops::Range<usize>) -> u64 {
    let frames = bake.frame_times.len();
    let mut n = 0u64;
    for v in &bake.views {
        for part in &v.parts {
            let Some(fit) = &part.fit else { continue };
            n += 2 * (fit.vertex_count() * range.len()) as u64;
            // Extra keys hold only their span's frames (as the pack writes them).
            if part.frame_key.is_empty() {
                continue;
            }
            for e in &part.extra {
                let inside = range.clone().filter(|&f| e.span.contains(f, frames)).count();
                n += 2 * (e.fit.vertex_count() * inside) as u64;
            }
        }
    }
    n
}

impl Report {
    /// The options that made this bake (for re-fitting single views the same way):
    /// settings, clip by name in `character`, the coverage its view directions show.
    pub fn bake_options(&self, character: &crate::character::Character) -> crate::bake::pipeline::BakeOptions {
        let s = &self.settings;
        let full_sphere = self.views.iter().any(|v| v.direction[1] < -1e-3);
        crate::bake::pipeline::BakeOptions {
            views: s.views,
            coverage: if full_sphere {
                crate::bake::viewpoints::Coverage::FullSphere
            } else {
                crate::bake::viewpoints::Coverage::UpperHemisphere
            },
            resolution: s.resolution,
            fps: s.fps,
            clip: s.clip.as_deref().and_then(|n| character.find_clip(n)),
            extra_clips: self
                .clips
                .iter()
                .skip(1)
                .filter_map(|c| character.find_clip(&c.name))
                .collect(),
            key_frame: crate::bake::pipeline::KeyFrame::Frame(self.key_frame),
            fit: crate::bake::part_fit::PartFitOptions {
                key_vertices: s.key_vertices,
                frame_vertices: s.frame_vertices,
                final_vertices: s.final_vertices,
                exhaustive: s.exhaustive,
                fold_free: s.fold_free,
                charge_missed_coverage: s.charge_missed_coverage,
                restart_threshold: s.restart_threshold.unwrap_or(f64::INFINITY),
                subpixel: s.subpixel,
                interior_vertices: s.interior_vertices,
                ..Default::default()
            },
            keys: s.keys.unwrap_or(crate::bake::keys::KeyOptions::SINGLE),
            textures: s.textures.unwrap_or(crate::bake::pipeline::TextureEncoding::Png),
            ..Default::default()
        }
    }
}

/// Reads a bake's `report.json` (a file, or the pack folder holding one).
pub fn read_report(path: &std::path::Path) -> Result<Report, String> {
    let file = if path.is_dir() {
        path.join("report.json")
    } else {
        path.to_owned()
    };
    let bytes = crate::safe_fs::read_regular(&file, 256 << 20, "a bake report").map_err(|e| e.to_string())?;
    serde_json::from_slice(&bytes).map_err(|e| format!("{} is not a bake report: {e}", file.display()))
}

/// A view's key table ([`crate::bake::keys::view_keys`]).
pub fn view_keys_of(v: &crate::bake::pipeline::ViewResult) -> Vec<crate::bake::keys::ViewKey> {
    view_keys_of_parts(&v.parts)
}

/// The key table of a view's fitted parts ([`crate::bake::keys::view_keys`]).
pub fn view_keys_of_parts(parts: &[crate::bake::pipeline::PartResult]) -> Vec<crate::bake::keys::ViewKey> {
    let parts: Vec<_> = parts
        .iter()
        .filter_map(|p| p.fit.as_ref().map(|f| (f, &p.sse[..], &p.extra[..], &p.frame_key[..])))
        .collect();
    crate::bake::keys::view_keys(&parts)
}

fn mean(v: &[f64]) -> f64 {
    if v.is_empty() {
        0.0
    } else {
        v.iter().sum::<f64>() / v.len() as f64
    }
}

/// The PSNR of several frames (dB each) taken together: the PSNR of their mean RMSE, the
/// way `compare` takes its means. The mean of the decibels themselves let a frame drawn
/// exactly (99 dB, the cap) outweigh every other: a box figure at 64² whose extra keys draw
/// most frames unwarped read 66.5 dB where its frames lay between 23 and 31. 0 for none.
pub fn mean_psnr(db: &[f64]) -> f64 {
    if db.is_empty() {
        return 0.0;
    }
    let rmse = db.iter().map(|&p| 10f64.powf(-p / 20.0)).sum::<f64>() / db.len() as f64;
    crate::bake::raster::psnr(rmse)
}

/// Sizes of a written pack.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct PackStats {
    /// Textures (uncompressed RGBA8) + vertex + index data.
    pub pack_bytes: u64,
    pub texture_bytes: u64,
    pub vertex_bytes: u64,
    pub index_bytes: u64,
    /// The same textures block-compressed (BC3/DXT5: 1 byte per texel).
    pub pack_bytes_bc: u64,
    /// Bytes on disk (PNG-compressed atlases).
    pub file_bytes: u64,
    pub triangles_per_view: f64,
    /// What the key images after each view's first take of `pack_bytes` (their atlas
    /// cut-outs' texels, colour and half-resolution normals, without the packing's gaps; and
    /// their vertices and indices).
    pub extra_key_bytes: u64,
}

/// What a report written before brightness was measured reads as: not dark.
fn fully_bright() -> f64 {
    1.0
}

/// Builds the report of a finished bake and its written pack.
pub fn build_report(bake: &Bake, character: &str, clip: Option<&str>, stats: &PackStats, seconds_total: f64) -> Report {
    let frames = bake.frame_times.len();
    let r = bake.options.resolution as u64;
    let impostor_bytes = bake.views.len() as u64 * frames as u64 * r * r * 4 * 2;
    let views: Vec<ViewReport> = bake
        .views
        .iter()
        .enumerate()
        .map(|(i, v)| ViewReport {
            index: i,
            direction: v.direction.to_array(),
            psnr: v.error.psnr.clone(),
            psnr_static: v.error.psnr_static.clone(),
            mean_psnr: mean_psnr(&v.error.psnr),
            ssim: v.error.ssim.clone(),
            mean_ssim: mean(&v.error.ssim),
            silhouette_iou: v.error.silhouette_iou.clone(),
            mean_silhouette_iou: mean(&v.error.silhouette_iou),
            order: v.order.clone(),
            key_frame: v.key_frame,
            keys: view_keys_of(v),
            hidden: v.hidden.clone(),
            key_budget: v.key_budget,
            parts: v
                .parts
                .iter()
                .enumerate()
                .map(|(p, part)| PartReport {
                    name: bake.segmentation.parts.get(p).map_or(String::new(), |x| x.name.clone()),
                    psnr: part.psnr.clone(),
                    ssim: part.ssim.clone(),
                    fit_cost: part.fit.as_ref().map_or(Vec::new(), |f| f.costs.clone()),
                    fit_cost_per_pixel: part.fit.as_ref().map_or(Vec::new(), |f| {
                        f.costs
                            .iter()
                            .zip(&f.targets)
                            .map(|(c, t)| c / (crate::bake::contour::signed_area2(t).abs() / 2.0).max(1.0))
                            .collect()
                    }),
                    vertices: part.fit.as_ref().map_or(0, |f| f.vertex_count()),
                    triangles: part.fit.as_ref().map_or(0, |f| f.triangles.len()),
                    problem: part.problem.clone(),
                    key_frames: part.key_frames(),
                    frame_key: part.frame_key.clone(),
                    keys_gain_db: crate::bake::keys::key_gains(&part.sse, &part.extra).0,
                })
                .collect(),
        })
        .collect();
    // Views that traced nothing draw nothing against part images that hold nothing: a
    // perfect score that is no score.
    let empty_views: Vec<usize> = bake
        .views
        .iter()
        .enumerate()
        .filter(|(_, v)| {
            // Only parts that cover nothing: a part whose fit failed (triangulation) is a
            // failure the means must show.
            v.parts.iter().all(|p| {
                p.fit.is_none()
                    && p.problem
                        .as_deref()
                        .is_some_and(crate::bake::part_fit::PartFitError::says_empty)
            })
        })
        .map(|(i, _)| i)
        .collect();
    let counted: Vec<&ViewReport> = if empty_views.len() < views.len() {
        views.iter().filter(|v| !empty_views.contains(&v.index)).collect()
    } else {
        views.iter().collect()
    };
    let all: Vec<f64> = counted.iter().flat_map(|v| v.psnr.iter().copied()).collect();
    let all_static: Vec<f64> = counted.iter().flat_map(|v| v.psnr_static.iter().copied()).collect();
    let all_ssim: Vec<f64> = counted.iter().flat_map(|v| v.ssim.iter().copied()).collect();
    let all_iou: Vec<f64> = counted.iter().flat_map(|v| v.silhouette_iou.iter().copied()).collect();
    let brightness: Vec<f64> = bake.views.iter().map(|v| v.error.truth_brightness).collect();
    let mut worst: Vec<WorstView> = counted
        .iter()
        .map(|v| WorstView {
            view: v.index,
            mean_psnr: v.mean_psnr,
            mean_ssim: v.mean_ssim,
            direction: v.direction,
        })
        .collect();
    worst.sort_by(|a, b| a.mean_psnr.total_cmp(&b.mean_psnr));
    worst.truncate(10);
    Report {
        character: character.to_string(),
        adapter: bake.adapter.clone(),
        dropped_corrections: bake.dropped_corrections(),
        settings: Settings {
            views: bake.views.len(),
            resolution: bake.options.resolution,
            fps: bake.options.fps,
            frames,
            clip: clip.map(String::from),
            exhaustive: bake.options.fit.exhaustive,
            fold_free: bake.options.fit.fold_free,
            charge_missed_coverage: bake.options.fit.charge_missed_coverage,
            restart_threshold: Some(bake.options.fit.restart_threshold).filter(|t| t.is_finite()),
            subpixel: bake.options.fit.subpixel,
            key_vertices: bake.options.fit.key_vertices,
            frame_vertices: bake.options.fit.frame_vertices,
            final_vertices: bake.options.fit.final_vertices,
            interior_vertices: bake.options.fit.interior_vertices,
            keys: Some(bake.options.keys),
            textures: Some(bake.options.textures),
        },
        seconds_total,
        stage_seconds: bake.stage_secs.clone(),
        cpu_seconds: Default::default(),
        cpu_counts: Default::default(),
        key_frame: bake.key_frame,
        mean_psnr: mean_psnr(&all),
        worst_psnr: all.iter().copied().fold(f64::INFINITY, f64::min),
        mean_psnr_static: mean_psnr(&all_static),
        mean_ssim: mean(&all_ssim),
        worst_ssim: all_ssim.iter().copied().fold(f64::INFINITY, f64::min).min(1.0),
        mean_silhouette_iou: mean(&all_iou),
        truth_brightness: mean(&brightness),
        pack_bytes: stats.pack_bytes,
        pack_bytes_bc: stats.pack_bytes_bc,
        pack_file_bytes: stats.file_bytes,
        impostor_bytes,
        impostor_bytes_bc: impostor_bytes / 4,
        memory_ratio: impostor_bytes as f64 / stats.pack_bytes.max(1) as f64,
        extra_keys: bake.views.iter().flat_map(|v| &v.parts).map(|p| p.extra.len()).sum(),
        extra_key_bytes: stats.extra_key_bytes,
        triangles_per_view: stats.triangles_per_view,
        worst_views: worst,
        clips: clip_reports(bake, &counted, stats),
        empty_views,
        views,
    }
}

fn clip_reports(bake: &Bake, views: &[&ViewReport], stats: &PackStats) -> Vec<ClipReport> {
    let frames = bake.frame_times.len();
    let r = bake.options.resolution as u64;
    let all_animation = animation_bytes(bake, 0..frames);
    let shared = stats.pack_bytes.saturating_sub(all_animation);
    bake.timeline
        .spans
        .iter()
        .map(|s| {
            let range = s.range();
            let psnr: Vec<f64> = views
                .iter()
                .flat_map(|v| v.psnr.get(range.clone()).unwrap_or(&[]).iter().copied())
                .collect();
            let ssim: Vec<f64> = views
                .iter()
                .flat_map(|v| v.ssim.get(range.clone()).unwrap_or(&[]).iter().copied())
                .collect();
            let animation = animation_bytes(bake, range.clone());
            let alone = shared + animation;
            let impostor = bake.views.len() as u64 * range.len() as u64 * r * r * 4 * 2;
            ClipReport {
                name: s.name.clone(),
                first_frame: range.start,
                frames: range.len(),
                ground_speed: s.ground_speed,
                mean_psnr: mean_psnr(&psnr),
                worst_psnr: psnr.iter().copied().fold(f64::INFINITY, f64::min),
                mean_ssim: mean(&ssim),
                animation_bytes: animation,
                alone_bytes: alone,
                impostor_bytes: impostor,
                memory_ratio: impostor as f64 / alone.max(1) as f64,
            }
        })
        .collect()
}

fn line(img: &mut image::RgbaImage, a: [f32; 2], b: [f32; 2], ox: u32, oy: u32, color: [u8; 4]) {
    let steps = ((b[0] - a[0]).abs().max((b[1] - a[1]).abs()).ceil() as usize).max(1);
    for s in 0..=steps {
        let t = s as f32 / steps as f32;
        let (x, y) = (a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t);
        let (px, py) = (ox as i64 + x as i64, oy as i64 + y as i64);
        if px >= 0 && py >= 0 && (px as u32) < img.width() && (py as u32) < img.height() {
            img.put_pixel(px as u32, py as u32, image::Rgba(color));
        }
    }
}

fn polygon(img: &mut image::RgbaImage, pts: &[[f32; 2]], ox: u32, oy: u32, color: [u8; 4]) {
    for i in 0..pts.len() {
        line(img, pts[i], pts[(i + 1) % pts.len()], ox, oy, color);
    }
}

/// One debug image per view: a row per part, a column per frame; each tile shows the part's
/// render with the traced target polygon T (green) and the fitted final polygon (red, with
/// its triangles in dark red); the key frame's column shows S (yellow).
pub fn debug_image(bake: &Bake, view: usize, tiles_color: &[Vec<image::RgbaImage>]) -> image::RgbaImage {
    let v = &bake.views[view];
    let r = bake.options.resolution;
    let frames = bake.frame_times.len() as u32;
    let parts = v.parts.len() as u32;
    let mut img = image::RgbaImage::from_pixel(frames * r, parts * r, image::Rgba([24, 24, 28, 255]));
    for (p, part) in v.parts.iter().enumerate() {
        for f in 0..frames as usize {
            let (ox, oy) = (f as u32 * r, p as u32 * r);
            if let Some(tile) = tiles_color.get(p).and_then(|t| t.get(f)) {
                for (x, y, q) in tile.enumerate_pixels() {
                    if q[3] > 0 {
                        img.put_pixel(
                            ox + x,
                            oy + y,
                            image::Rgba([q[0] / 2 + 20, q[1] / 2 + 20, q[2] / 2 + 20, 255]),
                        );
                    }
                }
            }
            let Some(fit) = &part.fit else { continue };
            polygon(&mut img, &fit.targets[f], ox, oy, [60, 220, 90, 255]);
            let pos = fit.positions(f);
            for t in &fit.triangles {
                polygon(&mut img, &t.map(|i| pos[i]), ox, oy, [140, 40, 40, 255]);
            }
            polygon(&mut img, &pos, ox, oy, [250, 70, 60, 255]);
            if f == fit.key_frame {
                polygon(&mut img, &fit.key_polygon, ox, oy, [250, 220, 60, 255]);
            }
        }
    }
    img
}

impl Report {
    /// A whole-character pack's table: each clip's frames, ground speed, error and memory
    /// (alone and as impostors), then the whole pack; `None` for one clip.
    pub fn clip_table(&self) -> Option<String> {
        if self.clips.len() < 2 {
            return None;
        }
        use std::fmt::Write as _;
        let mut t = String::new();
        let _ = writeln!(
            t,
            "{:<16} {:>6} {:>9} {:>9} {:>7} {:>11} {:>11} {:>8}",
            "clip", "frames", "speed", "PSNR dB", "SSIM", "alone", "impostors", "ratio"
        );
        for c in &self.clips {
            let _ = writeln!(
                t,
                "{:<16} {:>6} {:>9.3} {:>9.2} {:>7.3} {:>11} {:>11} {:>7.1}×",
                c.name,
                c.frames,
                c.ground_speed,
                c.mean_psnr,
                c.mean_ssim,
                human_bytes(c.alone_bytes),
                human_bytes(c.impostor_bytes),
                c.memory_ratio
            );
        }
        let _ = writeln!(
            t,
            "{:<16} {:>6} {:>9} {:>9.2} {:>7.3} {:>11} {:>11} {:>7.1}×",
            "whole pack",
            self.settings.frames,
            "",
            self.mean_psnr,
            self.mean_ssim,
            human_bytes(self.pack_bytes),
            human_bytes(self.impostor_bytes),
            self.memory_ratio
        );
        Some(t)
    }
}

/// Bytes as decimal MB (from 1 MB) or KB, as the command line's tables print them.
pub fn human_bytes(b: u64) -> String {
    let b = b as f64;
    if b >= 1e6 {
        format!("{:.1} MB", b / 1e6)
    } else {
        format!("{:.0} KB", b / 1e3)
    }
}

#[cfg(test)]
mod tests {
    use super::mean_psnr;
    use crate::bake::raster::psnr;

    #[test]
    fn mean_psnr_is_that_of_the_mean_rmse() {
        // Frames alike: their own PSNR.
        assert!((mean_psnr(&[25.0, 25.0, 25.0]) - 25.0).abs() < 1e-9);
        // RMSE 0.1 and 0.01 (20 and 40 dB): the mean RMSE is 0.055.
        assert!((mean_psnr(&[20.0, 40.0]) - psnr(0.055)).abs() < 1e-9);
        // A frame drawn exactly (the 99 dB cap) counts as no error, not as 99 dB: half the
        // frames exact halve the mean RMSE (+6 dB) where the decibels' mean read 59.5.
        let m = mean_psnr(&[20.0, 99.0]);
        assert!((m - psnr(0.05)).abs() < 1e-3, "{m}");
        assert_eq!(mean_psnr(&[]), 0.0);
        // Between the worst frame and the best.
        let m = mean_psnr(&[12.5, 31.0, 18.25, 27.0]);
        assert!(m > 12.5 && m < 31.0, "{m}");
    }
}
