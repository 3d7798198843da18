//! The fit inspector of the Views tab: one view re-rendered and re-fitted in the background
//! the way the bake did it, then per part and frame the target render with its traced
//! contour and the fitted polygon over it, the key-frame texture with the source polygon,
//! the per-pixel error, and the polypostor played against the ground truth (in-between
//! frames interpolated). Dragging a fitted vertex onto a contour vertex pins the
//! correspondence; the part is re-solved under its pins at once. The view's key frame and
//! drawing order are edited here too. Every edit is a project change (undoable, saved, used
//! by every later bake); the inspector re-fits whatever the project's corrections now say.

use std::collections::HashMap;
use std::sync::Arc;
use std::sync::mpsc::{Receiver, channel};
use std::time::Instant;

use polypostor::bake::inspect::{composite_at, error_map, positions_at, tile_image};
use polypostor::bake::keys::{KeyOptions, MAX_KEYS};
use polypostor::bake::overrides::{OverrideBasis, Pin, ViewOverride};
use polypostor::bake::part_fit::PartFitOptions;
use polypostor::bake::pipeline::{
    CompositeError, PartResult, Prepared, PreviousFit, ViewData, ground_truth, refit_view,
};
use polypostor::bake::raster::psnr;
use polypostor::bake::report::{Report, view_keys_of_parts};
use polypostor::project::StoredSegmentation;

use super::document::Document;

/// One view, rendered and fitted.
pub struct Session {
    pub view: usize,
    pub basis: OverrideBasis,
    /// The bake's key frame (this view's unless overridden).
    pub bake_key: usize,
    pub key: usize,
    pub options: PartFitOptions,
    pub keys: KeyOptions,
    pub data: Arc<ViewData>,
    pub parts: Vec<PartResult>,
    pub order: Vec<usize>,
    /// The composite's error per frame, as the bake measures it.
    pub error: CompositeError,
    pub names: Vec<String>,
    /// The corrections it was fitted with.
    pub ov: ViewOverride,
    /// The segmentation and caps it was made for (stale when the project's differ).
    made_for: (Option<StoredSegmentation>, polypostor::bake::caps::CapOverrides),
    /// Increases with every change (textures rebuild).
    version: u64,
}

impl Session {
    pub fn frames(&self) -> usize {
        self.data.tiles.first().map_or(0, Vec::len)
    }
}

/// A finished re-fit.
struct Refit {
    view: usize,
    fit: polypostor::bake::pipeline::ViewFit,
    ov: ViewOverride,
    ms: f32,
}

#[derive(Default)]
pub struct Inspector {
    pub session: Option<Session>,
    opening: Option<(usize, Receiver<Result<Session, String>>, Instant)>,
    refit: Option<Receiver<Refit>>,
    pub part: usize,
    /// Time in frames (fractional: in-between frames are interpolated).
    pub time: f32,
    pub playing: bool,
    /// How long the last re-solve took (one part after a pin: the 250 ms target).
    pub last_refit_ms: Option<f32>,
    pub error: Option<String>,
    /// The view whose opening failed (not tried again until it is chosen anew).
    failed: Option<usize>,
    drag: Option<usize>,
    drag_to: Option<egui::Pos2>,
    /// Why the last drag made no pin (dropped away from the outline), shown until the next.
    pin_note: Option<String>,
    textures: Textures,
    /// The shown error map's RMSE (computed with its texture, when that is rebuilt).
    rmse: f64,
}

/// Runs `job` here (`sync`, for tests) or on a thread; its result arrives on the receiver.
///
/// Its parallel work runs in a pool of its own at normal priority: the global pool's threads
/// are lowered for bakes (`lower_thread_priority`), and a pin the user is waiting on must not
/// wait behind the window's drawing or a bake.
pub(super) fn run<T: Send + 'static>(sync: bool, job: impl FnOnce() -> T + Send + 'static) -> Receiver<T> {
    static POOL: std::sync::OnceLock<Option<rayon::ThreadPool>> = std::sync::OnceLock::new();
    let (tx, rx) = channel();
    if sync {
        let _ = tx.send(job());
    } else {
        std::thread::spawn(move || {
            let pool = POOL.get_or_init(|| {
                rayon::ThreadPoolBuilder::new()
                    .thread_name(|i| format!("inspector {i}"))
                    .build()
                    .ok()
            });
            let result = match pool {
                Some(pool) => pool.install(job),
                None => job(),
            };
            let _ = tx.send(result);
        });
    }
    rx
}

type Textures = HashMap<&'static str, (u64, egui::TextureHandle)>;

/// A version no session has had: every session and every re-fit takes a new one, so a
/// cached texture (keyed by name and version) can never show another view's or another
/// character's images.
fn fresh_version() -> u64 {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
    NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
}

/// A texture for `name`, rebuilt only when `version` changes.
fn texture(
    textures: &mut Textures,
    ui: &egui::Ui,
    name: &'static str,
    version: u64,
    make: impl FnOnce() -> image::RgbaImage,
) -> egui::TextureId {
    if let Some((v, t)) = textures.get(name)
        && *v == version
    {
        return t.id();
    }
    let handle = ui
        .ctx()
        .load_texture(name, to_color_image(&make()), egui::TextureOptions::NEAREST);
    let id = handle.id();
    textures.insert(name, (version, handle));
    id
}

