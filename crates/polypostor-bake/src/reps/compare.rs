//! The comparison report: memory of every representation at the same settings, and each
//! one's error against the ground truth (the real mesh rendered with the same orthographic
//! view camera, pose and resolution), at the baked frames and half-way between them (where
//! impostors cannot interpolate). The error measure is the bake's: masked RMSE over pixels
//! either image covers (colour × coverage, sRGB 0..1), as PSNR.

use serde::Serialize;

use super::RepBytes;
use crate::animation::Pose;
use crate::bake::raster::psnr;
use crate::crowd::Instance;
use crate::crowd::lod::Level;
use crate::gpu::{
    CharacterRenderer, DrawOptions, GpuCharacter, GpuContext, GpuError, PolypostorStyle, RenderTarget, Shading,
    SkinningMode,
};
use crate::scene::CrowdAssets;

/// Memory of one representation.
#[derive(Clone, Debug, Serialize)]
pub struct MemoryRow {
    pub representation: String,
    #[serde(flatten)]
    pub bytes: RepBytes,
    /// This representation's bytes ÷ the Polypostor pack's (uncompressed).
    pub vs_polypostor: Option<f64>,
}

/// One sample of the error curve.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct ErrorSample {
    /// In frames (x.5: half-way between two baked frames).
    pub time_frames: f32,
    /// Mean RMSE over the compared views (0..1), and its PSNR.
    pub rmse: f64,
    pub psnr: f64,
    /// Mean SSIM over the compared views ([`crate::metrics`]).
    pub ssim: f64,
}

/// Error of one representation. Means are of the RMSE (then shown as PSNR), so a few
/// pixel-exact samples do not dominate them; SSIM means are plain means.
#[derive(Clone, Debug, Serialize)]
pub struct ErrorRow {
    pub representation: String,
    pub mean_psnr: f64,
    pub mean_psnr_on_frames: f64,
    pub mean_psnr_between_frames: f64,
    pub mean_ssim: f64,
    pub mean_ssim_on_frames: f64,
    pub mean_ssim_between_frames: f64,
    /// Mean silhouette agreement over every display time and view: the pixels both images
    /// cover over the pixels either covers ([`silhouette_iou`]), whatever their colours. PSNR
    /// and SSIM weigh a pixel one image covers and the other does not by its colour against
    /// the black background, so they cannot see a dark character's shape errors; this can.
    pub mean_silhouette_iou: f64,
    /// How dark the real mesh's images are: the mean over their covered pixels of the
    /// brightest channel (0..1). Under about 0.1 PSNR and SSIM see little of the shape.
    pub truth_brightness: f64,
    /// The compared view with the lowest mean PSNR, and that PSNR.
    pub worst_view: usize,
    pub worst_view_psnr: f64,
    pub samples: Vec<ErrorSample>,
    /// Per compared view (in the order given): mean PSNR and SSIM over all display times.
    pub per_view: Vec<ViewError>,
    /// Per clip of a whole-character pack (in the pack's order): mean PSNR and SSIM over the
    /// clip's display times.
    pub per_clip: Vec<ClipError>,
}

/// One representation's error over one clip's display times.
#[derive(Clone, Debug, Serialize)]
pub struct ClipError {
    pub clip: String,
    pub psnr: f64,
    pub ssim: f64,
}

/// One representation's error from one view, over every display time.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct ViewError {
    pub view: usize,
    pub psnr: f64,
    pub ssim: f64,
    /// The baked frame where this representation is worst from this view (by RMSE).
    pub worst_frame: u32,
}

