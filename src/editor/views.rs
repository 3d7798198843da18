//! The Views tab: the bake's viewpoints on the hemisphere, coloured by how well the
//! Polypostor fits there, the worst first in a list beside it; picking one turns the viewport
//! camera to look from it. Below, the chosen view's error per frame for the whole character
//! and for every part (egui_plot).

use std::path::{Path, PathBuf};
use std::time::SystemTime;

use polypostor::bake::report::{Report, read_report};

use super::document::Document;
use super::inspect::Inspector;
use super::viewport::OrbitCamera;

#[derive(Default)]
pub struct ViewsPanel {
    pub inspector: Inspector,
    /// The report shown, from which file, and that file's time (reloaded when it changes).
    pub report: Option<(PathBuf, SystemTime, Report)>,
    pub selected: Option<usize>,
    pub error: Option<String>,
    /// Where the report is looked for (the project's bake folder).
    pub source: Option<PathBuf>,
    /// What the error plot shows (set to the silhouette when a nearly black character's
    /// report loads: its PSNR reads about 99 dB at every frame).
    pub plot: PlotMetric,
    /// The quality sheet of one view (the real mesh beside every representation).
    pub sheet: QualitySheet,
    /// The up axis the shown bake read the character with (its manifest's `character_up`).
    pub baked_up: polypostor::UpAxis,
}

/// What the Views tab's per-frame plot shows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PlotMetric {
    #[default]
    Psnr,
    Ssim,
    /// The silhouette agreement (the character only: parts have none of their own).
    Silhouette,
}

/// The quality sheet of the chosen view at a frame and half-way to the next, made in the
/// background from the bake folder (every representation it holds).
#[derive(Default)]
pub struct QualitySheet {
    /// (view, frame) shown, its image, its texture.
    pub shown: Option<(usize, u32, image::RgbaImage, Option<egui::TextureHandle>)>,
    job: Option<(usize, u32, std::sync::mpsc::Receiver<Result<image::RgbaImage, String>>)>,
    pub error: Option<String>,
    pub open: bool,
}

impl QualitySheet {
    pub fn busy(&self) -> bool {
        self.job.is_some()
    }

    /// Starts making the sheet of `view` at baked `frame` from the bake in `dir` of the
    /// character at `character` (the open document's).
    pub fn start(&mut self, dir: &Path, character: Option<PathBuf>, view: usize, frame: u32, sync: bool) {
        let dir = dir.to_owned();
        let job = move || -> Result<image::RgbaImage, String> {
            let assets = polypostor::scene::CrowdAssets::load(&dir, character.as_deref(), None)?;
            let ctx = polypostor::gpu::GpuContext::from_env().map_err(|e| e.to_string())?;
            let mut renders = polypostor::reps::compare::Renders::new(&ctx, &assets).map_err(|e| e.to_string())?;
            let rows = [frame as f32, frame as f32 + 0.5].map(|time| polypostor::reps::quality::SheetRow {
                view,
                time,
                why: "chosen in the editor".into(),
            });
            let title = format!(
                "{}: view {view}, PSNR / SSIM against the real mesh",
                assets.character.name
            );
            let (img, _) =
                polypostor::reps::quality::render_sheet(&mut renders, &title, &rows, assets.resolution().min(256))
                    .map_err(|e| e.to_string())?;
            Ok(img)
        };
        self.error = None;
        self.open = true;
        self.job = Some((view, frame, super::inspect::run(sync, job)));
    }

    /// Collects a finished sheet.
    pub fn poll(&mut self) {
        if let Some((view, frame, rx)) = &self.job
            && let Ok(result) = rx.try_recv()
        {
            let (view, frame) = (*view, *frame);
            self.job = None;
            match result {
                Ok(img) => self.shown = Some((view, frame, img, None)),
                Err(e) => self.error = Some(format!("quality sheet: {e}")),
            }
        }
    }

