//! The editor application: menus, panels, viewport, timeline, log, dialogs.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::mpsc::{Receiver, channel};
use std::time::{Duration, Instant};

use eframe::egui_wgpu;

use polypostor::Character;
use polypostor::animation::{Pose, clip_bounds};
use polypostor::project::{PROJECT_FILE, Project};

use super::document::{Command, Document, Playback, TIMELINE_FPS};
use super::settings::Settings;
use super::viewport::{OrbitCamera, ViewMode, ViewportCallback, ViewportResources};

mod commands;
mod dialogs;
mod files;
mod panels;

use commands::{remove_temp_bakes, views_source_on_open};
use dialogs::{PathPrompt, PathPurpose};
use files::{LoadRequest, Loading};
use files::{expand_home, is_gltf};
use panels::panel_frame;

/// How the app is set up (tests use no settings file and synchronous loading).
#[derive(Clone, Debug, Default)]
pub struct AppOptions {
    /// Where recent files are remembered; `None` keeps them in memory only.
    pub settings_path: Option<PathBuf>,
    /// Load on the UI thread (tests) instead of a background thread.
    pub sync_loading: bool,
    /// Where never-saved projects are autosaved; `None`: they are not.
    pub recovery_dir: Option<PathBuf>,
    /// Autosave and offer recovery (tests that do not exercise it turn it off, so a stray
    /// autosave beside the default project cannot change what they see).
    pub autosave: bool,
}

pub use super::log_entry::{LogEntry, LogLevel};

/// Frame-time statistics for the FPS figure.
#[derive(Default)]
struct FrameTimer {
    last: Option<Instant>,
    smoothed_secs: f32,
    /// eframe's CPU time of a frame (update + paint, without waiting for vsync), smoothed.
    cpu_secs: f32,
    /// `POLYPOSTOR_FRAME_LOG`: one line per frame, "interval_ms cpu_ms", for measuring the UI
    /// (see the README's benchmarks).
    log: Option<std::io::LineWriter<std::fs::File>>,
    /// Whether the last frame asked for the next one at once: only then is the interval
    /// between them the frame's cost (a throttled or idle window waits on purpose).
    continuous: bool,
}

impl FrameTimer {
    fn tick(&mut self) -> f32 {
        let now = Instant::now();
        let dt = self.last.map_or(0.0, |l| (now - l).as_secs_f32());
        self.last = Some(now);
        if dt > 0.0 && std::mem::take(&mut self.continuous) {
            self.smoothed_secs = if self.smoothed_secs == 0.0 {
                dt
            } else {
                self.smoothed_secs * 0.9 + dt * 0.1
            };
        }
        dt.min(0.25)
    }
    /// Opens the frame log named by `POLYPOSTOR_FRAME_LOG`, if any.
    fn from_env() -> Self {
        let log = std::env::var_os("POLYPOSTOR_FRAME_LOG").and_then(|p| {
            std::fs::File::create(&p)
                .map_err(|e| log::warn!("cannot write the frame log {}: {e}", p.display()))
                .ok()
                .map(std::io::LineWriter::new)
        });
        Self { log, ..Self::default() }
    }

    /// Records eframe's figures for the last frame (and logs this frame's interval).
    fn record(&mut self, dt_secs: f32, cpu: Option<f32>) {
        if let Some(c) = cpu {
            self.cpu_secs = if self.cpu_secs == 0.0 {
                c
            } else {
                self.cpu_secs * 0.9 + c * 0.1
            };
        }
        if let Some(f) = &mut self.log {
            use std::io::Write;
            let _ = writeln!(f, "{:.2} {:.2}", dt_secs * 1000.0, cpu.unwrap_or(0.0) * 1000.0);
        }
    }

    fn fps(&self) -> f32 {
        if self.smoothed_secs > 0.0 {
            1.0 / self.smoothed_secs
        } else {
            0.0
        }
    }
}