/// Memory of every representation the folder holds (and the skinned mesh, always).
pub fn memory(assets: &CrowdAssets) -> Vec<MemoryRow> {
    let mut rows: Vec<(String, RepBytes)> = Vec::new();
    let c = &assets.character;
    let timing = assets.timing();
    rows.push((
        "skinned".into(),
        super::skinned_bytes(c, timing.frames * crate::gpu::JOINT_SAMPLES_PER_FRAME),
    ));
    if let Some(r) = &assets.reps
        && let Some(b) = r.rigid_bytes(super::character_static_bytes(c))
    {
        rows.push(("rigid".into(), b));
    }
    if let Some(p) = &assets.pack {
        let texture: u64 = p
            .manifest
            .views
            .iter()
            .map(|v| {
                let [w, h] = v.atlas_size;
                4 * (w as u64 * h as u64 + (w / 2) as u64 * (h / 2) as u64)
            })
            .sum();
        rows.push((
            "polypostor".into(),
            RepBytes {
                texture,
                geometry: p.manifest.vertex_bytes + p.manifest.index_bytes,
                total: texture + p.manifest.vertex_bytes + p.manifest.index_bytes,
                total_bc: texture / 4 + p.manifest.vertex_bytes + p.manifest.index_bytes,
            },
        ));
    }
    if let Some(r) = &assets.reps {
        if let Some(b) = r.impostor_bytes() {
            rows.push(("impostor".into(), b));
        }
        if let Some(b) = r.np3d_bytes() {
            rows.push(("np3d".into(), b));
        }
    }
    let poly = rows.iter().find(|r| r.0 == "polypostor").map(|r| r.1.total);
    rows.into_iter()
        .map(|(representation, bytes)| MemoryRow {
            vs_polypostor: poly.map(|p| bytes.total as f64 / p.max(1) as f64),
            representation,
            bytes,
        })
        .collect()
}

/// The views compared: `count` spread evenly over the baked ones (0: all).
pub fn chosen_views(total: usize, count: usize) -> Vec<usize> {
    if count == 0 || count >= total {
        return (0..total).collect();
    }
    (0..count).map(|i| i * total / count).collect()
}

/// Renders the ground truth and every representation a folder holds, from its baked views.
pub struct Renders<'a> {
    ctx: &'a GpuContext,
    assets: &'a CrowdAssets,
    scene: crate::scene::CrowdScene,
    /// The representations drawn by the crowd renderers (no skinned: that is the truth).
    pub levels: Vec<Level>,
    cameras: Vec<crate::pack::PackCamera>,
    target: RenderTarget,
    renderer: CharacterRenderer,
    mesh: GpuCharacter,
    style: PolypostorStyle,
}

impl<'a> Renders<'a> {
    /// In a pack of several clips, the clip frame `t` (of the timeline) is in, and the time
    /// in it ("Death", 5.5); `None` for a pack of one clip.
    pub fn clip_at(&self, t: f32) -> Option<(&str, f32)> {
        let spans = &self.assets.timeline.spans;
        if spans.len() < 2 {
            return None;
        }
        let f = t.max(0.0).floor() as u32;
        spans
            .iter()
            .find(|s| (s.start..s.start + s.frames).contains(&f))
            .map(|s| (s.name.as_str(), t - s.start as f32))
    }

    pub fn new(ctx: &'a GpuContext, assets: &'a CrowdAssets) -> Result<Self, GpuError> {
        let (device, queue) = (&ctx.device, &ctx.queue);
        let scene = crate::scene::CrowdScene::new(device, queue, assets, assets.crowd_params(0))?;
        let levels: Vec<Level> = Level::ALL.iter().copied().filter(|l| scene.renderers.has(*l)).collect();
        let cameras: Vec<crate::pack::PackCamera> = match (&assets.pack, &assets.reps) {
            (Some(p), _) => p.manifest.views.iter().map(|v| v.camera.clone()).collect(),
            (None, Some(r)) => r.manifest.views.iter().map(|v| v.camera.clone()).collect(),
            _ => Vec::new(),
        };
        let r = assets.resolution();
        let target = RenderTarget::new(device, r, r);
        let renderer = CharacterRenderer::new(device);
        let mesh = GpuCharacter::new(&renderer, device, queue, &assets.character);
        Ok(Self {
            ctx,
            assets,
            scene,
            levels,
            cameras,
            target,
            renderer,
            mesh,
            style: PolypostorStyle {
                lit: false,
                tint: 0.0,
                ..Default::default()
            },
        })
    }

    pub fn views(&self) -> usize {
        self.cameras.len()
    }

    fn camera(&self, view: usize) -> Option<crate::gpu::Camera> {
        let cam = self.cameras.get(view)?;
        Some(cam.to_camera(cam.half_size * 4.0, cam.half_size * 0.5, cam.half_size * 8.0))
    }