    /// The sheet's window (when open).
    pub fn window(&mut self, ctx: &egui::Context) {
        if !self.open {
            return;
        }
        let mut open = self.open;
        let title = match &self.shown {
            Some((v, f, _, _)) => format!("Quality sheet: view {v}, frame {f}"),
            None => "Quality sheet".to_string(),
        };
        egui::Window::new(title)
            .id(egui::Id::unique("quality sheet window"))
            .open(&mut open)
            .default_size(egui::vec2(720.0, 640.0))
            .default_pos(egui::pos2(320.0, 60.0))
            .resizable(true)
            .show(ctx, |ui| {
                if self.job.is_some() {
                    ui.horizontal(|ui| {
                        ui.spinner();
                        ui.label("Rendering every representation …");
                    });
                }
                if let Some(e) = &self.error {
                    ui.label(egui::RichText::new(e).color(ui.visuals().error_fg_color));
                }
                if let Some((_, _, img, tex)) = &mut self.shown {
                    let handle = tex.get_or_insert_with(|| {
                        ui.ctx().load_texture(
                            "quality sheet",
                            super::inspect::to_color_image(img),
                            egui::TextureOptions::LINEAR,
                        )
                    });
                    let size = handle.size_vec2();
                    egui::ScrollArea::both().show(ui, |ui| {
                        let w = ui.available_width().min(size.x).max(100.0);
                        ui.add(
                            egui::Image::new((handle.id(), size)).fit_to_exact_size(egui::vec2(w, w * size.y / size.x)),
                        );
                    });
                }
            });
        self.open = open;
    }
}

/// Yaw and pitch of an orbit camera looking from `dir` (from the character towards the
/// camera) at the character.
pub fn yaw_pitch(dir: [f32; 3]) -> (f32, f32) {
    let d = glam::Vec3::from(dir).normalize_or(glam::Vec3::Z);
    (d.x.atan2(d.z), d.y.clamp(-1.0, 1.0).asin())
}

/// Red (worst) through yellow to green (best) for `t` in 0..1.
fn heat(t: f32) -> egui::Color32 {
    let t = t.clamp(0.0, 1.0);
    let (r, g) = if t < 0.5 { (1.0, 2.0 * t) } else { (2.0 - 2.0 * t, 1.0) };
    egui::Color32::from_rgb((r * 230.0) as u8, (g * 200.0) as u8, 60)
}

impl ViewsPanel {
    /// Loads (or reloads, when the file changed) the report of the bake at `source`.
    pub fn refresh(&mut self) {
        let Some(dir) = &self.source else { return };
        let file = dir.join("report.json");
        let Ok(modified) = std::fs::metadata(&file).and_then(|m| m.modified()) else {
            self.report = None;
            self.error = Some(format!("no bake report yet at {} (bake with Ctrl+B)", file.display()));
            return;
        };
        if self
            .report
            .as_ref()
            .is_some_and(|(f, t, _)| *f == file && *t == modified)
        {
            return;
        }
        match read_report(&file) {
            Ok(r) => {
                self.selected = self.selected.filter(|&s| s < r.views.len());
                // The plot opens on the silhouette for a nearly black character, on PSNR
                // otherwise; a re-read of the same kind of report (a re-bake) keeps the
                // artist's choice.
                let was_dark = self.report.as_ref().map(|(_, _, old)| dark_report(old));
                if was_dark != Some(dark_report(&r)) {
                    self.plot = if dark_report(&r) {
                        PlotMetric::Silhouette
                    } else {
                        PlotMetric::Psnr
                    };
                }
                self.report = Some((file, modified, r));
                self.error = None;
                // A pack records the axis only when it is not glTF's.
                self.baked_up = std::fs::read(dir.join("manifest.json"))
                    .ok()
                    .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
                    .and_then(|m| serde_json::from_value(m["character_up"].clone()).ok())
                    .unwrap_or_default();
            }
            Err(e) => {
                self.report = None;
                self.error = Some(e);
            }
        }
    }

    /// Points the panel at a bake folder.
    pub fn set_source(&mut self, dir: Option<&Path>) {
        if self.source.as_deref() != dir {
            self.source = dir.map(Path::to_owned);
            self.report = None;
            self.selected = None;
            // A fit of another bake's view (the inspector knows views by number only) is
            // not this one's.
            self.inspector = Inspector::default();
        }
    }