pub struct EditorApp {
    options: AppOptions,
    settings: Settings,
    pub doc: Option<Document>,
    pub playback: Playback,
    pub camera: OrbitCamera,
    pub view_mode: ViewMode,
    pub grid: bool,
    commands: Vec<Command>,
    loading: Option<Loading>,
    /// The last re-import started for an up-axis change (file and axis): not started again
    /// while the project asks for the same one, so a failed re-import (the file gone or
    /// broken since it was opened) is reported once, not every frame.
    reimport_tried: Option<(PathBuf, polypostor::UpAxis)>,
    /// The message of the error dialog, when one is open.
    pub error: Option<String>,
    pub log: Vec<LogEntry>,
    show_log: bool,
    adapter: Option<String>,
    timer: FrameTimer,
    /// The window title last sent (a title command counts as a repaint request: sent only
    /// when it changes, so an idle editor does not redraw).
    window_title: String,
    prompt: Option<PathPrompt>,
    dialog: Option<(PathPurpose, Instant, Receiver<Option<PathBuf>>)>,
    /// The first texture's preview: the document generation it shows, its handle, and whether
    /// any texel is not opaque (then drawn over a checkerboard).
    texture_preview: Option<(u64, egui::TextureHandle, bool)>,
    next_generation: u64,
    show_about: bool,
    /// Close the window at the end of this frame.
    closing: bool,
    /// Where the 3D viewport was last laid out (points).
    pub viewport_rect: egui::Rect,
    /// Where the side panels were drawn this frame: the viewport keeps between them (at
    /// 900 px the fit inspector, wider than its room, lay under the 3D view).
    side_panels: (Option<f32>, Option<f32>),
    pub crowd: super::crowd::CrowdPanel,
    /// Which tab of the side panel shows (when the crowd preview is closed).
    pub tab: SideTab,
    pub segment: super::segment::SegmentPanel,
    pub safety: super::safety::Safety,
    pub views: super::views::ViewsPanel,
    pub export: super::export::ExportDialog,
    /// An export's clip set and settings, made the project's only when its bake succeeds
    /// (a cancelled 137-view export had already set them).
    pending_export: Option<(Vec<String>, polypostor::bake::settings::BakeSettings)>,
    /// Tab pressed outside a text field, taken out of egui's input before its pass (see
    /// `raw_input_hook`): the crowd preview's shortcut, not a move of keyboard focus (which
    /// left a menu button focused, and every shortcut off, until a click elsewhere).
    tab_key: bool,
    /// The Views tab's folder before the running bake pointed it at its own: back there if
    /// the bake fails or is cancelled.
    source_before_bake: Option<Option<std::path::PathBuf>>,
}

/// An answer to the unsaved-changes prompt.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum UnsavedAnswer {
    Save,
    Discard,
    Cancel,
}

/// The side panel's tabs besides the crowd preview.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SideTab {
    Character,
    Segment,
    Views,
}

impl EditorApp {
    pub fn new(cc: &eframe::CreationContext<'_>, options: AppOptions, open: Option<PathBuf>) -> Self {
        let adapter = cc.wgpu_render_state.as_ref().map(ViewportResources::install);
        if let Some(rs) = &cc.wgpu_render_state {
            super::set_software_rendering(&cc.egui_ctx, rs.adapter.get_info().device_type == wgpu::DeviceType::Cpu);
        }
        let settings = Settings::load(options.settings_path.as_deref());
        remove_temp_bakes(false);
        let mut app = Self {
            options,
            settings,
            doc: None,
            playback: Playback::default(),
            camera: OrbitCamera::default(),
            view_mode: ViewMode::Lit,
            grid: true,
            commands: Vec::new(),
            loading: None,
            reimport_tried: None,
            error: None,
            log: Vec::new(),
            show_log: true,
            adapter,
            timer: FrameTimer::from_env(),
            window_title: String::new(),
            prompt: None,
            dialog: None,
            texture_preview: None,
            next_generation: 1,
            show_about: false,
            closing: false,
            viewport_rect: egui::Rect::NOTHING,
            side_panels: (None, None),
            crowd: Default::default(),
            tab: SideTab::Character,
            segment: Default::default(),
            safety: Default::default(),
            views: Default::default(),
            export: Default::default(),
            pending_export: None,
            tab_key: false,
            source_before_bake: None,
        };
        match &app.adapter {
            Some(a) => app.info(format!("GPU adapter: {a}")),
            None => app.log_error("no wgpu renderer: the 3D viewport is disabled".into()),
        }
        if let Some(path) = open {
            app.commands.push(Command::Open(path));
        }
        app
    }