    /// The real mesh from `view` at time `t` (in frames; fractional between baked frames).
    pub fn truth(&mut self, view: usize, t: f32) -> Result<Option<image::RgbaImage>, GpuError> {
        let Some(camera) = self.camera(view) else {
            return Ok(None);
        };
        let (device, queue) = (&self.ctx.device, &self.ctx.queue);
        let fps = self.assets.timing().fps.max(1e-3);
        // Time `t` in the timeline: its clip, and the time in that clip (a clip's last frame
        // runs on into its own first).
        let tl = &self.assets.timeline;
        let f = t.max(0.0).floor() as usize;
        let span = tl.span_of(f);
        let clip = tl.clips.get(span).copied().unwrap_or(self.assets.clip);
        let mut local = t - tl.spans.get(span).map_or(0.0, |s| s.start as f32);
        // A clip that does not loop holds its last frame (as the crowd shows it).
        if let Some(s) = tl.spans.get(span).filter(|s| !s.looping) {
            local = local.min(s.frames.saturating_sub(1) as f32);
        }
        let secs = tl.spans.get(span).map_or(local / fps, |s| s.clip_secs(local, fps));
        let pose = Pose::sample_index(&self.assets.character, clip, secs);
        self.renderer.render(
            device,
            queue,
            &self.target,
            &mut self.mesh,
            &self.assets.character,
            &pose,
            SkinningMode::Gpu,
            &camera,
            &DrawOptions {
                shading: Shading::Unlit,
                ..Default::default()
            },
        );
        Ok(Some(self.target.read_color(device, queue)?))
    }

    /// `level` from `view` at time `t`, as the crowd draws it.
    pub fn level(&mut self, level: Level, view: usize, t: f32) -> Result<Option<image::RgbaImage>, GpuError> {
        let Some(camera) = self.camera(view) else {
            return Ok(None);
        };
        let (device, queue) = (&self.ctx.device, &self.ctx.queue);
        let mut instances: [Vec<Instance>; Level::COUNT] = Default::default();
        instances[level as usize].push(Instance {
            pos: [0.0, 0.0],
            facing: [0.0, 1.0],
            view: view as u32,
            frame: {
                let f = t.max(0.0).floor() as usize;
                crate::crowd::frame_pair(f as u32, self.assets.timeline.next(f) as u32)
            },
            blend: t.fract(),
            variant: 0,
        });
        self.scene.renderers.render(
            device,
            queue,
            &self.target,
            camera.clip_from_world(1.0),
            &self.style,
            &instances,
            wgpu::Color::TRANSPARENT,
        );
        Ok(Some(self.target.read_color(device, queue)?))
    }
}