/// The tiles' background: composited into their images rather than painted under them, so
/// each pixel is shaded once (on a software rasteriser every overdrawn pixel counts).
const TILE_BACKGROUND: [u8; 3] = [20, 20, 20];

/// `img` over [`TILE_BACKGROUND`], opaque.
fn on_tile_background(mut img: image::RgbaImage) -> image::RgbaImage {
    for p in img.pixels_mut() {
        let a = p[3] as u32;
        for c in 0..3 {
            p[c] = ((p[c] as u32 * a + TILE_BACKGROUND[c] as u32 * (255 - a) + 127) / 255) as u8;
        }
        p[3] = 255;
    }
    img
}

/// Frame `f` of the bake `report` describes as the artist reads it: its number, and in a pack
/// of several clips the clip it is in and its number there ("14 (Run 4)").
pub(super) fn frame_label(report: &Report, f: usize) -> String {
    if report.clips.len() < 2 {
        return f.to_string();
    }
    match report
        .clips
        .iter()
        .find(|c| (c.first_frame..c.first_frame + c.frames).contains(&f))
    {
        Some(c) => format!("{f} ({} {})", c.name, f - c.first_frame),
        None => f.to_string(),
    }
}

pub(super) fn to_color_image(img: &image::RgbaImage) -> egui::ColorImage {
    egui::ColorImage::from_rgba_unmultiplied([img.width() as usize, img.height() as usize], img.as_raw())
}

impl Inspector {
    /// The version of the cached texture `name` ("key", "composite", …), if it was drawn.
    #[cfg_attr(not(test), allow(dead_code))]
    pub fn texture_version(&self, name: &str) -> Option<u64> {
        self.textures.get(name).map(|(v, _)| *v)
    }

    /// Whether a session or an opening is for `view`.
    pub fn is_for(&self, view: usize) -> bool {
        self.session.as_ref().is_some_and(|s| s.view == view)
            || self.opening.as_ref().is_some_and(|o| o.0 == view)
            || self.failed == Some(view)
    }

    /// Lets a view whose opening failed be tried again (the artist chose it anew).
    pub fn forget_failure(&mut self) {
        self.failed = None;
    }

    pub fn busy(&self) -> bool {
        self.opening.is_some() || self.refit.is_some()
    }

    /// Renders and fits `view` of the bake `report` describes, in the background.
    pub fn open(&mut self, view: usize, doc: &Document, report: &Report, sync: bool) {
        self.pin_note = None;
        let character = doc.character.clone();
        let segmentation = doc.segmentation.clone();
        let caps = doc.project.caps.clone();
        let mut options = report.bake_options(&character);
        options.overrides = doc.project.overrides.clone();
        // A view the bake's shared key budget gave more keeps it (the keys the bake chose).
        if let Some(b) = report.views.get(view).and_then(|v| v.key_budget) {
            options.keys.budget = b;
        }
        let made_for = (doc.project.segmentation.clone(), doc.project.caps.clone());
        let names: Vec<String> = segmentation.parts.iter().map(|p| p.name.clone()).collect();
        let bake_key = report.key_frame;
        let job = move || -> Result<Session, String> {
            let ctx = polypostor::gpu::GpuContext::from_env().map_err(|e| e.to_string())?;
            let prepared =
                Prepared::new(&ctx, &character, &segmentation, &caps, &options).map_err(|e| e.to_string())?;
            if view >= prepared.directions.len() {
                return Err(format!("view {view} is not in this bake"));
            }
            let data = Arc::new(prepared.render(&ctx, view).map_err(|e| e.to_string())?);
            let ov = options
                .overrides
                .view(prepared.basis, view)
                .cloned()
                .unwrap_or_default();
            let fit = refit_view(&data, bake_key, &options.fit, &options.keys, Some(&ov), None);
            Ok(Session {
                view,
                basis: prepared.basis,
                bake_key,
                key: fit.key,
                options: options.fit,
                keys: options.keys,
                data,
                parts: fit.parts,
                order: fit.order,
                error: fit.error,
                names,
                ov,
                made_for,
                version: fresh_version(),
            })
        };
        self.session = None;
        self.refit = None;
        self.error = None;
        self.failed = None;
        self.drag = None;
        self.opening = Some((view, run(sync, job), Instant::now()));
    }

