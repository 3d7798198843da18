//! The whole bake: segmentation and caps in, per-view fitted polygons, visibility orders,
//! key-frame images and fit errors out. GPU renders run on the calling thread; fitting runs
//! on the rayon pool, a few views ahead of the renderer.

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use super::profile;

use glam::Vec3;
use rayon::prelude::*;

use super::caps::{CapOverrides, find_caps};
use super::image_cost::PartTile;
use super::keys::{self, ExtraKey, KeyOptions, ViewBytes};
use super::overrides::{BakeOverrides, OverrideBasis, ViewOverride, valid_order};
use super::part_fit::{PartFit, PartFitOptions, fit_part};
use super::raster::{Canvas, psnr, tile_canvas};
use super::renders::{merge_parts, sample_timeline, view_cameras};
use super::segment::Segmentation;
use super::viewpoints::{Coverage, directions};
use super::visibility::draw_order;
use crate::character::Character;
use crate::gpu::{Camera, CharacterRenderer, GpuContext, GpuError, PartImages, PartRenderer};
use crate::timeline::Timeline;

/// Most frames tried as the key frame by [`KeyFrame::Auto`] (evenly spread over the clip).
pub const KEY_FRAME_CANDIDATES: usize = 5;

/// Most frames the key-frame ranking fits per candidate and probe view: a longer timeline
/// (several clips: 57 frames for the default's four, 203 for RobotExpressive's fourteen) is
/// ranked on every k-th frame and the candidates, so the ranking's cost stops growing with
/// the clip set. One clip of up to 4 s at 10 fps is ranked on every frame, as before.
pub const KEY_FRAME_PROBE_FRAMES: usize = 40;

/// The frames the key-frame ranking fits, in order: every frame of a timeline of up to
/// [`KEY_FRAME_PROBE_FRAMES`], else evenly spaced ones at most that many, plus `candidates`.
pub fn key_frame_probe_frames(frames: usize, candidates: &[usize]) -> Vec<usize> {
    if frames <= KEY_FRAME_PROBE_FRAMES {
        return (0..frames).collect();
    }
    let k = frames.div_ceil(KEY_FRAME_PROBE_FRAMES);
    let mut out: Vec<usize> = (0..frames)
        .step_by(k)
        .chain(candidates.iter().copied().filter(|&f| f < frames))
        .collect();
    out.sort_unstable();
    out.dedup();
    out
}

/// How the texture key-frame is chosen.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum KeyFrame {
    /// The frame that lets the others fit best (tried on a few views).
    #[default]
    Auto,
    Frame(usize),
}

impl KeyFrame {
    /// `auto` or a frame number (the command line's `--key-frame`).
    pub fn parse(s: &str) -> Result<Self, String> {
        match s {
            "auto" => Ok(Self::Auto),
            k => k
                .parse()
                .map(Self::Frame)
                .map_err(|_| format!("--key-frame must be a frame number or 'auto', not '{k}'")),
        }
    }
}

/// Every setting of a bake.
#[derive(Clone, Debug, PartialEq)]
pub struct BakeOptions {
    pub views: usize,
    pub coverage: Coverage,
    pub resolution: u32,
    pub fps: f32,
    /// Clip index (None: rest pose).
    pub clip: Option<usize>,
    /// Further clips baked after `clip` into the same pack (a whole-character pack: one set of
    /// key images for every clip, [`crate::timeline`]).
    pub extra_clips: Vec<usize>,
    pub key_frame: KeyFrame,
    pub fit: PartFitOptions,
    /// Views used to choose the key frame automatically.
    pub key_frame_probe_views: usize,
    /// Keep every frame's part images (for debug images; memory grows with views × frames).
    pub keep_frame_images: bool,
    /// The artist's corrections (per-view key frame, order, pins), applied where their basis
    /// matches this bake's views and frames.
    pub overrides: BakeOverrides,
    /// How the pack's atlases are stored: BC7 blocks in KTX2 files (what a GPU samples, a
    /// quarter of RGBA8's bytes) or PNG (lossless, for tools).
    pub textures: TextureEncoding,
    /// How hard PNG textures are compressed (lossless either way).
    pub png: PngCompression,
    /// How many key images each view's parts get, and which ([`keys`]).
    pub keys: KeyOptions,
}

/// How a pack's atlases are written.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum TextureEncoding {
    /// BC7 blocks in KTX2 containers (`atlas_NNN.ktx2`): uploaded as they are where the
    /// adapter samples BC7, decoded to RGBA8 where it does not. Lossy (see the README's
    /// figures).
    #[default]
    #[serde(alias = "bc7", alias = "BC7")]
    Bc7,
    /// Lossless PNG (`atlas_NNN.png`) at [`BakeOptions::png`]'s level.
    #[serde(alias = "png", alias = "PNG")]
    Png,
}

impl TextureEncoding {
    /// Both encodings, BC7 first.
    pub const ALL: [TextureEncoding; 2] = [TextureEncoding::Bc7, TextureEncoding::Png];

    /// The name the command line takes.
    pub fn name(self) -> &'static str {
        match self {
            TextureEncoding::Bc7 => "bc7",
            TextureEncoding::Png => "png",
        }
    }

    /// The file extension of its textures.
    pub fn extension(self) -> &'static str {
        match self {
            TextureEncoding::Bc7 => "ktx2",
            TextureEncoding::Png => "png",
        }
    }

    /// The encoding named `name` (`bc7` or `png`).
    pub fn parse(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|t| t.name() == name)
    }
}

/// PNG compression of the written textures: lossless at every level, trading write time for
/// file size.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum PngCompression {
    #[serde(alias = "fast")]
    Fast,
    #[default]
    #[serde(alias = "balanced")]
    Balanced,
    #[serde(alias = "best")]
    Best,
}

impl PngCompression {
    pub const ALL: [PngCompression; 3] = [PngCompression::Fast, PngCompression::Balanced, PngCompression::Best];

    pub fn label(self) -> &'static str {
        match self {
            PngCompression::Fast => "PNG, fast",
            PngCompression::Balanced => "PNG, balanced",
            PngCompression::Best => "PNG, smallest",
        }
    }

    /// Encodes `img` as PNG at this level (marked as this tool's: see [`crate::safe_fs`]).
    pub fn encode(self, img: &image::RgbaImage) -> Result<Vec<u8>, String> {
        let level = match self {
            PngCompression::Fast => png::Compression::Fast,
            PngCompression::Balanced => png::Compression::Balanced,
            PngCompression::Best => png::Compression::High,
        };
        crate::safe_fs::encode_png(img, level)
    }
}

impl BakeOptions {
    /// Every clip baked, in order: `clip` then `extra_clips`.
    pub fn clip_list(&self) -> Vec<Option<usize>> {
        std::iter::once(self.clip)
            .chain(self.extra_clips.iter().map(|&c| Some(c)))
            .collect()
    }

    /// The frames baked: every clip of [`BakeOptions::clip_list`] at the bake's rate, with
    /// their measured ground speeds.
    pub fn timeline(&self, character: &Character) -> Result<Timeline, crate::limits::LimitError> {
        Timeline::measured(character, &self.clip_list(), self.fps)
    }
}