/// Renders every representation and the ground truth from `views` at every baked frame and
/// half-way between, and measures the error (PSNR and SSIM). `progress(done, total)` per view.
pub fn errors(
    ctx: &GpuContext,
    assets: &CrowdAssets,
    views: &[usize],
    progress: &dyn Fn(usize, usize),
) -> Result<Vec<ErrorRow>, GpuError> {
    let mut renders = Renders::new(ctx, assets)?;
    let levels = renders.levels.clone();
    let frames = assets.timing().frames.max(1);
    let times: Vec<f32> = (0..frames * 2).map(|k| k as f32 * 0.5).collect();
    // sums[level][time]: RMSE and SSIM summed over views.
    let mut sums = vec![vec![(0.0f64, 0.0f64); times.len()]; levels.len()];
    let mut per_view: Vec<Vec<ViewError>> = vec![Vec::new(); levels.len()];
    // Silhouette IoU summed over every view and time, with the count; the truth's brightness.
    let mut iou = vec![(0.0f64, 0usize); levels.len()];
    let mut brightness = (0.0f64, 0usize);
    let mut counted = 0usize;
    for (n, &v) in views.iter().enumerate() {
        progress(n, views.len());
        if v >= renders.views() {
            continue;
        }
        // this view: per level, (rmse sum, ssim sum, worst baked frame, its rmse)
        let mut here = vec![(0.0f64, 0.0f64, 0u32, -1.0f64); levels.len()];
        for (k, &t) in times.iter().enumerate() {
            let Some(truth) = renders.truth(v, t)? else { continue };
            for p in truth.pixels().filter(|p| p[3] > 127) {
                brightness.0 += p[0].max(p[1]).max(p[2]) as f64 / 255.0;
                brightness.1 += 1;
            }
            for (li, &level) in levels.iter().enumerate() {
                let Some(img) = renders.level(level, v, t)? else {
                    continue;
                };
                let rmse = masked_rmse(&truth, &img);
                let ssim = crate::metrics::ssim_rgba8(&truth, &img).unwrap_or(0.0);
                iou[li].0 += silhouette_iou(&truth, &img);
                iou[li].1 += 1;
                sums[li][k].0 += rmse;
                sums[li][k].1 += ssim;
                let h = &mut here[li];
                h.0 += rmse;
                h.1 += ssim;
                if t.fract() == 0.0 && rmse > h.3 {
                    h.2 = t as u32;
                    h.3 = rmse;
                }
            }
        }
        for (li, h) in here.iter().enumerate() {
            let m = times.len().max(1) as f64;
            per_view[li].push(ViewError {
                view: v,
                psnr: psnr(h.0 / m),
                ssim: h.1 / m,
                worst_frame: h.2,
            });
        }
        counted += 1;
    }
    progress(views.len(), views.len());
    let n = counted.max(1) as f64;
    let truth_brightness = brightness.0 / brightness.1.max(1) as f64;
    Ok(levels
        .iter()
        .zip(&sums)
        .zip(per_view)
        .zip(&iou)
        .map(|(((level, s), per_view), iou)| {
            let samples: Vec<ErrorSample> = times
                .iter()
                .zip(s)
                .map(|(&t, &(rmse, ssim))| ErrorSample {
                    time_frames: t,
                    rmse: rmse / n,
                    psnr: psnr(rmse / n),
                    ssim: ssim / n,
                })
                .collect();
            let mean = |f: &dyn Fn(&ErrorSample) -> bool| {
                let v: Vec<&ErrorSample> = samples.iter().filter(|s| f(s)).collect();
                let k = v.len().max(1) as f64;
                (
                    psnr(v.iter().map(|s| s.rmse).sum::<f64>() / k),
                    v.iter().map(|s| s.ssim).sum::<f64>() / k,
                )
            };
            let (all, on, between) = (
                mean(&|_| true),
                mean(&|s| s.time_frames.fract() == 0.0),
                mean(&|s| s.time_frames.fract() != 0.0),
            );
            let worst = per_view.iter().min_by(|a, b| a.psnr.total_cmp(&b.psnr)).copied();
            let per_clip = assets
                .timeline
                .spans
                .iter()
                .map(|c| {
                    let r = c.range();
                    let (psnr, ssim) = mean(&|s| r.contains(&(s.time_frames.floor() as usize)));
                    ClipError {
                        clip: c.name.clone(),
                        psnr,
                        ssim,
                    }
                })
                .collect();
            ErrorRow {
                representation: level.name().into(),
                mean_psnr: all.0,
                mean_psnr_on_frames: on.0,
                mean_psnr_between_frames: between.0,
                mean_ssim: all.1,
                mean_ssim_on_frames: on.1,
                mean_ssim_between_frames: between.1,
                mean_silhouette_iou: if iou.1 == 0 { 1.0 } else { iou.0 / iou.1 as f64 },
                truth_brightness,
                worst_view: worst.map_or(0, |w| w.view),
                worst_view_psnr: worst.map_or(0.0, |w| w.psnr),
                samples,
                per_view,
                per_clip,
            }
        })
        .collect())
}

/// [`crate::metrics::silhouette_iou`] of two images, a pixel covered when its alpha is over
/// half.
pub fn silhouette_iou(a: &image::RgbaImage, b: &image::RgbaImage) -> f64 {
    crate::metrics::silhouette_iou(a.pixels().zip(b.pixels()).map(|(p, q)| (p[3] > 127, q[3] > 127)))
}