    /// Collects finished work and starts a re-fit when the project's corrections for the
    /// view no longer match what the session was fitted with.
    pub fn poll(&mut self, doc: &Document, sync: bool) {
        if let Some((view, rx, _)) = &self.opening
            && let Ok(result) = rx.try_recv()
        {
            let view = *view;
            self.opening = None;
            match result {
                Ok(s) => {
                    self.part = self.part.min(s.parts.len().saturating_sub(1));
                    self.time = self.time.min(s.frames().saturating_sub(1) as f32);
                    self.session = Some(s);
                }
                // Shown, and not tried again until the view is chosen anew (it was retried
                // every frame, forever).
                Err(e) => {
                    self.error = Some(e);
                    self.failed = Some(view);
                }
            }
        }
        if let Some(rx) = &self.refit
            && let Ok(r) = rx.try_recv()
        {
            self.refit = None;
            if let Some(s) = self.session.as_mut().filter(|s| s.view == r.view) {
                s.parts = r.fit.parts;
                s.key = r.fit.key;
                s.order = r.fit.order;
                s.error = r.fit.error;
                s.ov = r.ov;
                s.version = fresh_version();
                self.last_refit_ms = Some(r.ms);
            }
        }
        let Some(s) = &self.session else { return };
        if self.refit.is_some() {
            return;
        }
        let want = doc.project.overrides.view(s.basis, s.view).cloned().unwrap_or_default();
        if want == s.ov {
            return;
        }
        // The library decides what to re-fit (the key frame: every part; pins: their parts;
        // the order only re-composites), exactly as a re-bake does.
        let (data, options, keys, view, bake_key) = (s.data.clone(), s.options, s.keys, s.view, s.bake_key);
        let (parts_now, key_now, ov_now) = (s.parts.clone(), s.key, s.ov.clone());
        let job = move || {
            let t = Instant::now();
            let prev = PreviousFit {
                key: key_now,
                parts: &parts_now,
                ov: &ov_now,
            };
            let fit = refit_view(&data, bake_key, &options, &keys, Some(&want), Some(prev));
            Refit {
                view,
                fit,
                ov: want,
                ms: t.elapsed().as_secs_f32() * 1000.0,
            }
        };
        self.refit = Some(run(sync, job));
    }