    fn info(&mut self, text: String) {
        log::info!("{text}");
        self.log.push(LogEntry {
            level: LogLevel::Info,
            text,
        });
    }

    fn warn(&mut self, text: String) {
        log::warn!("{text}");
        self.log.push(LogEntry {
            level: LogLevel::Warning,
            text,
        });
    }

    fn log_error(&mut self, text: String) {
        log::error!("{text}");
        self.log.push(LogEntry {
            level: LogLevel::Error,
            text,
        });
    }

    /// Shows an error dialog (and logs it).
    fn fail(&mut self, text: String) {
        self.log_error(text.clone());
        self.error = Some(text);
    }

    // ----------------------------------------------------------------------------------
    // Commands

    // ----------------------------------------------------------------------------------
    // UI
}

impl eframe::App for EditorApp {
    fn raw_input_hook(&mut self, ctx: &egui::Context, raw_input: &mut egui::RawInput) {
        // Only where Tab would move focus off nothing: a focused widget, a question or a
        // dialog keeps Tab for moving between its fields.
        if ctx.memory(|m| m.focused().is_some() || m.top_modal_layer().is_some())
            || self.prompt.is_some()
            || self.export.open
            || egui::Popup::is_any_open(ctx)
        {
            return;
        }
        raw_input.events.retain(|e| match e {
            egui::Event::Key {
                key: egui::Key::Tab,
                pressed,
                modifiers,
                ..
            } if modifiers.is_none() => {
                self.tab_key |= *pressed;
                false
            }
            _ => true,
        });
    }

    /// The temporary bake of a never-saved project goes with the editor.
    fn on_exit(&mut self) {
        remove_temp_bakes(true);
        // Closing with nothing unsaved: an autosave left (a recovery undone back to the
        // saved project) holds nothing the project lacks, and would be offered again.
        // Not while its recovery is still being asked about: that autosave is the lost work.
        if let Some(doc) = self.doc.as_ref().filter(|d| !d.dirty)
            && self.options.autosave
            && self.safety.recovery.is_none()
        {
            self.safety.clear(doc, self.options.recovery_dir.as_deref());
        }
    }

    /// The panels' background: they leave it unpainted (see [`panel_frame`]).
    fn clear_color(&self, visuals: &egui::Visuals) -> [f32; 4] {
        visuals.panel_fill.to_normalized_gamma_f32()
    }