/// RMSE (0..1) of colour × coverage over the pixels either image covers.
pub fn masked_rmse(a: &image::RgbaImage, b: &image::RgbaImage) -> f64 {
    let mut sum = 0.0f64;
    let mut n = 0usize;
    for (p, q) in a.pixels().zip(b.pixels()) {
        let (ca, cb) = (p[3] > 127, q[3] > 127);
        if !ca && !cb {
            continue;
        }
        n += 1;
        for k in 0..3 {
            let x = if ca { p[k] as f64 / 255.0 } else { 0.0 };
            let y = if cb { q[k] as f64 / 255.0 } else { 0.0 };
            sum += (x - y).powi(2);
        }
    }
    if n == 0 { 0.0 } else { (sum / (3 * n) as f64).sqrt() }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn masked_rmse_counts_only_covered_pixels() {
        let mut a = image::RgbaImage::new(4, 4);
        let mut b = image::RgbaImage::new(4, 4);
        assert_eq!(masked_rmse(&a, &b), 0.0);
        a.put_pixel(0, 0, image::Rgba([255, 255, 255, 255]));
        // One pixel covered by one image only: white against black, RMSE 1.
        assert!((masked_rmse(&a, &b) - 1.0).abs() < 1e-9);
        b.put_pixel(0, 0, image::Rgba([255, 255, 255, 255]));
        assert_eq!(masked_rmse(&a, &b), 0.0);
        b.put_pixel(1, 0, image::Rgba([0, 0, 0, 255]));
        assert_eq!(masked_rmse(&a, &b), 0.0, "black on black background");
        // The silhouette sees that black pixel: 1 of the 2 covered pixels is covered by both.
        assert_eq!(silhouette_iou(&a, &b), 0.5);
        assert_eq!(silhouette_iou(&b, &b), 1.0);
        assert_eq!(
            silhouette_iou(&image::RgbaImage::new(4, 4), &image::RgbaImage::new(4, 4)),
            1.0
        );
        assert_eq!(chosen_views(10, 0).len(), 10);
        assert_eq!(chosen_views(137, 24).len(), 24);
        assert_eq!(chosen_views(5, 24), vec![0, 1, 2, 3, 4]);
    }

    #[test]
    fn the_estimate_follows_the_polygon_vertices() {
        let e = estimate(137, 128, 57, 5, 5000, 0);
        let drawn = crate::bake::part_fit::DEFAULT_POLYGON_VERTICES
            + kept_interior(crate::bake::part_fit::DEFAULT_INTERIOR_VERTICES);
        let same = e.with_polygon_vertices(drawn, 137, 57, 5);
        assert_eq!(same, e);
        let fewer = e.with_polygon_vertices(drawn / 2, 137, 57, 5);
        assert_eq!(fewer.polypostor_atlas, e.polypostor_atlas);
        assert_eq!(fewer.impostor, e.impostor);
        // Positions are most of the geometry: half the drawn vertices hold about half of the
        // default's (40 on the outline, two fifths of the 24 inside allowed).
        let (g40, g20) = (
            e.polypostor - e.polypostor_atlas,
            fewer.polypostor - fewer.polypostor_atlas,
        );
        assert!(
            g20 < g40 && g20 * 2 > g40 * 9 / 10 && g20 * 2 < g40 * 11 / 10,
            "{g20} vs {g40}"
        );
        // The key ratio: a 10-frame clip keeps the default budget's atlas; the same views on
        // a long clip grow towards the ratio (at most twice the first keys), never past it.
        let keys = crate::bake::keys::KeyOptions::default();
        let short = estimate(137, 128, 10, 12, 5000, 0);
        assert_eq!(short.with_keys(&keys, 137, 10, 1, 128), short);
        let off = crate::bake::keys::KeyOptions { ratio: 0.0, ..keys };
        assert_eq!(e.with_keys(&off, 137, 57, 1, 128), e);
        let long = e.with_keys(&keys, 137, 57, 1, 128);
        assert!(long.polypostor_atlas > e.polypostor_atlas);
        assert!(long.polypostor_atlas <= (e.polypostor_atlas as f64 * 2.0 / 1.25) as u64 + 1);
        assert!(long.impostor as f64 / long.polypostor as f64 >= keys.ratio * 0.999);
        assert_eq!(
            long.polypostor - long.polypostor_atlas,
            e.polypostor - e.polypostor_atlas
        );
        // Four clips of the same 57 frames weigh one clip's impostor: less room.
        let four = e.with_keys(&keys, 137, 57, 4, 128);
        assert!(four.polypostor_atlas < long.polypostor_atlas);
        // Either order with the textures gives the same.
        let bc = crate::bake::pipeline::TextureEncoding::Bc7;
        assert_eq!(
            fewer.with_textures(bc),
            e.with_textures(bc).with_polygon_vertices(drawn / 2, 137, 57, 5)
        );
        // BC7 quarters what the pack writes as BC7, NP3D's images included (a byte a texel),
        // and leaves the meshes' textures and every mesh as they are.
        let b = e.with_textures(bc);
        assert_eq!(b.np3d_images, 137 * 128 * 128);
        assert_eq!(e.np3d - e.np3d_images, b.np3d - b.np3d_images);
        assert_eq!((b.rigid, b.skinned), (e.rigid, e.skinned));
        assert_eq!(b.impostor * 4, e.impostor);
    }
}