    /// Drops the fit inspector's view, its fits and images (another document was opened: it
    /// showed the last one's fit of the same view number).
    pub fn forget_inspector(&mut self) {
        self.inspector = Inspector::default();
        self.selected = None;
    }

    /// Selects a view and turns the camera to look from it.
    pub fn select(&mut self, view: usize, camera: &mut OrbitCamera) {
        let Some((_, _, r)) = &self.report else { return };
        let Some(v) = r.views.get(view) else { return };
        self.selected = Some(view);
        self.inspector.forget_failure();
        let (yaw, pitch) = yaw_pitch(v.direction);
        camera.yaw_rad = yaw;
        camera.pitch_rad = pitch.clamp(-1.55, 1.55);
    }

    pub fn controls(
        &mut self,
        ui: &mut egui::Ui,
        camera: &mut OrbitCamera,
        mut doc: Option<&mut Document>,
        sync: bool,
    ) {
        self.refresh();
        if let Some(d) = doc.as_deref() {
            self.inspector.poll(d, sync);
        }
        ui.heading("Viewpoints");
        if let Some(dir) = &self.source {
            ui.label(egui::RichText::new(dir.display().to_string()).small().weak());
        }
        if let Some(e) = &self.error {
            ui.label(egui::RichText::new(e).color(ui.visuals().warn_fg_color));
        }
        if let Some(d) = doc.as_deref()
            && self.report.is_some()
            && d.character.up_axis != self.baked_up
        {
            ui.label(
                egui::RichText::new(format!(
                    "⚠ This bake read the character with {} as up; it is now read with {} as up: bake again (Ctrl+B)",
                    self.baked_up, d.character.up_axis
                ))
                .color(ui.visuals().warn_fg_color),
            );
        }
        let Some((_, _, report)) = &self.report else { return };
        // A nearly black character's views are ranked by their silhouette agreement: PSNR sees
        // little of its shape (every view reads about 99 dB).
        let dark = dark_report(report);
        let score = |v: &polypostor::bake::report::ViewReport| if dark { v.mean_silhouette_iou } else { v.mean_psnr };
        let (lo, hi) = report
            .views
            .iter()
            .fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(score(v)), b.max(score(v))));
        let span = (hi - lo).max(1e-6);
        ui.label(format!(
            "{} views · mean {:.2} dB, SSIM {:.3} · worst {:.2} dB, SSIM {:.3} · key frame {}",
            report.views.len(),
            report.mean_psnr,
            report.mean_ssim,
            report.worst_psnr,
            report.worst_ssim,
            // Named as the inspector names it ("15 (Walking 1)" in a pack of several clips).
            super::inspect::frame_label(report, report.key_frame)
        ));
        // Reports written before the silhouette was measured have none.
        if report.mean_silhouette_iou > 0.0 {
            ui.label(format!("silhouette agreement {:.3}", report.mean_silhouette_iou))
                .on_hover_text("the pixels both the composite and the render cover over those either covers, whatever their colours (1 = the same shape)");
        }
        for note in polypostor::bake::pipeline::dark_note(report.truth_brightness)
            .into_iter()
            .chain(report.empty_views_note())
        {
            ui.label(
                egui::RichText::new(format!("⚠ {note}"))
                    .small()
                    .color(ui.visuals().warn_fg_color),
            );
        }
        let dropped = report.dropped_corrections.lines();
        if !dropped.is_empty() {
            egui::Frame::group(ui.style()).show(ui, |ui| {
                ui.label(
                    egui::RichText::new("⚠ Corrections not applied by this bake")
                        .strong()
                        .color(ui.visuals().warn_fg_color),
                );
                for line in &dropped {
                    ui.label(egui::RichText::new(line).small());
                }
            });
        }

        // The hemisphere seen from above: the centre is straight up, the rim the horizon,
        // the character's front (+Z) at the bottom.
        let size = ui.available_width().min(260.0);
        let (rect, response) = ui.allocate_exact_size(egui::vec2(size, size), egui::Sense::click());
        let painter = ui.painter_at(rect);
        let centre = rect.center();
        let radius = size * 0.5 - 8.0;
        painter.circle_filled(centre, radius, egui::Color32::from_gray(28));
        for k in 1..=3 {
            painter.circle_stroke(
                centre,
                radius * k as f32 / 3.0,
                egui::Stroke::new(1.0, egui::Color32::from_gray(55)),
            );
        }
        painter.text(
            centre + egui::vec2(0.0, radius + 1.0),
            egui::Align2::CENTER_BOTTOM,
            "front",
            egui::FontId::proportional(10.0),
            egui::Color32::from_gray(140),
        );
        let place = |d: [f32; 3]| {
            // Azimuthal equidistant: distance from the centre grows with the angle from up.
            let v = glam::Vec3::from(d).normalize_or(glam::Vec3::Y);
            let from_up = v.y.clamp(-1.0, 1.0).acos() / std::f32::consts::FRAC_PI_2;
            let h = glam::Vec2::new(v.x, v.z).normalize_or_zero();
            centre + egui::vec2(h.x, h.y) * from_up.min(1.05) * radius
        };
        let mut hovered = None;
        let pointer = response.hover_pos();
        for (i, v) in report.views.iter().enumerate() {
            let p = place(v.direction);
            let t = ((score(v) - lo) / span) as f32;
            let r = if self.selected == Some(i) { 6.0 } else { 4.0 };
            painter.circle_filled(p, r, heat(t));
            if self.selected == Some(i) {
                painter.circle_stroke(p, r + 2.0, egui::Stroke::new(2.0, egui::Color32::WHITE));
            }
            if pointer.is_some_and(|q| q.distance(p) < 7.0) {
                hovered = Some(i);
            }
        }
        let mut pick = None;
        if let Some(i) = hovered {
            let v = &report.views[i];
            response.clone().on_hover_text(format!(
                "view {i}: {:.2} dB, SSIM {:.3}, silhouette {:.3}",
                v.mean_psnr, v.mean_ssim, v.mean_silhouette_iou
            ));
            if response.clicked() {
                pick = Some(i);
            }
        }
        // Worst first.
        ui.label(
            egui::RichText::new(if dark {
                "Worst views first (by silhouette)"
            } else {
                "Worst views first"
            })
            .strong(),
        );
        let mut order: Vec<usize> = (0..report.views.len()).collect();
        order.sort_by(|&a, &b| score(&report.views[a]).total_cmp(&score(&report.views[b])));
        // Eight views whole; a longer list shows seven and a half rows and its scroll bar, so
        // that it reads as one to scroll (a fixed height hid an eighth view with no sign).
        let row = ui.spacing().interact_size.y.max(18.0) + ui.spacing().item_spacing.y;
        let rows = order.len();
        ui.scope(|ui| {
            // A solid bar, always drawn (egui's floating bars show only under the pointer).
            ui.spacing_mut().scroll = egui::style::ScrollStyle::solid();
            egui::ScrollArea::vertical()
                .id_salt("views list")
                .max_height(if rows <= 8 { row * rows as f32 + 4.0 } else { row * 7.5 })
                .show(ui, |ui| {
                    for &i in &order {
                        let v = &report.views[i];
                        let t = ((score(v) - lo) / span) as f32;
                        ui.horizontal(|ui| {
                            let (dot, _) = ui.allocate_exact_size(egui::vec2(10.0, 10.0), egui::Sense::hover());
                            ui.painter().circle_filled(dot.center(), 4.0, heat(t));
                            let text = if dark {
                                format!("view {i:>3}   silhouette {:.3}", v.mean_silhouette_iou)
                            } else {
                                format!("view {i:>3}   {:.2} dB   SSIM {:.3}", v.mean_psnr, v.mean_ssim)
                            };
                            if ui.selectable_label(self.selected == Some(i), text).clicked() {
                                pick = Some(i);
                            }
                        });
                    }
                });
        });
        if let Some(i) = pick {
            self.select(i, camera);
        }
        self.error_plot(ui);
        self.sheet.poll();
        if let (Some(sel), Some(dir)) = (self.selected, self.source.clone()) {
            let frame = self.inspector.time.round().max(0.0) as u32;
            let busy = self.sheet.busy();
            let label = format!("Quality sheet of view {sel} at frame {frame}");
            let response = ui
                .add_enabled(!busy, egui::Button::new(label))
                .on_hover_text(
                    "The real mesh beside the Polypostor, impostor and NP3D from this view, at this frame and half-way to the next, each with its PSNR and SSIM",
                );
            if response.clicked() {
                let character = doc.as_deref().map(|d| d.character_path.clone());
                self.sheet.start(&dir, character, sel, frame, sync);
            }
        }
        self.sheet.window(ui.ctx());
        if let (Some(sel), Some(d)) = (self.selected, doc.as_deref_mut()) {
            let report = self.report.as_ref().map(|r| r.2.clone()).unwrap();
            if !self.inspector.is_for(sel) {
                self.inspector.open(sel, d, &report, sync);
                self.inspector.poll(d, sync);
            }
        }
    }

    /// The fit inspector of the chosen view (a panel of its own, beside the viewport).
    pub fn inspector_panel(&mut self, ui: &mut egui::Ui, doc: &mut Document, dt: f32) {
        let (Some(_), Some((_, _, report))) = (self.selected, &self.report) else {
            return;
        };
        let report = report.clone();
        self.inspector.ui(ui, doc, &report, dt);
    }

    /// PSNR, SSIM or the silhouette agreement per frame of the chosen view: the character
    /// (fitted, and for PSNR the still key-frame polygons) and, for PSNR and SSIM, every part.
    fn error_plot(&mut self, ui: &mut egui::Ui) {
        let (Some((_, _, report)), Some(sel)) = (&self.report, self.selected) else {
            ui.label(egui::RichText::new("Pick a view to see its error per frame.").weak());
            return;
        };
        let v = &report.views[sel];
        let metric = self.plot;
        // After corrections the inspector's re-fit is newer than the report.
        let live = self.inspector.session.as_ref().filter(|s| s.view == sel);
        let (overall, still): (Vec<f64>, Vec<f64>) = match (live, metric) {
            (Some(s), PlotMetric::Psnr) => (s.error.psnr.clone(), s.error.psnr_static.clone()),
            (Some(s), PlotMetric::Ssim) => (s.error.ssim.clone(), Vec::new()),
            (Some(s), PlotMetric::Silhouette) => (s.error.silhouette_iou.clone(), Vec::new()),
            (None, PlotMetric::Psnr) => (v.psnr.clone(), v.psnr_static.clone()),
            (None, PlotMetric::Ssim) => (v.ssim.clone(), Vec::new()),
            (None, PlotMetric::Silhouette) => (v.silhouette_iou.clone(), Vec::new()),
        };
        let pick = |psnr: &Vec<f64>, ssim: &Vec<f64>| match metric {
            PlotMetric::Psnr => Some(psnr.clone()),
            PlotMetric::Ssim => Some(ssim.clone()),
            PlotMetric::Silhouette => None,
        };
        let per_part: Vec<(String, Vec<f64>)> = match live {
            Some(s) => s
                .names
                .iter()
                .cloned()
                .zip(s.parts.iter().map(|p| pick(&p.psnr, &p.ssim)))
                .filter_map(|(n, v)| Some((n, v?)))
                .collect(),
            None => v
                .parts
                .iter()
                .filter_map(|p| Some((p.name.clone(), pick(&p.psnr, &p.ssim)?)))
                .collect(),
        };
        ui.separator();
        let mut chosen = metric;
        ui.horizontal(|ui| {
            let what = match metric {
                PlotMetric::Psnr => "PSNR per frame (dB)",
                PlotMetric::Ssim => "SSIM per frame",
                PlotMetric::Silhouette => "silhouette per frame",
            };
            ui.label(egui::RichText::new(format!("View {sel}: {what}")).strong());
            ui.selectable_value(&mut chosen, PlotMetric::Psnr, "PSNR")
                .on_hover_text("Peak signal-to-noise ratio over the pixels either image covers (higher is better)");
            ui.selectable_value(&mut chosen, PlotMetric::Ssim, "SSIM").on_hover_text(
                "Structural similarity (11×11 Gaussian window, σ 1.5) over the pixels either image covers: 1 is identical",
            );
            ui.selectable_value(&mut chosen, PlotMetric::Silhouette, "Silhouette").on_hover_text(
                "The pixels both the composite and the render cover over those either covers, whatever their colours (1 = the same shape; the character only): what to read for a nearly black character",
            );
        });
        if overall.is_empty() && metric == PlotMetric::Silhouette {
            ui.label(egui::RichText::new("This report has no silhouette per frame: bake again.").weak());
        }
        use egui_plot::{Corner, Legend, Line, Plot, PlotPoints};
        // PSNR capped as in `compare`'s plots: a frame drawn from its own key image is exact
        // (99 dB), and that spike set the axis to 0..100 with every other curve near its foot.
        let cap = if metric == PlotMetric::Psnr {
            PSNR_PLOT_CAP
        } else {
            f64::INFINITY
        };
        let series = |values: &[f64]| -> PlotPoints<'static> {
            values
                .iter()
                .enumerate()
                .filter(|(_, y)| y.is_finite())
                .map(|(f, &y)| [f as f64, y.min(cap)])
                .collect()
        };
        if metric == PlotMetric::Psnr
            && overall
                .iter()
                .chain(per_part.iter().flat_map(|(_, v)| v))
                .any(|&y| y > cap)
        {
            ui.label(
                egui::RichText::new(format!(
                    "capped at {PSNR_PLOT_CAP:.0} dB: a frame drawn from its own key image is exact"
                ))
                .small()
                .weak(),
            );
        }
        Plot::new(("view error", sel, metric as u8))
            .height(180.0)
            .legend(
                Legend::default()
                    .position(Corner::LeftBottom)
                    .background_alpha(0.6)
                    .text_style(egui::TextStyle::Small),
            )
            .x_axis_label("frame")
            .allow_scroll(false)
            .show(ui, |plot| {
                plot.line(
                    Line::new("character", series(&overall))
                        .width(2.5)
                        .color(egui::Color32::WHITE),
                );
                if !still.is_empty() {
                    plot.line(
                        Line::new("still key frame", series(&still))
                            .style(egui_plot::LineStyle::dashed_dense())
                            .color(egui::Color32::GRAY),
                    );
                }
                for (name, values) in &per_part {
                    plot.line(Line::new(name.clone(), series(values)));
                }
            });
        self.plot = chosen;
    }
}

/// Highest PSNR the per-frame plot shows (dB), as `compare`'s plots.
const PSNR_PLOT_CAP: f64 = 60.0;

/// Whether `report`'s views are ranked and plotted by their silhouette agreement: a nearly
/// black character ([`polypostor::bake::pipeline::is_dark`]) with the silhouette measured
/// (reports written before it have none).
fn dark_report(report: &Report) -> bool {
    polypostor::bake::pipeline::is_dark(report.truth_brightness) && report.mean_silhouette_iou > 0.0
}

#[cfg(test)]
mod tests {
    use super::yaw_pitch;

    #[test]
    fn yaw_pitch_give_back_the_direction() {
        for d in [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.3, 0.8, -0.5], [-0.6, 0.1, -0.7]] {
            let (yaw, pitch) = yaw_pitch(d);
            let cam = polypostor::gpu::Camera::orbit(glam::Vec3::ZERO, yaw, pitch, 1.0, 0.7);
            let got = cam.eye.normalize();
            let want = glam::Vec3::from(d).normalize();
            assert!(got.distance(want) < 1e-5, "{d:?}: {got:?}");
        }
    }
}