impl Default for BakeOptions {
    fn default() -> Self {
        Self {
            views: super::viewpoints::DEFAULT_VIEW_COUNT,
            coverage: Coverage::UpperHemisphere,
            resolution: super::renders::DEFAULT_RESOLUTION,
            fps: super::renders::DEFAULT_FPS,
            clip: Some(0),
            extra_clips: Vec::new(),
            key_frame: KeyFrame::Auto,
            fit: PartFitOptions::default(),
            key_frame_probe_views: 4,
            keep_frame_images: false,
            overrides: BakeOverrides::default(),
            textures: TextureEncoding::default(),
            png: PngCompression::default(),
            keys: KeyOptions::default(),
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum BakeError {
    #[error("GPU: {0}")]
    Gpu(#[from] GpuError),
    #[error("the segmentation has {got} labels but the character has {want} triangles")]
    Segmentation { got: usize, want: usize },
    #[error("key frame {0} is out of range ({1} frames)")]
    KeyFrame(usize, usize),
    #[error("{0}")]
    Limit(#[from] crate::limits::LimitError),
    #[error("cancelled")]
    Cancelled,
}

/// The result for one part in one view.
#[derive(Clone, Debug)]
pub struct PartResult {
    /// `None` when the part could not be fitted here (e.g. seen edge-on); the message says why.
    pub fit: Option<PartFit>,
    pub problem: Option<String>,
    /// PSNR of the part's polypostor against its own render, per frame.
    pub psnr: Vec<f64>,
    /// SSIM of the same ([`crate::metrics`]), per frame.
    pub ssim: Vec<f64>,
    /// The key-frame colour and normal images of the part (RGBA8, `resolution²`).
    pub key_color: image::RgbaImage,
    pub key_normal: image::RgbaImage,
    /// Rendered squared colour error per frame of the first key's fit ([`keys::sse`]).
    pub sse: Vec<f64>,
    /// Key images after the first ([`keys`]).
    pub extra: Vec<ExtraKey>,
    /// Per frame, the key it is drawn from: 0 the first, `k` `extra[k - 1]` (empty: all 0).
    pub frame_key: Vec<u8>,
    /// The first key's drawn error summed over frames before its interior vertices (its
    /// outline alone): what the view's interior vertices are priced against
    /// ([`view_fit_options`]).
    pub outline_error: f64,
}

impl PartResult {
    /// The fit and key frame drawing frame `f`.
    pub fn fit_at(&self, f: usize) -> Option<(&PartFit, usize)> {
        let k = self.frame_key.get(f).copied().unwrap_or(0) as usize;
        match k {
            0 => self.fit.as_ref().map(|fit| (fit, fit.key_frame)),
            k => self.extra.get(k - 1).map(|e| (&e.fit, e.frame)),
        }
    }

    /// Every key frame of the part, the first one first.
    pub fn key_frames(&self) -> Vec<usize> {
        self.fit
            .iter()
            .map(|f| f.key_frame)
            .chain(self.extra.iter().map(|e| e.frame))
            .collect()
    }
}

/// The result for one view.
#[derive(Clone, Debug)]
pub struct ViewResult {
    pub direction: Vec3,
    pub camera: Camera,
    /// This view's texture key frame (the bake's unless overridden).
    pub key_frame: usize,
    pub parts: Vec<PartResult>,
    /// `hidden[a][b]`: pixels of part b hidden by part a, averaged over frames.
    pub hidden: Vec<Vec<f64>>,
    /// Drawing order, back to front.
    pub order: Vec<usize>,
    /// The composited character's error per frame (PSNR moving and still, SSIM, silhouette
    /// agreement) and the renders' brightness.
    pub error: CompositeError,
    /// Every part's colour image per frame, when [`BakeOptions::keep_frame_images`] is set.
    pub frame_colors: Vec<Vec<image::RgbaImage>>,
    /// The key budget ([`KeyOptions::budget`]) this view's keys were chosen with when the
    /// bake gave it more than its own ([`share_key_budget`]); `None`: the bake's.
    pub key_budget: Option<f64>,
}

/// A finished bake.
pub struct Bake {
    pub options: BakeOptions,
    /// Each frame's time in its clip.
    pub frame_times: Vec<f32>,
    /// The clips baked, one after another ([`crate::timeline`]).
    pub timeline: Timeline,
    pub key_frame: usize,
    pub segmentation: Segmentation,
    /// The cap colours it was made with.
    pub caps: CapOverrides,
    pub views: Vec<ViewResult>,
    /// Seconds per stage.
    pub stage_secs: BTreeMap<String, f64>,
    pub adapter: String,
    /// The file the character came from, when the caller knows it (written into the pack's
    /// manifest: [`polypostor_runtime::pack::Manifest::character_path`]).
    pub character_path: Option<String>,
    /// Which of that file's axes was read as up ([`crate::character::Character::up_axis`]).
    pub character_up: crate::import::UpAxis,
}

impl Bake {
    /// What the view numbers of this bake's corrections refer to.
    pub fn basis(&self) -> OverrideBasis {
        OverrideBasis {
            views: self.views.len(),
            full_sphere: self.options.coverage == Coverage::FullSphere,
            frames: self.frame_times.len(),
        }
    }

    /// The corrections in [`BakeOptions::overrides`] this bake could not apply, by kind:
    /// those [`BakeOverrides::audit`] finds, and pins on polygon vertices the fitted part
    /// does not have (or on a part not fitted in its view).
    pub fn dropped_corrections(&self) -> super::overrides::DroppedCorrections {
        let basis = self.basis();
        let parts = self.segmentation.parts.len();
        let overrides = &self.options.overrides;
        let mut d = overrides.audit(basis, parts);
        if overrides.basis != basis {
            return d;
        }
        for (&v, o) in &overrides.views {
            let Some(view) = self.views.get(v) else { continue };
            if let Some(keys) = &o.keys {
                d.keys_over += super::overrides::keys_over(keys, basis.frames, view.key_frame);
            }
            for (&p, pins) in &o.pins {
                let Some(part) = view.parts.get(p) else { continue };
                d.pins += pins
                    .iter()
                    .filter(|pin| pin.frame < basis.frames)
                    .filter(|pin| {
                        part.fit.as_ref().is_none_or(|fit| {
                            pin.source >= fit.key_polygon.len()
                                || fit.targets.get(pin.frame).is_none_or(|t| pin.target >= t.len())
                        })
                    })
                    .count();
            }
        }
        d
    }
}

/// Progress callback data.
#[derive(Clone, Debug)]
pub struct Progress {
    pub stage: &'static str,
    pub done: usize,
    pub total: usize,
}

/// One view's renders, ready to fit: every part's tile per frame, the occlusion weights and
/// the images (with depth) they came from.
pub struct ViewData {
    pub tiles: Vec<Vec<PartTile>>,
    /// The clips the frames belong to (each loops on its own: a key may only draw a frame
    /// whose neighbours in its clip it also fits).
    pub clips: Vec<crate::timeline::ClipSpan>,
    pub hidden: Vec<Vec<f64>>,
    pub depth_order_tiles: PartImages,
}

/// A view's part tiles and occlusion from its renders; `clips`: the timeline's spans.
pub fn extract(images: PartImages, clips: &[crate::timeline::ClipSpan]) -> ViewData {
    let (parts, frames, r) = (images.parts, images.frames, images.resolution);
    let tiles: Vec<Vec<PartTile>> = (0..parts)
        .map(|p| {
            (0..frames)
                .map(|f| PartTile::from_images(&images.tile(&images.color, p, f), &images.tile(&images.normal, p, f)))
                .collect()
        })
        .collect();
    let mut hidden = vec![vec![0.0f64; parts]; parts];
    for f in 0..frames {
        for y in 0..r {
            for x in 0..r {
                let covering: Vec<(usize, f32)> = (0..parts)
                    .filter(|&p| images.covered(p, f, x, y))
                    .map(|p| (p, images.depth_at(p, f, x, y)))
                    .collect();
                for &(a, da) in &covering {
                    for &(b, db) in &covering {
                        if a != b && da < db {
                            hidden[a][b] += 1.0;
                        }
                    }
                }
            }
        }
    }
    for row in &mut hidden {
        for w in row {
            *w /= frames.max(1) as f64;
        }
    }
    ViewData {
        tiles,
        clips: clips.to_vec(),
        hidden,
        depth_order_tiles: images,
    }
}

/// The ground truth of a frame: the parts composited by depth.
pub fn ground_truth(images: &PartImages, frame: usize) -> Canvas {
    let r = images.resolution;
    let mut c = Canvas::new(r);
    for y in 0..r {
        for x in 0..r {
            if let Some(p) = images.front_part(frame, x, y) {
                let (ox, oy) = images.tile_origin(p, frame);
                let q = images.color.get_pixel(ox + x, oy + y);
                c.px[(y * r + x) as usize] = [q[0] as f32 / 255.0, q[1] as f32 / 255.0, q[2] as f32 / 255.0, 1.0];
            }
        }
    }
    c
}

/// Draws the polypostor of one view at one frame.
pub fn render_polypostor(
    parts: &[PartResult],
    key_tiles: &[PartTile],
    order: &[usize],
    frame: usize,
    size: u32,
) -> Canvas {
    let mut c = Canvas::new(size);
    for &p in order {
        let Some(fit) = &parts[p].fit else { continue };
        let pos = fit.positions(frame);
        let uv = fit.uvs();
        for t in &fit.triangles {
            c.draw_textured(t.map(|i| pos[i]), t.map(|i| uv[i]), &key_tiles[p]);
        }
    }
    c
}

/// Draws the polypostor of one view at one frame as the bake wrote it: each part from the
/// key that draws that frame. `tiles[p][f]`: part `p`'s tile at frame `f`.
pub fn render_view_frame(
    parts: &[PartResult],
    tiles: &[Vec<PartTile>],
    order: &[usize],
    frame: usize,
    size: u32,
) -> Canvas {
    let mut c = Canvas::new(size);
    for &p in order {
        let Some((fit, key)) = parts[p].fit_at(frame) else {
            continue;
        };
        let pos = fit.positions(frame);
        let uv = fit.uvs();
        for t in &fit.triangles {
            c.draw_textured(t.map(|i| pos[i]), t.map(|i| uv[i]), &tiles[p][key]);
        }
    }
    c
}

/// Fits one part of a view (with its pins) on its outline alone and measures its squared
/// error against its own render per frame ([`PartResult::outline_error`]); `refit_view` then
/// gives it its interior vertices and its PSNR and SSIM.
pub fn fit_view_part(
    data: &ViewData,
    p: usize,
    key: usize,
    options: &PartFitOptions,
    pins: &[Vec<(usize, usize)>],
) -> PartResult {
    let images = &data.depth_order_tiles;
    let tiles = &data.tiles[p];
    let outline_only = PartFitOptions {
        interior_vertices: 0,
        ..*options
    };
    let (fit, problem) = match profile::in_root("part fit", || fit_part(tiles, key, &outline_only, pins)) {
        Ok(f) => (Some(f), None),
        Err(e) => (None, Some(e.to_string())),
    };
    let mut r = PartResult {
        fit,
        problem,
        psnr: Vec::new(),
        ssim: Vec::new(),
        key_color: images.tile(&images.color, p, key),
        key_normal: images.tile(&images.normal, p, key),
        sse: Vec::new(),
        extra: Vec::new(),
        frame_key: Vec::new(),
        outline_error: 0.0,
    };
    // The interior vertices come later, priced by the whole view (`refit_view`): here only
    // the outline's error, which prices them.
    measure_first_key(data, p, &mut r, false);
    r.outline_error = r.sse.iter().sum();
    r
}

/// Part `p`'s first key's squared error (and with `quality` its PSNR and SSIM) at every frame
/// against its render.
fn measure_first_key(data: &ViewData, p: usize, r: &mut PartResult, quality: bool) {
    let _measure = profile::root("measure");
    let tiles = &data.tiles[p];
    let frames = tiles.len();
    let per_frame: Vec<(f64, f64, f64)> = (0..frames)
        .map(|f| match &r.fit {
            Some(fit) => {
                let c = keys::draw_part(fit, &tiles[fit.key_frame], f, tiles[f].size);
                let truth = tile_canvas(&tiles[f]);
                let (rmse, n) = c.rmse(&truth);
                let ssim = if quality { c.ssim(&truth) } else { 0.0 };
                // As keys::sse, from the same RMSE.
                (psnr(rmse), ssim, rmse * rmse * (3 * n) as f64)
            }
            None => (0.0, 0.0, 0.0),
        })
        .collect();
    r.psnr = per_frame.iter().map(|e| e.0).collect();
    r.ssim = per_frame.iter().map(|e| e.1).collect();
    r.sse = per_frame.iter().map(|e| e.2).collect();
}

/// Share of a view's outline-only drawn error (its parts' [`PartResult::outline_error`]
/// summed) an interior vertex must be expected to cut per byte it adds: the view's PSNR is
/// what the bake reports, so a vertex is worth the same in a view drawn almost perfectly
/// (where a small cut is a large part of the error) as a larger cut where the error is large.
/// 3·10⁻⁶ per byte: about 0.013 dB of the view per kilobyte (the extra keys kept on
/// RobotExpressive buy 0.005–0.02 dB per kilobyte).
pub const INTERIOR_MIN_SHARE: f64 = 3e-6;

/// `options` with the interior vertices priced for a view whose parts are `parts`
/// ([`PartFitOptions::interior_min_gain`] = [`INTERIOR_MIN_SHARE`] of their outline-only
/// error): the same for every part and key of the view, whichever way it is fitted.
pub fn view_fit_options(options: &PartFitOptions, parts: &[PartResult]) -> PartFitOptions {
    let error: f64 = parts.iter().map(|r| r.outline_error).sum();
    PartFitOptions {
        interior_min_gain: INTERIOR_MIN_SHARE * error,
        ..*options
    }
}

/// Gives part `p`'s first key, fitted on its outline alone, its interior vertices
/// ([`crate::bake::part_fit::add_interior_vertices`] over all frames, priced by `options`)
/// and measures it.
fn add_first_key_interior(data: &ViewData, p: usize, r: &mut PartResult, options: &PartFitOptions) {
    if let Some(fit) = r.fit.as_mut() {
        let frames = data.tiles[p].len();
        let all = crate::bake::part_fit::Span {
            start: 0,
            count: frames,
        };
        profile::in_root("part fit", || {
            crate::bake::part_fit::add_interior_vertices(fit, &data.tiles[p], all, options)
        });
    }
    measure_first_key(data, p, r, true);
}

/// Gives the parts of a view their key images after the first ([`keys::choose`]; `manual`:
/// the artist's extra key frames), then each frame's key and its PSNR and SSIM.
pub fn add_view_keys(
    data: &ViewData,
    parts: &mut [PartResult],
    options: &PartFitOptions,
    key_options: &KeyOptions,
    manual: Option<&[usize]>,
) {
    let frames = data.tiles.first().map_or(0, |t| t.len());
    let images = &data.depth_order_tiles;
    let options = &view_fit_options(options, parts);
    {
        let mut state: Vec<Option<keys::PartKeys<'_>>> = parts
            .iter()
            .enumerate()
            .map(|(p, r)| {
                r.fit.as_ref().map(|fit| keys::PartKeys {
                    tiles: &data.tiles[p],
                    clips: &data.clips,
                    targets: &fit.targets,
                    primary: fit,
                    primary_sse: &r.sse,
                    extra: Vec::new(),
                })
            })
            .collect();
        let grab = |p: usize, f: usize| (images.tile(&images.color, p, f), images.tile(&images.normal, p, f));
        keys::choose(&mut state, options, key_options, manual, &grab);
        let chosen: Vec<Vec<ExtraKey>> = state
            .into_iter()
            .map(|s| s.map(|s| s.extra).unwrap_or_default())
            .collect();
        for (r, extra) in parts.iter_mut().zip(chosen) {
            r.extra = extra;
        }
    }
    parts.par_iter_mut().enumerate().for_each(|(p, r)| {
        let _measure = profile::root("measure");
        if r.extra.is_empty() {
            r.frame_key.clear();
            return;
        }
        r.frame_key = keys::assign(&r.sse, &r.extra, frames);
        for f in 0..frames {
            let k = r.frame_key[f] as usize;
            if k == 0 {
                continue;
            }
            let e = &r.extra[k - 1];
            let (q, s) = keys::frame_quality(&e.fit, &data.tiles[p][e.frame], &data.tiles[p][f], f);
            r.psnr[f] = q;
            r.ssim[f] = s;
        }
    });
}

/// The composite's error per frame against the ground truth.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CompositeError {
    /// PSNR with the polygons moving (dB).
    pub psnr: Vec<f64>,
    /// PSNR with the polygons left still at the key frame (what fitting gains).
    pub psnr_static: Vec<f64>,
    /// SSIM with the polygons moving.
    pub ssim: Vec<f64>,
    /// Silhouette agreement with the polygons moving ([`Canvas::silhouette_iou`]).
    pub silhouette_iou: Vec<f64>,
    /// The renders' brightness: the mean over their covered pixels of the brightest channel
    /// (0..1; under about 0.1 PSNR and SSIM see little of the shape, see
    /// [`DARK_BRIGHTNESS`]).
    pub truth_brightness: f64,
}

/// Renders darker than this ([`CompositeError::truth_brightness`]) leave PSNR and SSIM, which
/// compare colour × coverage against a black background, blind to most shape errors: the
/// bake says so and points at the silhouette agreement.
pub const DARK_BRIGHTNESS: f64 = 0.1;

/// Whether renders of brightness `brightness` ([`CompositeError::truth_brightness`]) are
/// too dark for PSNR and SSIM to judge shape: under [`DARK_BRIGHTNESS`]. The one test the
/// bake, `compare` and the editor use.
pub fn is_dark(brightness: f64) -> bool {
    brightness < DARK_BRIGHTNESS
}

/// What the bake, `compare` and the editor say of renders of brightness `brightness`
/// ([`CompositeError::truth_brightness`]): a warning where [`is_dark`], else nothing.
pub fn dark_note(brightness: f64) -> Option<String> {
    is_dark(brightness).then(|| {
        format!(
            "the character is nearly black (its renders' brightest channel averages {brightness:.2}): PSNR and SSIM \
             compare colour against a black background and see little of its shape errors; read the silhouette \
             agreement (IoU of the covered pixels, 1 = the same shape)"
        )
    })
}

/// The composite's PSNR and SSIM per frame against the ground truth, with the polygons
/// moving, and its PSNR left still at the key frame. Frames are measured in parallel.
pub fn composite_error(data: &ViewData, parts: &[PartResult], order: &[usize], key: usize) -> CompositeError {
    let images = &data.depth_order_tiles;
    let frames = data.tiles.first().map_or(0, |t| t.len());
    // Each part textured from its own first key (see [`part_key`]).
    let key_tiles: Vec<PartTile> = data
        .tiles
        .iter()
        .zip(parts)
        .map(|(t, r)| {
            t[r.fit
                .as_ref()
                .map_or(key, |f| f.key_frame)
                .min(t.len().saturating_sub(1))]
            .clone()
        })
        .collect();
    let still = profile::in_root("composite", || {
        render_polypostor(parts, &key_tiles, order, key, images.resolution)
    });
    let per_frame: Vec<(f64, f64, f64, f64, (f64, usize))> = (0..frames)
        .into_par_iter()
        .map(|f| {
            let _composite = profile::root("composite");
            let gt = ground_truth(images, f);
            let poly = render_view_frame(parts, &data.tiles, order, f, images.resolution);
            (
                psnr(poly.rmse(&gt).0),
                psnr(still.rmse(&gt).0),
                poly.ssim(&gt),
                poly.silhouette_iou(&gt),
                gt.brightness(),
            )
        })
        .collect();
    let (lit, covered) = per_frame.iter().fold((0.0, 0usize), |(s, n), e| (s + e.4.0, n + e.4.1));
    CompositeError {
        psnr: per_frame.iter().map(|e| e.0).collect(),
        psnr_static: per_frame.iter().map(|e| e.1).collect(),
        ssim: per_frame.iter().map(|e| e.2).collect(),
        silhouette_iou: per_frame.iter().map(|e| e.3).collect(),
        truth_brightness: if covered == 0 { 1.0 } else { lit / covered as f64 },
    }
}

/// The drawing order of a view: the override when it is a valid permutation, else the
/// minimum feedback arc set of the occlusion graph.
pub fn view_order(hidden: &[Vec<f64>], ov: Option<&ViewOverride>) -> Vec<usize> {
    match ov.and_then(|o| o.order.as_ref()) {
        Some(order) if valid_order(order, hidden.len()) => order.clone(),
        _ => profile::in_root("order", || draw_order(hidden).order),
    }
}

/// The key frame a view is fitted with: its override when it is a frame of the bake, else
/// the bake's key frame (clamped to the frames).
/// A part whose image at the view's key frame covers less than this share of its largest
/// image over the clip gets its own first key ([`part_key`]).
pub const FORESHORTENED: f64 = 0.5;

/// The first key frame of a part: the view's key frame `key`, unless the part's image there
/// covers less than [`FORESHORTENED`] of its largest image over the clip — the part is turned
/// away or foreshortened there, and its texture would be stretched into a wedge over the
/// frames where it is seen in full; then the frame of its largest image (a texture shrunk
/// where the part foreshortens loses little). `forced`: the artist set the view's key frame,
/// which then holds for every part.
pub fn part_key(tiles: &[PartTile], key: usize, forced: bool) -> usize {
    if forced || tiles.len() < 2 || key >= tiles.len() {
        return key;
    }
    let area: Vec<f64> = tiles.iter().map(|t| t.px.iter().map(|p| p[6] as f64).sum()).collect();
    let (best, largest) = area
        .iter()
        .enumerate()
        .fold((key, area[key]), |b, (f, &a)| if a > b.1 { (f, a) } else { b });
    if area[key] >= FORESHORTENED * largest {
        key
    } else {
        best
    }
}

pub fn view_key(ov: Option<&ViewOverride>, bake_key: usize, frames: usize) -> usize {
    ov.and_then(|o| o.key_frame)
        .filter(|&k| k < frames)
        .unwrap_or(bake_key.min(frames.saturating_sub(1)))
}

/// A view fitted before, whose parts a re-fit may keep.
#[derive(Clone, Copy)]
pub struct PreviousFit<'a> {
    pub key: usize,
    pub parts: &'a [PartResult],
    /// The corrections it was fitted with.
    pub ov: &'a ViewOverride,
}

/// One view fitted by [`refit_view`].
#[derive(Clone, Debug)]
pub struct ViewFit {
    pub key: usize,
    pub parts: Vec<PartResult>,
    /// The parts fitted now (the others were kept from the previous fit).
    pub refit: Vec<usize>,
    pub order: Vec<usize>,
    pub error: CompositeError,
}

/// Fits one view, or re-fits it after its corrections changed: the one way the bake, the
/// incremental re-bake and the editor's inspector fit a view, so the inspector shows exactly
/// what a bake writes.
///
/// The key frame is [`view_key`]. Without `prev` every part is fitted. With it, every part is
/// fitted again when the key frame differs from the previous one, else only the parts whose
/// pins changed; the others are kept. The order is the override when valid, else computed
/// ([`view_order`]); the composite error is measured last.
pub fn refit_view(
    data: &ViewData,
    bake_key: usize,
    options: &PartFitOptions,
    key_options: &KeyOptions,
    ov: Option<&ViewOverride>,
    prev: Option<PreviousFit<'_>>,
) -> ViewFit {
    let parts_n = data.tiles.len();
    let frames = data.tiles.first().map_or(0, |t| t.len());
    let key = view_key(ov, bake_key, frames);
    let no_pins = std::collections::BTreeMap::new();
    let pins_now = ov.map_or(&no_pins, |o| &o.pins);
    let manual = ov.and_then(|o| o.keys.as_deref());
    let refit: Vec<usize> = match prev {
        Some(prev) if prev.key == key && prev.parts.len() == parts_n => (0..parts_n)
            .filter(|p| pins_now.get(p) != prev.ov.pins.get(p))
            .collect(),
        _ => (0..parts_n).collect(),
    };
    let same_keys = prev.is_some_and(|prev| prev.ov.keys.as_deref() == manual);
    // Outlines first; the interior vertices once the whole view's error prices them.
    let fitted: Vec<PartResult> = refit
        .par_iter()
        .map(|&p| {
            let pins = ov.map_or_else(Vec::new, |o| o.pins_per_frame(p, frames));
            let forced = ov.is_some_and(|o| o.key_frame.is_some());
            fit_view_part(data, p, part_key(&data.tiles[p], key, forced), options, &pins)
        })
        .collect();
    let mut parts: Vec<Option<PartResult>> = match prev {
        Some(prev) if prev.parts.len() == parts_n => prev.parts.iter().cloned().map(Some).collect(),
        _ => vec![None; parts_n],
    };
    for (&p, r) in refit.iter().zip(fitted) {
        parts[p] = Some(r);
    }
    let mut parts: Vec<PartResult> = parts
        .into_iter()
        .map(|p| p.expect("every part fitted or kept"))
        .collect();
    if !refit.is_empty() {
        let priced = view_fit_options(options, &parts);
        let mut fresh: Vec<(usize, &mut PartResult)> = parts
            .iter_mut()
            .enumerate()
            .filter(|(p, _)| refit.contains(p))
            .collect();
        fresh
            .par_iter_mut()
            .for_each(|(p, r)| add_first_key_interior(data, *p, r, &priced));
    }
    // The extra keys depend on every part of the view (one budget): chosen again whenever
    // a part was re-fitted or the artist's keys changed, exactly as a bake would.
    if !refit.is_empty() || !same_keys {
        if refit.len() < parts_n {
            // Kept parts go back to their first key's PSNR and SSIM before the choice.
            for p in (0..parts_n).filter(|p| !refit.contains(p)) {
                first_key_only(data, p, &mut parts[p]);
            }
        }
        add_view_keys(data, &mut parts, options, key_options, manual);
    }
    let order = view_order(&data.hidden, ov);
    let error = composite_error(data, &parts, &order, key);
    ViewFit {
        key,
        parts,
        refit,
        order,
        error,
    }
}

/// Takes part `p`'s key images after the first away: every frame drawn from the first again,
/// with its PSNR and SSIM.
fn first_key_only(data: &ViewData, p: usize, r: &mut PartResult) {
    let frames = data.tiles.first().map_or(0, |t| t.len());
    if let Some(fit) = &r.fit {
        for f in (0..frames).filter(|&f| r.frame_key.get(f).is_some_and(|&k| k != 0)) {
            let (q, s) = keys::frame_quality(fit, &data.tiles[p][fit.key_frame], &data.tiles[p][f], f);
            r.psnr[f] = q;
            r.ssim[f] = s;
        }
    }
    r.extra.clear();
    r.frame_key.clear();
}

/// The key images of a fitted view chosen again with `key_options` (another budget), its
/// first keys kept: what [`refit_view`] from scratch gives with those options, without
/// fitting the first keys again.
pub fn rechoose_view_keys(
    data: &ViewData,
    view: &mut ViewResult,
    options: &PartFitOptions,
    key_options: &KeyOptions,
    ov: Option<&ViewOverride>,
) {
    for (p, r) in view.parts.iter_mut().enumerate() {
        first_key_only(data, p, r);
    }
    add_view_keys(
        data,
        &mut view.parts,
        options,
        key_options,
        ov.and_then(|o| o.keys.as_deref()),
    );
    view.error = composite_error(data, &view.parts, &view.order, view.key_frame);
}

/// Bytes of a view's first key images and of its key images after them.
pub fn view_key_bytes(view: &ViewResult) -> (f64, f64) {
    let first = view
        .parts
        .iter()
        .filter_map(|p| p.fit.as_ref())
        .map(keys::key_bytes)
        .sum();
    let extra = view
        .parts
        .iter()
        .flat_map(|p| &p.extra)
        .map(|e| keys::key_bytes(&e.fit))
        .sum();
    (first, extra)
}

/// Fits a whole view ([`refit_view`] from scratch) and keeps what the bake writes.
#[allow(clippy::too_many_arguments)]
pub fn fit_view(
    direction: Vec3,
    camera: Camera,
    data: ViewData,
    key: usize,
    options: &PartFitOptions,
    key_options: &KeyOptions,
    keep: bool,
    ov: Option<&ViewOverride>,
) -> ViewResult {
    let fit = refit_view(&data, key, options, key_options, ov, None);
    let frames = data.tiles.first().map_or(0, |t| t.len());
    let images = &data.depth_order_tiles;
    let frame_colors = if keep {
        (0..data.tiles.len())
            .map(|p| (0..frames).map(|f| images.tile(&images.color, p, f)).collect())
            .collect()
    } else {
        Vec::new()
    };
    ViewResult {
        direction,
        camera,
        key_frame: fit.key,
        parts: fit.parts,
        hidden: data.hidden,
        order: fit.order,
        error: fit.error,
        frame_colors,
        key_budget: None,
    }
}

/// Everything a bake sets up before fitting views: the capped, merged character uploaded
/// with its frames, the view directions and cameras. Views can then be rendered one at a
/// time (the editor re-fits single views with it).
pub struct Prepared {
    /// Each frame's time in its clip.
    pub times: Vec<f32>,
    pub timeline: Timeline,
    pub directions: Vec<Vec3>,
    pub cameras: Vec<Camera>,
    pub basis: OverrideBasis,
    renderer: CharacterRenderer,
    batch: PartRenderer,
}

impl Prepared {
    /// Caps, merges, samples the frames, places the views and uploads everything.
    pub fn new(
        ctx: &GpuContext,
        character: &Character,
        segmentation: &Segmentation,
        cap_overrides: &CapOverrides,
        options: &BakeOptions,
    ) -> Result<Self, BakeError> {
        if segmentation.labels.len() != character.triangle_count() {
            return Err(BakeError::Segmentation {
                got: segmentation.labels.len(),
                want: character.triangle_count(),
            });
        }
        let max_side = ctx.device.limits().max_texture_dimension_2d;
        super::plan::check(
            character,
            segmentation,
            options,
            polypostor_runtime::reps::RepSet::POLYPOSTOR,
            max_side,
        )?;
        let caps = find_caps(character, segmentation);
        let (merged, ranges) = merge_parts(character, segmentation, &caps, cap_overrides);
        let timeline = options.timeline(character)?;
        let samples = timeline.samples();
        let times: Vec<f32> = samples.iter().map(|s| s.1).collect();
        let (poses, points) = sample_timeline(&merged, &samples);
        let dirs = directions(options.views.max(1), options.coverage);
        let cameras = view_cameras(&points, &dirs);
        let renderer = CharacterRenderer::new(&ctx.device);
        let batch = PartRenderer::new(
            &renderer,
            &ctx.device,
            &ctx.queue,
            &merged,
            ranges,
            &poses,
            options.resolution,
        );
        let basis = OverrideBasis {
            views: dirs.len(),
            full_sphere: options.coverage == Coverage::FullSphere,
            frames: times.len(),
        };
        Ok(Self {
            times,
            timeline,
            directions: dirs,
            cameras,
            basis,
            renderer,
            batch,
        })
    }

    /// Renders view `v`'s parts at every frame.
    pub fn render(&self, ctx: &GpuContext, v: usize) -> Result<ViewData, BakeError> {
        Ok(extract(self.render_images(ctx, v)?, &self.timeline.spans))
    }

    fn render_images(&self, ctx: &GpuContext, v: usize) -> Result<PartImages, BakeError> {
        let _render = profile::root("render");
        Ok(self
            .batch
            .render_view(&self.renderer, &ctx.device, &ctx.queue, &self.cameras[v])?)
    }

    /// The bake's key frame: the one asked for, or (auto) the candidate whose fits cost least
    /// over a few probe views.
    pub fn key_frame(
        &self,
        ctx: &GpuContext,
        options: &BakeOptions,
        progress: &(dyn Fn(Progress) + Sync),
        cancel: &AtomicBool,
    ) -> Result<usize, BakeError> {
        let times = &self.times;
        Ok(match options.key_frame {
            KeyFrame::Frame(k) if k < times.len() => k,
            KeyFrame::Frame(k) => return Err(BakeError::KeyFrame(k, times.len())),
            KeyFrame::Auto if times.len() == 1 => 0,
            KeyFrame::Auto => {
                let n_dirs = self.directions.len();
                let probes: Vec<usize> = (0..options.key_frame_probe_views.max(1))
                    .map(|i| (i * n_dirs) / options.key_frame_probe_views.max(1))
                    .collect();
                // Candidate key frames: at most KEY_FRAME_CANDIDATES, evenly spread.
                let step = times.len().div_ceil(KEY_FRAME_CANDIDATES).max(1);
                let candidates: Vec<usize> = (0..times.len()).step_by(step).collect();
                let mut totals = vec![0.0f64; candidates.len()];
                // Every clip counts the same (a long idle does not outvote a short run).
                let weights = keys::frame_weights(&self.timeline.spans, times.len());
                // A long timeline is ranked on a subset of its frames (the candidates in it).
                let probed = key_frame_probe_frames(times.len(), &candidates);
                let weights: Vec<f64> = probed.iter().map(|&f| weights[f]).collect();
                let at: Vec<usize> = candidates
                    .iter()
                    .map(|k| probed.iter().position(|f| f == k).expect("the candidates are probed"))
                    .collect();
                for (n, &v) in probes.iter().enumerate() {
                    if cancel.load(Ordering::Relaxed) {
                        return Err(BakeError::Cancelled);
                    }
                    progress(Progress {
                        stage: "key frame",
                        done: n,
                        total: probes.len(),
                    });
                    let data = self.render(ctx, v)?;
                    let subset: Option<Vec<Vec<PartTile>>> = (probed.len() < times.len()).then(|| {
                        data.tiles
                            .iter()
                            .map(|t| probed.iter().map(|&f| t[f].clone()).collect())
                            .collect()
                    });
                    let part_tiles = subset.as_ref().unwrap_or(&data.tiles);
                    // Ranking key frames needs no restarts (they polish the poorest frames of
                    // whichever key) and one refinement pass without sweeps: the candidates are
                    // compared with each other, all fitted the same way, at about half the time.
                    let probe = PartFitOptions {
                        restart_threshold: f64::INFINITY,
                        refine_passes: 1,
                        sweeps: 0,
                        subpixel: false,
                        interior_vertices: 0,
                        ..options.fit
                    };
                    // Each part's fit checks the cancel flag first, so a cancel is not held
                    // up by a whole probe view.
                    let per_key: Vec<f64> = at
                        .par_iter()
                        .map(|&k| {
                            part_tiles
                                .iter()
                                .map(|tiles| {
                                    let _probe = profile::root("key frame");
                                    if cancel.load(Ordering::Relaxed) {
                                        return 0.0;
                                    }
                                    fit_part(tiles, k, &probe, &[])
                                        .map_or(0.0, |f| f.costs.iter().zip(&weights).map(|(c, w)| c * w).sum())
                                })
                                .sum()
                        })
                        .collect();
                    if cancel.load(Ordering::Relaxed) {
                        return Err(BakeError::Cancelled);
                    }
                    for (t, c) in totals.iter_mut().zip(per_key) {
                        *t += c;
                    }
                }
                (0..candidates.len())
                    .min_by(|&a, &b| totals[a].total_cmp(&totals[b]))
                    .map_or(0, |i| candidates[i])
            }
        })
    }
}

/// Runs the whole bake.
pub fn bake(
    ctx: &GpuContext,
    character: &Character,
    segmentation: &Segmentation,
    cap_overrides: &CapOverrides,
    options: &BakeOptions,
    progress: &(dyn Fn(Progress) + Sync),
    cancel: &AtomicBool,
) -> Result<Bake, BakeError> {
    bake_sharing(
        ctx,
        character,
        segmentation,
        cap_overrides,
        options,
        progress,
        cancel,
        &mut |_: &ViewRenders| {},
    )
}

/// One view's part renders as the bake made them, handed to whoever shares them (the other
/// representations composite their whole-character images from them instead of rendering
/// the view again).
pub struct ViewRenders<'a> {
    pub view: usize,
    pub camera: Camera,
    /// The bake's key frame.
    pub key_frame: usize,
    pub images: &'a PartImages,
}

/// [`bake`], handing every view's part renders to `on_view` (on the rendering thread, in
/// view order) before they are fitted.
#[allow(clippy::too_many_arguments)]
pub fn bake_sharing(
    ctx: &GpuContext,
    character: &Character,
    segmentation: &Segmentation,
    cap_overrides: &CapOverrides,
    options: &BakeOptions,
    progress: &(dyn Fn(Progress) + Sync),
    cancel: &AtomicBool,
    on_view: &mut dyn FnMut(&ViewRenders),
) -> Result<Bake, BakeError> {
    let mut stage_secs = BTreeMap::new();
    let t0 = Instant::now();
    let prepared = profile::in_root("prepare", || {
        Prepared::new(ctx, character, segmentation, cap_overrides, options)
    })?;
    stage_secs.insert("prepare".into(), t0.elapsed().as_secs_f64());

    // Key frame.
    let t2 = Instant::now();
    let key = prepared.key_frame(ctx, options, progress, cancel)?;
    stage_secs.insert("key_frame".into(), t2.elapsed().as_secs_f64());

    // Render views on this thread; fit them on the rayon pool, a few views in flight.
    let t3 = Instant::now();
    let dirs = &prepared.directions;
    let (tx, rx) = std::sync::mpsc::channel::<(usize, ViewResult)>();
    let mut results: Vec<Option<ViewResult>> = vec![None; dirs.len()];
    let mut received = 0usize;
    let mut render_secs = 0.0;
    let in_flight_limit = super::plan::views_in_flight(
        segmentation.parts.len(),
        prepared.times.len(),
        options.resolution,
        rayon::current_num_threads(),
    );
    let mut store = |pair: (usize, ViewResult), received: &mut usize| {
        results[pair.0] = Some(pair.1);
        *received += 1;
        progress(Progress {
            stage: "views",
            done: *received,
            total: dirs.len(),
        });
    };
    for (v, cam) in prepared.cameras.iter().enumerate() {
        if cancel.load(Ordering::Relaxed) {
            return Err(BakeError::Cancelled);
        }
        while v - received >= in_flight_limit {
            match rx.recv() {
                Ok(pair) => store(pair, &mut received),
                Err(_) => return Err(BakeError::Cancelled),
            }
        }
        let tr = Instant::now();
        let images = prepared.render_images(ctx, v)?;
        render_secs += tr.elapsed().as_secs_f64();
        on_view(&ViewRenders {
            view: v,
            camera: *cam,
            key_frame: key,
            images: &images,
        });
        let tx = tx.clone();
        let (dir, cam, fit_options, key_options, keep) =
            (dirs[v], *cam, options.fit, options.keys, options.keep_frame_images);
        let ov = options.overrides.view(prepared.basis, v).cloned();
        let clips = prepared.timeline.spans.clone();
        rayon::spawn(move || {
            let r = fit_view(
                dir,
                cam,
                extract(images, &clips),
                key,
                &fit_options,
                &key_options,
                keep,
                ov.as_ref(),
            );
            let _ = tx.send((v, r));
        });
    }
    drop(tx);
    while received < dirs.len() {
        if cancel.load(Ordering::Relaxed) {
            return Err(BakeError::Cancelled);
        }
        match rx.recv() {
            Ok(pair) => store(pair, &mut received),
            Err(_) => return Err(BakeError::Cancelled),
        }
    }
    stage_secs.insert("render".into(), render_secs);
    stage_secs.insert("fit".into(), t3.elapsed().as_secs_f64() - render_secs);
    let mut views: Vec<ViewResult> = results.into_iter().map(|r| r.expect("every view fitted")).collect();
    // Nothing traced anywhere: an empty pack would report a perfect fit.
    if !views.is_empty() && views.iter().all(|v| v.parts.iter().all(|p| p.fit.is_none())) {
        return Err(BakeError::Limit(crate::limits::LimitError(format!(
            "no part of the character covers a pixel of its {r}² images in any view (transparent, or a speck in its framing: a clip that carries it far away?); nothing to bake",
            r = options.resolution
        ))));
    }
    let t4 = Instant::now();
    share_key_budget(ctx, &prepared, options, &mut views, cancel)?;
    stage_secs.insert("shared key budget".into(), t4.elapsed().as_secs_f64());
    Ok(Bake {
        options: options.clone(),
        frame_times: prepared.times,
        timeline: prepared.timeline,
        key_frame: key,
        segmentation: segmentation.clone(),
        caps: cap_overrides.clone(),
        views,
        stage_secs,
        adapter: ctx.adapter_description(),
        character_path: None,
        character_up: character.up_axis,
    })
}

/// The pack-wide key budget: each view may add key images up to [`KeyOptions::budget`] of its
/// first ones; what the views left unspent goes to the worst views (lowest mean PSNR first),
/// each getting up to as much again, and their keys are chosen again with it (their first
/// keys kept). At most [`KeyOptions::share`] of the views; views whose keys the artist set
/// keep them. The pack never spends more than the per-view budgets would have allowed in all.
/// A view's new budget is kept in [`ViewResult::key_budget`] so every later re-fit of it
/// (re-bake, inspector) chooses the same keys.
pub fn share_key_budget(
    ctx: &GpuContext,
    prepared: &Prepared,
    options: &BakeOptions,
    views: &mut [ViewResult],
    cancel: &AtomicBool,
) -> Result<(), BakeError> {
    let k = options.keys;
    if k.max_keys < 2 || !(k.budget > 0.0 || k.ratio > 0.0) || !(k.share > 0.0) || views.len() < 2 {
        return Ok(());
    }
    let bytes: Vec<(f64, f64)> = views.iter().map(view_key_bytes).collect();
    // Each view's own budget (a fraction of its first keys' bytes), as it chose its keys.
    let own: Vec<f64> = views
        .iter()
        .zip(&bytes)
        .map(|(view, &(first, _))| {
            let parts = view.parts.iter().filter(|p| p.fit.is_some()).count();
            k.view_budget(ViewBytes::new(
                first,
                parts,
                prepared.times.len(),
                prepared.timeline.spans.len(),
                options.resolution,
                options.fit.final_vertices + options.fit.interior_vertices,
            ))
        })
        .collect();
    let mut pool: f64 = bytes
        .iter()
        .zip(&own)
        .map(|((first, extra), budget)| (budget * first - extra).max(0.0))
        .sum();
    let manual = |v: usize| {
        options
            .overrides
            .view(prepared.basis, v)
            .is_some_and(|o| o.keys.is_some())
    };
    let mean = |v: &ViewResult| v.error.psnr.iter().sum::<f64>() / v.error.psnr.len().max(1) as f64;
    let mut worst: Vec<usize> = (0..views.len()).filter(|&v| !manual(v) && bytes[v].0 > 0.0).collect();
    worst.sort_by(|&a, &b| mean(&views[a]).total_cmp(&mean(&views[b])).then(a.cmp(&b)));
    let most = (views.len() as f64 * k.share.min(1.0)).ceil() as usize;
    let mut grants = Vec::new();
    for &v in worst.iter().take(most) {
        let grant = pool.min(own[v] * bytes[v].0);
        if grant < 0.05 * own[v] * bytes[v].0 {
            break;
        }
        pool -= grant;
        grants.push((v, own[v] + grant / bytes[v].0));
    }
    // Renders on this thread (one GPU context), choices on the pool.
    let mut work = Vec::with_capacity(grants.len());
    for &(v, budget) in &grants {
        if cancel.load(Ordering::Relaxed) {
            return Err(BakeError::Cancelled);
        }
        let images = prepared.render_images(ctx, v)?;
        work.push((v, budget, extract(images, &prepared.timeline.spans)));
    }
    let redone: Vec<(usize, ViewResult)> = work
        .into_par_iter()
        .map(|(v, budget, data)| {
            let mut view = views[v].clone();
            let ov = options.overrides.view(prepared.basis, v);
            let key_options = KeyOptions { budget, ..k };
            rechoose_view_keys(&data, &mut view, &options.fit, &key_options, ov);
            view.key_budget = Some(budget);
            (v, view)
        })
        .collect();
    for (v, view) in redone {
        log::debug!(
            "shared key budget, view {v}: {:.2} -> {:.2} dB, added keys {:.0} -> {:.0} B (first keys {:.0} B)",
            mean(&views[v]),
            mean(&view),
            bytes[v].1,
            view_key_bytes(&view).1,
            bytes[v].0
        );
        views[v] = view;
    }
    Ok(())
}

/// What [`rebake`] re-did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Reuse {
    /// Everything was baked again (the inputs changed beyond the corrections).
    pub full: bool,
    pub views_refit: usize,
    pub parts_refit: usize,
    pub views: usize,
}

/// Whether `a` and `b` differ only in their corrections.
fn same_but_overrides(a: &BakeOptions, b: &BakeOptions) -> bool {
    BakeOptions {
        overrides: BakeOverrides::default(),
        ..a.clone()
    } == BakeOptions {
        overrides: BakeOverrides::default(),
        ..b.clone()
    }
}

/// Bakes again after an edit, re-doing only what the edit touched: when the character's
/// segmentation, caps and settings are those of `prev` and only the corrections changed,
/// only the views whose corrections changed are rendered again, and in them only the parts
/// whose pins changed are re-fitted (every part when the view's key frame changed; a new
/// order only re-composites). Anything else is a full bake.
#[allow(clippy::too_many_arguments)]
pub fn rebake(
    ctx: &GpuContext,
    prev: &Bake,
    character: &Character,
    segmentation: &Segmentation,
    cap_overrides: &CapOverrides,
    options: &BakeOptions,
    progress: &(dyn Fn(Progress) + Sync),
    cancel: &AtomicBool,
) -> Result<(Bake, Reuse), BakeError> {
    rebake_sharing(
        ctx,
        prev,
        character,
        segmentation,
        cap_overrides,
        options,
        progress,
        cancel,
        &mut |_: &ViewRenders| {},
    )
}

/// [`rebake`], handing every view's part renders to `on_view` when it bakes everything again
/// (as [`bake_sharing`]; an incremental re-bake renders only some views and hands none).
#[allow(clippy::too_many_arguments)]
pub fn rebake_sharing(
    ctx: &GpuContext,
    prev: &Bake,
    character: &Character,
    segmentation: &Segmentation,
    cap_overrides: &CapOverrides,
    options: &BakeOptions,
    progress: &(dyn Fn(Progress) + Sync),
    cancel: &AtomicBool,
    on_view: &mut dyn FnMut(&ViewRenders),
) -> Result<(Bake, Reuse), BakeError> {
    // A character read with another axis up is seen from other sides in every view.
    let compatible = prev.segmentation == *segmentation
        && prev.character_up == character.up_axis
        && prev.caps == *cap_overrides
        && same_but_overrides(&prev.options, options)
        && segmentation.labels.len() == character.triangle_count();
    if !compatible {
        let b = bake_sharing(
            ctx,
            character,
            segmentation,
            cap_overrides,
            options,
            progress,
            cancel,
            on_view,
        )?;
        let n = b.views.len();
        let parts = b.views.iter().map(|v| v.parts.len()).sum();
        return Ok((
            b,
            Reuse {
                full: true,
                views_refit: n,
                parts_refit: parts,
                views: n,
            },
        ));
    }
    let t0 = Instant::now();
    let basis = OverrideBasis {
        views: prev.views.len(),
        full_sphere: options.coverage == Coverage::FullSphere,
        frames: prev.frame_times.len(),
    };
    let changed: Vec<usize> = (0..prev.views.len())
        .filter(|&v| prev.options.overrides.view(basis, v) != options.overrides.view(basis, v))
        .collect();
    let mut views = prev.views.clone();
    let mut reuse = Reuse {
        full: false,
        views_refit: changed.len(),
        parts_refit: 0,
        views: prev.views.len(),
    };
    if !changed.is_empty() {
        let prepared = profile::in_root("prepare", || {
            Prepared::new(ctx, character, segmentation, cap_overrides, options)
        })?;
        for (n, &v) in changed.iter().enumerate() {
            if cancel.load(Ordering::Relaxed) {
                return Err(BakeError::Cancelled);
            }
            progress(Progress {
                stage: "views",
                done: n,
                total: changed.len(),
            });
            let old = prev.options.overrides.view(basis, v).cloned().unwrap_or_default();
            let new = options.overrides.view(basis, v).cloned().unwrap_or_default();
            let data = prepared.render(ctx, v)?;
            let fit = {
                let view = &prev.views[v];
                let prev_fit = PreviousFit {
                    key: view.key_frame,
                    parts: &view.parts,
                    ov: &old,
                };
                refit_view(
                    &data,
                    prev.key_frame,
                    &options.fit,
                    &options.keys,
                    Some(&new),
                    Some(prev_fit),
                )
            };
            reuse.parts_refit += fit.refit.len();
            let view = &mut views[v];
            view.parts = fit.parts;
            view.key_frame = fit.key;
            view.order = fit.order;
            view.error = fit.error;
            view.hidden = data.hidden;
            view.key_budget = None;
        }
        // The shared key budget decided again over every view, as the full bake would:
        // views it gave more go back to their own budget first.
        for v in 0..views.len() {
            if views[v].key_budget.is_some() {
                if cancel.load(Ordering::Relaxed) {
                    return Err(BakeError::Cancelled);
                }
                let data = prepared.render(ctx, v)?;
                let ov = options.overrides.view(basis, v);
                rechoose_view_keys(&data, &mut views[v], &options.fit, &options.keys, ov);
                views[v].key_budget = None;
            }
        }
        share_key_budget(ctx, &prepared, options, &mut views, cancel)?;
    }
    let mut stage_secs = BTreeMap::new();
    stage_secs.insert("rebake".into(), t0.elapsed().as_secs_f64());
    Ok((
        Bake {
            options: options.clone(),
            frame_times: prev.frame_times.clone(),
            timeline: prev.timeline.clone(),
            key_frame: prev.key_frame,
            segmentation: segmentation.clone(),
            caps: cap_overrides.clone(),
            views,
            stage_secs,
            adapter: ctx.adapter_description(),
            character_path: prev.character_path.clone(),
            character_up: prev.character_up,
        },
        reuse,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_key_frame_ranking_fits_every_frame_of_a_clip_and_a_bounded_subset_of_many() {
        // Up to the limit: every frame, as before.
        for n in [1, 10, 34, KEY_FRAME_PROBE_FRAMES] {
            assert_eq!(key_frame_probe_frames(n, &[0, n / 2]), (0..n).collect::<Vec<_>>());
        }
        // Beyond it: increasing, bounded, evenly spread, every candidate in it.
        for n in [KEY_FRAME_PROBE_FRAMES + 1, 57, 203, 4000] {
            let step = n.div_ceil(KEY_FRAME_CANDIDATES);
            let candidates: Vec<usize> = (0..n).step_by(step).collect();
            let p = key_frame_probe_frames(n, &candidates);
            assert!(p.windows(2).all(|w| w[0] < w[1]), "{n}: {p:?}");
            assert!(
                p.len() <= KEY_FRAME_PROBE_FRAMES + candidates.len(),
                "{n}: {} frames",
                p.len()
            );
            assert!(p.len() >= KEY_FRAME_PROBE_FRAMES / 2, "{n}: {} frames", p.len());
            assert!(candidates.iter().all(|c| p.contains(c)), "{n}");
            assert!(p.iter().all(|&f| f < n));
            // No gap longer than the spacing.
            let k = n.div_ceil(KEY_FRAME_PROBE_FRAMES);
            assert!(p.windows(2).all(|w| w[1] - w[0] <= k), "{n}");
        }
    }

    /// Tiles of a part whose image is a `w[f]` × 10 block of covered pixels at frame `f`.
    fn widths(w: &[u32]) -> Vec<PartTile> {
        w.iter()
            .map(|&w| {
                let size = 32u32;
                let px = (0..size * size)
                    .map(|i| {
                        let (x, y) = (i % size, i / size);
                        if x < w && y < 10 {
                            [0.5, 0.5, 0.5, 0.5, 0.5, 1.0, 1.0]
                        } else {
                            [0.0; 7]
                        }
                    })
                    .collect();
                PartTile { size, px }
            })
            .collect()
    }

    #[test]
    fn a_part_foreshortened_at_the_view_key_gets_its_own_first_key() {
        // Seen in full at the key frame (or nearly): the view's key.
        assert_eq!(part_key(&widths(&[20, 24, 30, 12]), 2, false), 2);
        assert_eq!(
            part_key(&widths(&[20, 24, 30, 12]), 0, false),
            0,
            "20 of 30 is above half"
        );
        // Foreshortened there (under half its largest image): the frame where it is largest,
        // the first of equals.
        assert_eq!(part_key(&widths(&[20, 24, 30, 12]), 3, false), 2);
        assert_eq!(part_key(&widths(&[4, 30, 30, 12]), 0, false), 1);
        // The artist's key frame holds for every part; degenerate input keeps the key.
        assert_eq!(part_key(&widths(&[20, 24, 30, 12]), 3, true), 3);
        assert_eq!(part_key(&widths(&[0, 0, 0]), 1, false), 1);
        assert_eq!(part_key(&widths(&[5]), 0, false), 0);
        // The choice reads coverage only: the same whichever frame the loop starts at
        // (rotating the frames rotates the answer).
        let w = [9u32, 3, 28, 30, 7];
        for shift in 0..w.len() {
            let rotated: Vec<u32> = (0..w.len()).map(|f| w[(f + shift) % w.len()]).collect();
            let key = (1 + w.len() - shift) % w.len();
            let want = (3 + w.len() - shift) % w.len();
            assert_eq!(part_key(&widths(&rotated), key, false), want, "shift {shift}");
        }
    }
}