/// Memory of each representation estimated before baking (uncompressed bytes, textures and
/// geometry): exact for classic impostors (a colour and a normal image per view per frame);
/// for Polypostors and NP3D from densities measured on the default character (atlas texels
/// per view ≈ 0.386 r² + 16.5 r with the extra key images, plus a quarter for normals; the
/// default polygon's vertices per part and frame, two bytes each, with the interior vertices a
/// view keeps ([`kept_interior`]), or
/// [`Estimate::with_polygon_vertices`]);
/// skinned and rigid from the mesh (the character's textures with their mipmaps).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Estimate {
    pub polypostor: u64,
    /// The part of `polypostor` that is atlas texels.
    pub polypostor_atlas: u64,
    pub impostor: u64,
    pub np3d: u64,
    /// The part of `np3d` that is its per-view images.
    pub np3d_images: u64,
    pub rigid: u64,
    pub skinned: u64,
}

impl Estimate {
    /// The same bake with polygons of `vertices` vertices instead of the default's (the
    /// bake's `views`, `frames` and `parts`, as given to [`estimate`]).
    pub fn with_polygon_vertices(self, vertices: usize, views: usize, frames: usize, parts: usize) -> Self {
        Self {
            polypostor: self.polypostor_atlas + pack_geometry(views, frames, parts, vertices),
            ..self
        }
    }

    /// The same bake with the key images that [`KeyOptions::ratio`] lets each view add on
    /// long clips (`frames` in `clips` clips, `parts` parts a view): where a view has room
    /// below `keys.ratio` times one clip's impostor, its atlas grows into it
    /// ([`KeyOptions::view_budget`]), as the packs of CesiumMan and RobotExpressive do; a view
    /// may stop short of it where added keys buy less than `keys.min_gain_db` (RiggedSimple's
    /// single part spent a fifth of its room), so on long clips this is the most the pack
    /// takes. Apply after [`Estimate::with_polygon_vertices`], before
    /// [`Estimate::with_textures`].
    ///
    /// [`KeyOptions::ratio`]: crate::bake::keys::KeyOptions::ratio
    /// [`KeyOptions::view_budget`]: crate::bake::keys::KeyOptions::view_budget
    pub fn with_keys(
        self,
        keys: &crate::bake::keys::KeyOptions,
        views: usize,
        frames: usize,
        clips: usize,
        resolution: u32,
    ) -> Self {
        use crate::bake::keys::{ATLAS_PACKING, KeyOptions, ViewBytes};
        let n = views.max(1) as f64;
        let atlas = self.polypostor_atlas as f64 / n;
        let geometry = (self.polypostor - self.polypostor_atlas) as f64 / n;
        // The densities hold the default budget's added keys.
        let first = atlas / ((1.0 + KeyOptions::default().budget) * ATLAS_PACKING);
        let r = resolution as f64;
        let view = ViewBytes {
            first,
            geometry,
            impostor_clip: frames.max(1) as f64 / clips.max(1) as f64 * r * r * 8.0,
        };
        let budget = keys.view_budget(view);
        let grown = (first * (1.0 + budget) * ATLAS_PACKING * n) as u64;
        if grown <= self.polypostor_atlas {
            return self;
        }
        Self {
            polypostor: self.polypostor - self.polypostor_atlas + grown,
            polypostor_atlas: grown,
            ..self
        }
    }