    fn ui(&mut self, ui: &mut egui::Ui, frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        let dt = self.timer.tick();
        self.timer.record(dt, frame.info().cpu_usage);
        self.poll_loading();
        self.poll_dialog();
        self.crowd.poll();
        if let Some(ok) = self.crowd.outcome.take() {
            let pending = self.pending_export.take();
            let before = self.source_before_bake.take();
            if ok {
                if let (Some((clips, settings)), Some(doc)) = (pending, self.doc.as_mut())
                    && (doc.project.clips != clips || doc.project.bake != settings)
                {
                    doc.project.clips = clips;
                    doc.project.bake = settings;
                    doc.dirty = true;
                }
                // A Polypostor bake (it pointed the Views tab at its folder): the project
                // remembers it, and opens on it next time.
                // (Not for a document never saved: its bake is in a temporary folder, gone
                // when the editor exits.)
                if before.is_some()
                    && let (Some(doc), Some(out)) = (self.doc.as_mut(), self.views.source.as_deref())
                    && let Some(dir) = doc.project_file.as_deref().and_then(Path::parent)
                {
                    let stored = polypostor::project::relative_path(out, dir);
                    if doc.project.view.last_pack.as_deref() != Some(stored.as_str()) {
                        doc.project.view.last_pack = Some(stored);
                        // Bookkeeping, not an edit: a project saved just before is kept saved
                        // (the record written into its file at once) rather than asking
                        // "Save changes?" on closing when nothing was changed.
                        // (Not over a file holding keys this build does not read: a save would
                        // drop them, and only the artist's Save may.)
                        let file = doc.project_file.clone();
                        let quiet = !doc.dirty
                            && file.as_deref().is_some_and(|f| {
                                polypostor::project::Project::unknown_keys(f).is_empty() && doc.project.save(f).is_ok()
                            });
                        if quiet {
                            if let Some(saved) = &mut doc.saved {
                                saved.view.last_pack = doc.project.view.last_pack.clone();
                            }
                        } else {
                            doc.dirty = true;
                        }
                    }
                }
            } else if let Some(before) = before {
                self.views.set_source(before.as_deref());
            }
        }
        for (level, text) in std::mem::take(&mut self.crowd.messages) {
            match level {
                LogLevel::Info => self.info(text),
                LogLevel::Warning => self.warn(text),
                LogLevel::Error => self.fail(text),
            }
        }
        for m in std::mem::take(&mut self.segment.messages) {
            self.fail(m);
        }
        for m in std::mem::take(&mut self.segment.notes) {
            self.warn(m);
        }
        self.dropped_files(&ctx);
        self.shortcuts(&ctx);
        self.apply_commands(&ctx);
        self.reimport_if_needed(&ctx);
        self.autosave(false);
        if self.options.autosave && self.doc.as_ref().is_some_and(|d| d.dirty) {
            ctx.request_repaint_after(self.safety.next_due() + std::time::Duration::from_millis(50));
        }
        // Closing with unsaved changes asks first.
        if ctx.input(|i| i.viewport().close_requested())
            && !self.safety.allow_close
            && self.doc.as_ref().is_some_and(|d| d.dirty)
        {
            ctx.send_viewport_cmd(egui::ViewportCommand::CancelClose);
            self.safety.close_prompt = true;
        }

        // Advance playback.
        if let Some(doc) = &self.doc {
            let d = doc.clip_duration(self.playback.clip);
            if self.playback.playing && d > 0.0 {
                self.playback.time_secs = (self.playback.time_secs + dt * self.playback.speed).rem_euclid(d);
            }
        }

        let title = match &self.doc {
            Some(doc) => format!("{} — Polypostor Studio", doc.title()),
            None => "Polypostor Studio".into(),
        };
        if title != self.window_title {
            self.window_title = title.clone();
            ctx.send_viewport_cmd(egui::ViewportCommand::Title(title));
        }

        egui::Panel::top("menu")
            .frame(panel_frame(ui.style()))
            .show(ui, |ui| self.menu_bar(ui));
        egui::Panel::bottom("status")
            .frame(panel_frame(ui.style()))
            .show(ui, |ui| self.status_bar(ui));
        egui::Panel::bottom("timeline")
            .frame(panel_frame(ui.style()))
            .show(ui, |ui| {
                ui.add_space(4.0);
                self.timeline(ui);
                ui.add_space(2.0);
            });
        if self.show_log {
            egui::Panel::bottom("log")
                .frame(panel_frame(ui.style()))
                .resizable(true)
                .default_size(130.0)
                .min_size(60.0)
                .show(ui, |ui| self.log_panel(ui));
        }
        let fps = self.timer.fps();
        // Side panels never take more than about half the window: wide content (the crowd's
        // statistics, long names) is cut at the edge instead of widening them for good.
        let side_max = (ui.available_width() * 0.45).max(260.0);
        self.side_panels = (None, None);
        let left = egui::Panel::left("character")
            .frame(panel_frame(ui.style()))
            .resizable(true)
            .default_size(300.0)
            .max_size(side_max)
            .show(ui, |ui| {
                // The tabs wrap onto a second row in a narrow panel.
                ui.horizontal_wrapped(|ui| {
                    let open = self.crowd.open;
                    if ui
                        .selectable_label(!open && self.tab == SideTab::Character, "Character")
                        .clicked()
                    {
                        self.tab = SideTab::Character;
                        self.send(Command::ShowCrowd(false));
                    }
                    if ui
                        .selectable_label(!open && self.tab == SideTab::Segment, "Segment")
                        .on_hover_text("Paint body parts and author caps")
                        .clicked()
                    {
                        self.tab = SideTab::Segment;
                        self.send(Command::ShowCrowd(false));
                    }
                    if ui
                        .selectable_label(!open && self.tab == SideTab::Views, "Views")
                        .on_hover_text("The bake's viewpoints by fit error, and the error per frame")
                        .clicked()
                    {
                        self.tab = SideTab::Views;
                        self.send(Command::ShowCrowd(false));
                    }
                    if ui.selectable_label(open, "Crowd preview").clicked() {
                        self.send(Command::ShowCrowd(true));
                    }
                });
                ui.separator();
                egui::ScrollArea::vertical().show(ui, |ui| {
                    if self.crowd.open {
                        self.crowd.controls(ui, fps);
                        match self.crowd.asks.take() {
                            Some(super::crowd::PanelAsk::Browse) => self.ask_path(PathPurpose::AddToCrowd),
                            Some(super::crowd::PanelAsk::TypePath) => {
                                self.prompt = Some(PathPrompt::new(PathPurpose::AddToCrowd))
                            }
                            Some(super::crowd::PanelAsk::Remove(k)) => self.send(Command::RemoveFromCrowd(k)),
                            None => {}
                        }
                    } else if self.tab == SideTab::Segment && self.doc.is_some() {
                        let doc = self.doc.as_mut().unwrap();
                        self.segment.controls(ui, doc);
                    } else if self.tab == SideTab::Views {
                        let sync = self.options.sync_loading;
                        self.views.controls(ui, &mut self.camera, self.doc.as_mut(), sync);
                    } else {
                        self.side_panel(ui);
                    }
                });
            });
        self.side_panels.0 = Some(left.response.rect.right());
        if !self.crowd.open && self.tab == SideTab::Views && self.views.selected.is_some() && self.doc.is_some() {
            let mut inspector_left = None;
            let right = egui::Panel::right("fit inspector")
                .frame(panel_frame(ui.style()))
                .resizable(true)
                .default_size(470.0)
                // What the character panel left, less room for the viewport between them (at
                // 700 px wide the viewport was drawn over both panels).
                .max_size((ui.available_width() - 160.0).max(120.0))
                .show(ui, |ui| {
                    // Where the panel starts: its content wider than the panel grows it off the
                    // window's right edge, and the rect the panel reports is then cut from
                    // that edge, not from where it is drawn.
                    inspector_left = Some(ui.max_rect().left() - panel_frame(ui.style()).total_margin().left);
                    egui::ScrollArea::vertical().id_salt("inspector scroll").show(ui, |ui| {
                        let doc = self.doc.as_mut().unwrap();
                        self.views.inspector_panel(ui, doc, dt);
                    });
                });
            self.side_panels.1 = Some(inspector_left.unwrap_or(right.response.rect.left()));
        }
        egui::CentralPanel::default().frame(egui::Frame::NONE).show(ui, |ui| {
            if self.crowd.open {
                self.crowd.viewport(ui, dt);
            } else {
                self.viewport(ui);
            }
        });
        self.dialogs(&ctx);
        self.safety_dialogs(&ctx);
        if let Some(doc) = &self.doc
            && let Some(req) = self.export.ui(&ctx, doc, self.playback.clip)
        {
            self.info(format!("exporting into {}", req.folder.display()));
            self.send(Command::Export(req));
        }
        if std::mem::take(&mut self.closing) {
            ctx.send_viewport_cmd(egui::ViewportCommand::Close);
        }

        // Animation redraws every frame, except while a bake runs: then the crowd preview
        // holds still and playback steps four times a second, since on a software rasteriser
        // every frame would take the CPU from the bake. Background work only needs its
        // progress shown: four redraws a second (input still redraws at once).
        let baking = self.crowd.busy();
        if (self.playback.playing && self.doc.is_some() && !baking)
            || self.views.inspector.busy()
            || (self.crowd.open && self.crowd.assets.is_some() && !baking)
        {
            ctx.request_repaint();
            self.timer.continuous = true;
        } else if baking {
            ctx.request_repaint_after(std::time::Duration::from_millis(250));
        } else if self.loading.is_some() || self.dialog.is_some() {
            ctx.request_repaint_after(std::time::Duration::from_millis(100));
        }
    }
}