    /// The inspector's panel for the selected view.
    pub fn ui(&mut self, ui: &mut egui::Ui, doc: &mut Document, report: &Report, dt: f32) {
        if let Some((view, _, since)) = &self.opening {
            ui.horizontal(|ui| {
                ui.spinner();
                ui.label(format!(
                    "Rendering and fitting view {view} … {:.1} s",
                    since.elapsed().as_secs_f32()
                ));
            });
            ui.ctx().request_repaint();
            return;
        }
        if let Some(e) = &self.error {
            ui.label(egui::RichText::new(e).color(ui.visuals().error_fg_color));
        }
        let Some(s) = &self.session else { return };
        let stale = s.made_for.0 != doc.project.segmentation || s.made_for.1 != doc.project.caps;
        if stale {
            ui.label(
                egui::RichText::new(
                    "The segmentation or caps changed since this view was fitted; pick the view again.",
                )
                .color(ui.visuals().warn_fg_color),
            );
        }
        let frames = s.frames();
        let (view, parts_n, version) = (s.view, s.parts.len(), s.version);
        ui.separator();
        ui.label(egui::RichText::new(format!("Fit inspector: view {view}")).strong());
        // Part and time.
        ui.horizontal(|ui| {
            egui::ComboBox::from_id_salt("inspect part")
                .selected_text(s.names.get(self.part).cloned().unwrap_or_default())
                .show_ui(ui, |ui| {
                    for (p, name) in s.names.iter().enumerate() {
                        ui.selectable_value(&mut self.part, p, name);
                    }
                });
            ui.checkbox(&mut self.playing, "▶ play");
        });
        if self.playing && frames > 0 {
            // The bake's frame rate: report settings.
            self.time = (self.time + dt * report.settings.fps).rem_euclid(frames as f32);
            ui.ctx().request_repaint();
        }
        ui.horizontal(|ui| {
            ui.add(egui::Slider::new(&mut self.time, 0.0..=(frames.saturating_sub(1)) as f32).text("frame"));
            let f = (self.time.round() as usize).min(frames.saturating_sub(1));
            let s = self.session.as_ref().unwrap();
            if ui
                .add_enabled(f != s.key, egui::Button::new("Key frame here"))
                .on_hover_text("Use this frame's texture for this view (the fit is re-solved)")
                .clicked()
            {
                let (basis, view) = (s.basis, s.view);
                doc.edit_overrides("Key frame", |o| {
                    o.view_mut(basis, view).key_frame = Some(f);
                    true
                });
            }
        });
        let part = self.part.min(parts_n.saturating_sub(1));
        let t = self.time;
        let f = (t.round() as usize).min(frames.saturating_sub(1));
        let s = self.session.as_ref().unwrap();
        let result = &s.parts[part];
        // The key that draws this frame: pins correct the first key's polygon only.
        let Some((fit, key)) = result.fit_at(f).map(|(fit, key)| (fit.clone(), key)) else {
            ui.label(format!(
                "{} is not fitted in this view: {}",
                s.names[part],
                result.problem.clone().unwrap_or_default()
            ));
            return;
        };
        let first_key = result.fit.as_ref().is_some_and(|first| first.key_frame == key);
        let data = s.data.clone();
        let tiles = &data.tiles[part];
        let w = ((ui.available_width() - 8.0) / 2.0).clamp(80.0, 220.0);
        let size = tiles[f].size as f32;
        // Zoom on the part: the square around its polygons over every frame.
        let (mut lo, mut hi) = (egui::pos2(size, size), egui::pos2(0.0, 0.0));
        for p in fit.targets.iter().flatten().chain(&fit.key_polygon) {
            lo = lo.min(egui::pos2(p[0], p[1]));
            hi = hi.max(egui::pos2(p[0], p[1]));
        }
        let side = ((hi - lo).max_elem() + 8.0).clamp(8.0, size);
        let centre = lo + (hi - lo) * 0.5;
        let crop_min = egui::pos2(
            (centre.x - side / 2.0).clamp(0.0, size - side),
            (centre.y - side / 2.0).clamp(0.0, size - side),
        );
        let crop_uv = egui::Rect::from_min_size(
            egui::pos2(crop_min.x / size, crop_min.y / size),
            egui::vec2(side / size, side / size),
        );
        let scale = w / side;

        // Row 1: the target with the traced contour and the fitted polygon; the key texture
        // with the source polygon.
        let target_id = texture(
            &mut self.textures,
            ui,
            "target",
            version * 1_000_003 + (part * 1000 + f) as u64,
            || on_tile_background(tile_image(&tiles[f])),
        );
        let key_id = texture(
            &mut self.textures,
            ui,
            "key",
            version * 1_000_003 + (part * 1000 + key) as u64,
            || on_tile_background(tile_image(&tiles[key])),
        );
        let mut pin_made: Option<Pin> = None;
        let pins_here: Vec<Pin> = s.ov.pins.get(&part).cloned().unwrap_or_default();
        ui.horizontal(|ui| {
            ui.vertical(|ui| {
                // The key frame (and frames showing exactly its image) draw the key image
                // itself: the key polygon onto its own vertices, nothing to correct.
                let own_image = fit.draws_key_image(f);
                let pinnable = first_key && !own_image;
                let hint = if own_image {
                    "the key image itself (pin at other frames)"
                } else if first_key {
                    "target + fit (drag a vertex to pin)"
                } else {
                    "target + fit (pins: frames of the first key)"
                };
                ui.label(egui::RichText::new(hint).small());
                let sense = if pinnable {
                    egui::Sense::drag()
                } else {
                    egui::Sense::hover()
                };
                let (rect, response) = ui.allocate_exact_size(egui::vec2(w, w), sense);
                let painter = ui.painter_at(rect);
                painter.image(target_id, rect, crop_uv, egui::Color32::WHITE);
                let to_screen = |p: [f32; 2]| rect.min + (egui::pos2(p[0], p[1]) - crop_min) * scale;
                let contour: Vec<egui::Pos2> = fit.targets[f].iter().map(|&p| to_screen(p)).collect();
                painter.add(egui::Shape::closed_line(
                    contour.clone(),
                    egui::Stroke::new(1.0, egui::Color32::from_rgb(80, 200, 255)),
                ));
                for &c in &contour {
                    painter.circle_filled(c, 1.5, egui::Color32::from_rgb(80, 200, 255));
                }
                let mut fitted: Vec<egui::Pos2> = positions_at(&fit, t).iter().map(|&p| to_screen(p)).collect();
                // The mesh's edges faintly (interior vertices make more than the outline's
                // fan), the interior vertices as rings: only the outline's take pins.
                for tri in &fit.triangles {
                    for e in 0..3 {
                        let (a, b) = (tri[e], tri[(e + 1) % 3]);
                        if a < b && (a >= fit.kept.len() || b >= fit.kept.len()) {
                            painter.line_segment(
                                [fitted[a], fitted[b]],
                                egui::Stroke::new(0.75, egui::Color32::from_rgba_unmultiplied(255, 255, 0, 110)),
                            );
                        }
                    }
                }
                for &v in &fitted[fit.kept.len()..] {
                    painter.circle_stroke(v, 2.5, egui::Stroke::new(1.0, egui::Color32::YELLOW));
                }
                fitted.truncate(fit.kept.len());
                painter.add(egui::Shape::closed_line(
                    fitted.clone(),
                    egui::Stroke::new(1.5, egui::Color32::YELLOW),
                ));
                for (k, &v) in fitted.iter().enumerate() {
                    let pinned = pins_here.iter().any(|p| p.frame == f && p.source == fit.kept[k]);
                    let color = if pinned {
                        egui::Color32::from_rgb(255, 60, 200)
                    } else {
                        egui::Color32::YELLOW
                    };
                    painter.circle_filled(v, if pinned { 4.0 } else { 2.5 }, color);
                }
                // Drag a fitted vertex onto a contour vertex.
                if response.drag_started()
                    && let Some(p) = ui
                        .input(|i| i.pointer.press_origin())
                        .or(response.interact_pointer_pos())
                {
                    self.drag = fitted
                        .iter()
                        .enumerate()
                        .map(|(k, v)| (k, v.distance(p)))
                        .filter(|(_, d)| *d < 10.0)
                        .min_by(|a, b| a.1.total_cmp(&b.1))
                        .map(|(k, _)| k);
                }
                if let Some(p) = response.interact_pointer_pos().or(response.hover_pos()) {
                    self.drag_to = Some(p);
                }
                if let (Some(k), Some(p)) = (self.drag, self.drag_to) {
                    painter.line_segment(
                        [fitted[k], p],
                        egui::Stroke::new(2.0, egui::Color32::from_rgb(255, 60, 200)),
                    );
                    if let Some((_, j)) = contour
                        .iter()
                        .enumerate()
                        .map(|(j, c)| (c.distance(p), j))
                        .filter(|(d, _)| *d < 10.0)
                        .min_by(|a, b| a.0.total_cmp(&b.0))
                    {
                        painter.circle_stroke(contour[j], 5.0, egui::Stroke::new(2.0, egui::Color32::WHITE));
                    }
                }
                if response.drag_stopped() {
                    if let (Some(k), Some(p)) = (self.drag.take(), self.drag_to.take()) {
                        match contour
                            .iter()
                            .enumerate()
                            .map(|(j, c)| (c.distance(p), j))
                            .filter(|(d, _)| *d < 10.0)
                            .min_by(|a, b| a.0.total_cmp(&b.0))
                        {
                            Some((_, j)) => {
                                pin_made = Some(Pin {
                                    frame: f,
                                    source: fit.kept[k],
                                    target: j,
                                });
                                self.pin_note = None;
                            }
                            // Dropped on the background or inside the part: said, not
                            // ignored without a word.
                            None => {
                                self.pin_note = Some(
                                    "no pin: a vertex pins onto the traced outline; drop it within 10 pixels of \
                                     an outline point (a white ring shows where it will land)"
                                        .into(),
                                )
                            }
                        }
                    }
                    self.drag = None;
                }
            });
            ui.vertical(|ui| {
                ui.label(egui::RichText::new(format!("key frame {key} texture + source polygon")).small());
                let (rect, _) = ui.allocate_exact_size(egui::vec2(w, w), egui::Sense::hover());
                let painter = ui.painter_at(rect);
                painter.image(key_id, rect, crop_uv, egui::Color32::WHITE);
                let to_screen = |p: [f32; 2]| rect.min + (egui::pos2(p[0], p[1]) - crop_min) * scale;
                let source: Vec<egui::Pos2> = fit.key_polygon.iter().map(|&p| to_screen(p)).collect();
                painter.add(egui::Shape::closed_line(
                    source,
                    egui::Stroke::new(1.0, egui::Color32::from_rgb(80, 200, 255)),
                ));
                for &k in &fit.kept {
                    painter.circle_filled(to_screen(fit.key_polygon[k]), 2.5, egui::Color32::YELLOW);
                }
                for &q in &fit.interior {
                    painter.circle_stroke(to_screen(q), 2.5, egui::Stroke::new(1.0, egui::Color32::YELLOW));
                }
            });
        });
        // Row 2: the error map; the polypostor and the ground truth at this time.
        // The error map and its RMSE are computed only when the texture is rebuilt.
        let mut fresh_rmse = None;
        let heat_id = texture(
            &mut self.textures,
            ui,
            "error",
            version * 1_000_003 + (part * 1000 + f) as u64,
            || {
                let (heat, rmse) = error_map(&fit, &tiles[key], &tiles[f], f);
                fresh_rmse = Some(rmse);
                on_tile_background(heat)
            },
        );
        if let Some(rmse) = fresh_rmse {
            self.rmse = rmse;
        }
        let rmse = self.rmse;
        let quant = (t * 8.0).round() as u64;
        let s = self.session.as_ref().unwrap();
        let order = s.order.clone();
        let parts = s.parts.clone();
        let res = data.depth_order_tiles.resolution;
        let poly_id = texture(&mut self.textures, ui, "composite", version * 1_000_003 + quant, || {
            on_tile_background(composite_at(&parts, &data.tiles, &order, t, res).to_image())
        });
        let truth_id = texture(&mut self.textures, ui, "truth", version * 1_000_003 + f as u64, || {
            on_tile_background(ground_truth(&data.depth_order_tiles, f).to_image())
        });
        ui.horizontal(|ui| {
            ui.vertical(|ui| {
                ui.label(egui::RichText::new(format!("error at frame {f}: {:.1} dB", psnr(rmse))).small());
                let (rect, _) = ui.allocate_exact_size(egui::vec2(w, w), egui::Sense::hover());
                ui.painter_at(rect).image(heat_id, rect, crop_uv, egui::Color32::WHITE);
            });
            ui.vertical(|ui| {
                ui.label(egui::RichText::new("polypostor | ground truth").small());
                let (rect, _) = ui.allocate_exact_size(egui::vec2(w, w / 2.0), egui::Sense::hover());
                let painter = ui.painter_at(rect);
                let left = egui::Rect::from_min_size(rect.min, egui::vec2(w / 2.0, w / 2.0));
                let right =
                    egui::Rect::from_min_size(rect.min + egui::vec2(w / 2.0, 0.0), egui::vec2(w / 2.0, w / 2.0));
                let full = egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0));
                painter.image(poly_id, left, full, egui::Color32::WHITE);
                painter.image(truth_id, right, full, egui::Color32::WHITE);
                ui.label(
                    egui::RichText::new(format!(
                        "view at frame {f}: {:.1} dB, SSIM {:.3}, silhouette {:.3} (still: {:.1} dB)",
                        s.error.psnr.get(f).copied().unwrap_or(0.0),
                        s.error.ssim.get(f).copied().unwrap_or(0.0),
                        s.error.silhouette_iou.get(f).copied().unwrap_or(0.0),
                        s.error.psnr_static.get(f).copied().unwrap_or(0.0)
                    ))
                    .small(),
                );
            });
        });
        if let Some(note) = &self.pin_note {
            ui.label(egui::RichText::new(note).small().color(ui.visuals().warn_fg_color));
        }
        if let Some(ms) = self.last_refit_ms {
            ui.label(egui::RichText::new(format!("last re-solve: {ms:.0} ms")).small().weak());
        }
        if self.refit.is_some() {
            ui.horizontal(|ui| {
                ui.spinner();
                ui.label("re-solving…");
            });
            ui.ctx().request_repaint();
        }
        let basis = s.basis;
        if let Some(pin) = pin_made {
            doc.edit_overrides("Pin correspondence", |o| {
                let list = o.view_mut(basis, view).pins.entry(part).or_default();
                list.retain(|p| !(p.frame == pin.frame && p.source == pin.source));
                list.push(pin);
                list.sort();
                true
            });
        }
        self.pins_ui(ui, doc, basis, view, part);
        self.key_frame_ui(ui, doc, report, basis, view, frames);
        self.keys_ui(ui, doc, report, basis, view, f);
        self.order_ui(ui, doc, report, basis, view);
    }

    /// The view's key images: each with the parts that have it, the frames it draws, its
    /// bytes and what it buys; add one at the current frame, remove one, or go back to the
    /// bake's choice. Every edit is a correction (undoable, saved, respected by every bake).
    fn keys_ui(
        &mut self,
        ui: &mut egui::Ui,
        doc: &mut Document,
        report: &Report,
        basis: OverrideBasis,
        view: usize,
        f: usize,
    ) {
        let Some(s) = &self.session else { return };
        let list = view_keys_of_parts(&s.parts);
        let manual = doc.project.overrides.view(basis, view).and_then(|o| o.keys.clone());
        // The extra key frames as the artist sees them: the hand-set list when there is one.
        let extras: Vec<usize> = match &manual {
            Some(l) => l.clone(),
            None => list.iter().filter(|k| !k.first).map(|k| k.frame).collect(),
        };
        let cap = s.keys.max_keys.clamp(1, MAX_KEYS);
        let heading = match &manual {
            Some(_) => format!("Key images ({}, set by hand)", list.len()),
            None => format!("Key images ({}, chosen by the bake)", list.len()),
        };
        egui::CollapsingHeader::new(heading)
            .id_salt("key images")
            .default_open(true)
            .show(ui, |ui| {
                let mut set: Option<Option<Vec<usize>>> = None;
                egui::Grid::new("key list").striped(true).show(ui, |ui| {
                    ui.label(egui::RichText::new("frame").small().strong());
                    ui.label(egui::RichText::new("parts").small().strong());
                    ui.label(egui::RichText::new("draws").small().strong());
                    ui.label(egui::RichText::new("buys").small().strong());
                    ui.label(egui::RichText::new("bytes").small().strong());
                    ui.end_row();
                    for k in &list {
                        ui.label(if k.first {
                            format!("{} (first)", frame_label(report, k.frame))
                        } else {
                            frame_label(report, k.frame)
                        });
                        ui.label(k.parts.to_string());
                        ui.label(format!("{} part-frames", k.frames_drawn));
                        ui.label(if k.first {
                            "-".to_string()
                        } else {
                            format!("{:.2} dB", k.buys_db)
                        });
                        ui.label(polypostor::limits::human_bytes(k.bytes));
                        if !k.first
                            && ui
                                .small_button("Remove")
                                .on_hover_text("Draw this view without this key image (undoable)")
                                .clicked()
                        {
                            set = Some(Some(extras.iter().copied().filter(|&x| x != k.frame).collect()));
                        }
                        ui.end_row();
                    }
                    // Frames the artist named that no part draws better from: listed, so
                    // the edit is seen and can be taken back.
                    let unused: Vec<usize> = manual
                        .iter()
                        .flatten()
                        .copied()
                        .filter(|m| !list.iter().any(|k| k.frame == *m))
                        .collect();
                    for m in unused {
                        ui.label(format!("{m} (unused)"));
                        ui.label("0");
                        ui.label("no part draws better from it");
                        ui.label("-");
                        ui.label("-");
                        if ui
                            .small_button("Remove")
                            .on_hover_text("Remove this key frame (undoable)")
                            .clicked()
                        {
                            set = Some(Some(manual.iter().flatten().copied().filter(|&x| x != m).collect()));
                        }
                        ui.end_row();
                    }
                });
                ui.horizontal(|ui| {
                    let is_key = list.iter().any(|k| k.frame == f) || manual.as_ref().is_some_and(|l| l.contains(&f));
                    let room = list.len() < cap.max(2);
                    if ui
                        .add_enabled(!is_key && room, egui::Button::new(format!("Add key at frame {f}")))
                        .on_hover_text(if room {
                            "Every part of this view gets a key image of this frame where it draws a frame better"
                        } else {
                            "This view has as many key images as the bake allows"
                        })
                        .clicked()
                    {
                        let mut l = extras.clone();
                        l.push(f);
                        l.sort_unstable();
                        set = Some(Some(l));
                    }
                    if ui
                        .add_enabled(manual.is_some(), egui::Button::new("Reset to auto"))
                        .on_hover_text("Let the bake choose this view's key images again")
                        .clicked()
                    {
                        set = Some(None);
                    }
                });
                if let Some(keys) = set {
                    let label = match &keys {
                        None => "Key images: auto",
                        Some(l) if l.len() > extras.len() => "Add key image",
                        Some(_) => "Remove key image",
                    };
                    doc.edit_overrides(label, |o| {
                        o.view_mut(basis, view).keys = keys;
                        true
                    });
                }
            });
    }

    fn pins_ui(&mut self, ui: &mut egui::Ui, doc: &mut Document, basis: OverrideBasis, view: usize, part: usize) {
        let pins: Vec<Pin> = doc
            .project
            .overrides
            .view(basis, view)
            .and_then(|o| o.pins.get(&part))
            .cloned()
            .unwrap_or_default();
        egui::CollapsingHeader::new(format!("Pins of this part ({})", pins.len()))
            .default_open(true)
            .show(ui, |ui| {
                if pins.is_empty() {
                    ui.label(egui::RichText::new("none: drag a yellow vertex onto a blue contour vertex").weak());
                }
                let mut remove = None;
                for (i, p) in pins.iter().enumerate() {
                    ui.horizontal(|ui| {
                        ui.label(format!(
                            "frame {}: vertex {} -> contour {}",
                            p.frame, p.source, p.target
                        ));
                        if ui.small_button("Remove").on_hover_text("Remove this pin").clicked() {
                            remove = Some(i);
                        }
                    });
                }
                if let Some(i) = remove {
                    doc.edit_overrides("Remove pin", |o| {
                        o.view_mut(basis, view).pins.entry(part).or_default().remove(i);
                        true
                    });
                }
                if !pins.is_empty() && ui.button("Clear pins of this part").clicked() {
                    doc.edit_overrides("Clear pins", |o| o.view_mut(basis, view).pins.remove(&part).is_some());
                }
            });
    }

    fn key_frame_ui(
        &mut self,
        ui: &mut egui::Ui,
        doc: &mut Document,
        report: &Report,
        basis: OverrideBasis,
        view: usize,
        frames: usize,
    ) {
        let current = doc.project.overrides.view(basis, view).and_then(|o| o.key_frame);
        let bake_key = report.key_frame;
        ui.horizontal(|ui| {
            ui.label("Key frame:");
            let auto = format!("auto (bake's: {})", frame_label(report, bake_key));
            let text = match current {
                Some(k) => format!("frame {}", frame_label(report, k)),
                None => auto.clone(),
            };
            let mut choice = current;
            egui::ComboBox::from_id_salt("key frame")
                .selected_text(text)
                .show_ui(ui, |ui| {
                    ui.selectable_value(&mut choice, None, auto);
                    for k in 0..frames {
                        ui.selectable_value(&mut choice, Some(k), format!("frame {}", frame_label(report, k)));
                    }
                });
            if choice != current {
                doc.edit_overrides("Key frame", |o| {
                    o.view_mut(basis, view).key_frame = choice;
                    true
                });
            }
            if ui
                .button("Use for all views")
                .on_hover_text("Every view takes this key frame (pins of other views are kept)")
                .clicked()
            {
                doc.edit_overrides("Key frame for all views", |o| {
                    for v in 0..basis.views {
                        o.view_mut(basis, v).key_frame = choice;
                    }
                    true
                });
            }
        });
    }

    fn order_ui(&mut self, ui: &mut egui::Ui, doc: &mut Document, report: &Report, basis: OverrideBasis, view: usize) {
        let Some(s) = &self.session else { return };
        let order = s.order.clone();
        let names = s.names.clone();
        let hidden = s.data.hidden.clone();
        let overridden = doc
            .project
            .overrides
            .view(basis, view)
            .and_then(|o| o.order.as_ref())
            .is_some();
        egui::CollapsingHeader::new("Visibility order (back to front)")
            .default_open(true)
            .show(ui, |ui| {
                let mut new_order: Option<Vec<usize>> = None;
                for (i, &p) in order.iter().enumerate() {
                    let row = ui.horizontal(|ui| {
                        if ui.add_enabled(i > 0, egui::Button::new("Up").small()).clicked() {
                            let mut o = order.clone();
                            o.swap(i, i - 1);
                            new_order = Some(o);
                        }
                        if ui
                            .add_enabled(i + 1 < order.len(), egui::Button::new("Down").small())
                            .clicked()
                        {
                            let mut o = order.clone();
                            o.swap(i, i + 1);
                            new_order = Some(o);
                        }
                        // What this part hides and what hides it (pixels per frame).
                        let hides: Vec<String> = (0..hidden.len())
                            .filter(|&q| q != p && hidden[p][q] >= 0.5)
                            .map(|q| format!("{} {:.0}", names[q], hidden[p][q]))
                            .collect();
                        // Drag the name onto another row to move the part there.
                        let name = names.get(p).cloned().unwrap_or_default();
                        let drag_id = ui.scope_id().with(("order row", view, i));
                        ui.dnd_drag_source(drag_id, i, |ui| {
                            ui.label(format!(":: {name}"));
                        })
                        .response
                        .on_hover_text(if hides.is_empty() {
                            "drag to reorder · hides nothing".to_owned()
                        } else {
                            format!("drag to reorder · hides (pixels per frame): {}", hides.join(", "))
                        });
                        // Weight of the occlusions this order gets wrong for this part.
                        let wrong: f64 = order[..i].iter().map(|&q| hidden[q][p]).sum();
                        if wrong >= 0.5 {
                            ui.label(
                                egui::RichText::new(format!("⚠ {wrong:.0} px drawn under parts behind it"))
                                    .small()
                                    .color(ui.visuals().warn_fg_color),
                            );
                        }
                    });
                    // A row dropped here takes this place.
                    let response = row.response;
                    if let Some(from) = response.dnd_hover_payload::<usize>()
                        && *from != i
                    {
                        let y = if *from < i {
                            response.rect.bottom()
                        } else {
                            response.rect.top()
                        };
                        ui.painter().hline(
                            response.rect.x_range(),
                            y,
                            egui::Stroke::new(2.0, ui.visuals().selection.bg_fill),
                        );
                    }
                    if let Some(from) = response.dnd_release_payload::<usize>()
                        && *from != i
                        && *from < order.len()
                    {
                        let mut o = order.clone();
                        let moved = o.remove(*from);
                        o.insert(i, moved);
                        new_order = Some(o);
                    }
                }
                let violated: f64 = (0..order.len())
                    .flat_map(|i| (0..i).map(move |j| (i, j)))
                    .map(|(i, j)| hidden[order[j]][order[i]])
                    .sum::<f64>();
                ui.label(
                    egui::RichText::new(format!("occlusion drawn wrong: {violated:.0} px per frame"))
                        .small()
                        .weak(),
                );
                ui.horizontal(|ui| {
                    if ui
                        .button("Apply to neighbours")
                        .on_hover_text("The four nearest views take this order too")
                        .clicked()
                    {
                        let dir = glam::Vec3::from(report.views[view].direction);
                        let mut near: Vec<usize> = (0..report.views.len()).filter(|&v| v != view).collect();
                        near.sort_by(|&a, &b| {
                            let da = glam::Vec3::from(report.views[a].direction).dot(dir);
                            let db = glam::Vec3::from(report.views[b].direction).dot(dir);
                            db.total_cmp(&da)
                        });
                        let order = order.clone();
                        doc.edit_overrides("Order for neighbouring views", |o| {
                            for &v in near.iter().take(4).chain([view].iter()) {
                                o.view_mut(basis, v).order = Some(order.clone());
                            }
                            true
                        });
                    }
                    if ui.button("Apply to all views").clicked() {
                        let order = order.clone();
                        doc.edit_overrides("Order for all views", |o| {
                            for v in 0..basis.views {
                                o.view_mut(basis, v).order = Some(order.clone());
                            }
                            true
                        });
                    }
                    if ui
                        .add_enabled(overridden, egui::Button::new("Computed order"))
                        .clicked()
                    {
                        doc.edit_overrides("Computed order", |o| o.view_mut(basis, view).order.take().is_some());
                    }
                });
                if let Some(o) = new_order {
                    doc.edit_overrides("Reorder parts", |ov| {
                        ov.view_mut(basis, view).order = Some(o);
                        true
                    });
                }
            });
    }
}

#[cfg(test)]
mod tests {
    use super::{TILE_BACKGROUND, on_tile_background};

    #[test]
    fn tiles_are_composited_over_their_background() {
        let img = image::RgbaImage::from_fn(3, 1, |x, _| match x {
            0 => image::Rgba([200, 100, 50, 255]),
            1 => image::Rgba([200, 100, 50, 0]),
            _ => image::Rgba([220, 120, 70, 128]),
        });
        let out = on_tile_background(img);
        assert_eq!(out.get_pixel(0, 0).0, [200, 100, 50, 255], "opaque stays");
        let [r, g, b] = TILE_BACKGROUND;
        assert_eq!(
            out.get_pixel(1, 0).0,
            [r, g, b, 255],
            "transparent shows the background"
        );
        // Half covered: half way between the colour and the background.
        for ((c, want), bg) in out.get_pixel(2, 0).0[..3]
            .iter()
            .zip([220, 120, 70])
            .zip(TILE_BACKGROUND)
        {
            let mid = (want + bg as u32) as f32 / 2.0;
            assert!((*c as f32 - mid).abs() <= 1.0, "{c} vs {mid}");
        }
        assert_eq!(out.get_pixel(2, 0)[3], 255);
    }
}