    /// The same bake's bytes with `textures` chosen: BC7 keeps one byte a texel (four as
    /// RGBA8) for what the pack writes as BC7 — the Polypostor's colour and normal atlases,
    /// the impostors' colour and normal sheets and NP3D's images (as `compare`'s
    /// block-compressed column counts them); the meshes draw the character's own textures,
    /// which stay as they are. PNG: unchanged (what a GPU without BC7 holds).
    pub fn with_textures(self, textures: crate::bake::pipeline::TextureEncoding) -> Self {
        match textures {
            crate::bake::pipeline::TextureEncoding::Png => self,
            crate::bake::pipeline::TextureEncoding::Bc7 => {
                // The Polypostor's atlas texels (colour + quarter-size normals) at a quarter;
                // its geometry as it is.
                let atlas = self.polypostor_atlas;
                Self {
                    polypostor: self.polypostor - atlas + atlas / 4,
                    polypostor_atlas: atlas / 4,
                    // Colour and normal sheets both BC7, a quarter (as the bake counts them,
                    // `report::impostor_bytes_bc`; the normals were counted uncompressed
                    // until 2026-12-02, which showed the impostors 2.5× too large).
                    impostor: self.impostor / 4,
                    // NP3D's images are BC7 in the pack too (its mesh as it is; they were
                    // counted uncompressed until 2026-12-02).
                    np3d: self.np3d - self.np3d_images + self.np3d_images / 4,
                    np3d_images: self.np3d_images / 4,
                    ..self
                }
            }
        }
    }
}

/// The Polypostor's polygons as the export estimate counts them:
/// [`crate::bake::keys::polygon_bytes_estimate`] and its per-part blocks (UVs, box,
/// triangles, coarse level) as much again for the extra keys' own blocks (measured on the
/// default character's packs, 128², 137 views: 0.91 MB besides the positions against 0.43 MB
/// estimated without them). The key budget keeps the first estimate.
fn pack_geometry(views: usize, frames: usize, parts: usize, vertices: usize) -> u64 {
    let (v, p, nv) = (views as u64, parts as u64, vertices.max(3) as u64);
    crate::bake::keys::polygon_bytes_estimate(views, frames, parts, vertices) + v * p * ((nv - 2) * 9 + nv * 4 + 8)
}

/// Interior vertices a polygon keeps on average when at most `most` are allowed: each view
/// keeps those its error pays for in bytes (`bake::interior`), about two fifths of the most
/// (measured on the default character's one- and four-clip packs, 128², 137 views: 74.9 KB a
/// frame of positions against 96.5 KB with every one kept). What [`estimate`] and the
/// export dialog count.
pub fn kept_interior(most: usize) -> usize {
    most * 2 / 5
}

/// See [`Estimate`]. `texture_bytes`: the character's own textures, uncompressed.
pub fn estimate(
    views: usize,
    resolution: u32,
    frames: usize,
    parts: usize,
    vertices: usize,
    texture_bytes: u64,
) -> Estimate {
    let (v, r2, f, n) = (
        views as u64,
        (resolution as u64).pow(2),
        frames.max(1) as u64,
        vertices as u64,
    );
    // Atlas texels per view, key images after the first included (`bake::keys`, default
    // budget): about 0.386 r² + 16.5 r (the cut-outs' padding weighs more at low
    // resolution), measured on the default character's Walk at 128², 137 views (5.8 MB of
    // colour and normals; 0.42 r² + 18 r before the atlases kept only the texels their
    // polygons sample, 2026-12-02); colour 4 bytes a texel plus the quarter-size normal atlas.
    // Against the packs written (default character, 128², 137 views, 40 polygon and up to 24
    // interior vertices, 2026-12-02): one clip 0.9 % under (BC7: 2.1 % under), four clips
    // 10.7 % over (BC7: 2.7 % over).
    let r = resolution as u64;
    let atlas = v * (r2 * 386 / 1000 + 165 * r / 10) * 5;
    let texture_bytes = texture_bytes * 4 / 3;
    let poly_geometry = pack_geometry(
        views,
        frames,
        parts,
        crate::bake::part_fit::DEFAULT_POLYGON_VERTICES
            + kept_interior(crate::bake::part_fit::DEFAULT_INTERIOR_VERTICES),
    );
    Estimate {
        polypostor: atlas + poly_geometry,
        polypostor_atlas: atlas,
        impostor: v * f * r2 * 4 * 2,
        np3d: v * r2 * 4 + f * 220 * 24 + 400 * 3 * 2,
        np3d_images: v * r2 * 4,
        rigid: f * n * 24 + n * 8 + texture_bytes,
        skinned: n * 56 + texture_bytes,
    }
}
