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

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LogLevel {
    Info,
    Warning,
    Error,
}

#[derive(Clone, Debug)]
pub struct LogEntry {
    pub level: LogLevel,
    pub text: String,
}

/// A loaded project, ready to become the document.
struct Loaded {
    project: Project,
    project_file: Option<PathBuf>,
    character_path: PathBuf,
    character: Character,
    from_gltf: bool,
}

/// What a typed-path prompt or a file dialog is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PathPurpose {
    NewFromGltf,
    Open,
    SaveAs,
    OpenCrowd,
    AddToCrowd,
}

impl PathPurpose {
    fn title(self) -> &'static str {
        match self {
            PathPurpose::NewFromGltf => "New project from glTF",
            PathPurpose::Open => "Open project",
            PathPurpose::SaveAs => "Save project as",
            PathPurpose::OpenCrowd => "Open a baked folder in the crowd preview",
            PathPurpose::AddToCrowd => "Add another baked character to the crowd",
        }
    }
    fn hint(self) -> &'static str {
        match self {
            PathPurpose::NewFromGltf => "path to a .glb or .gltf file",
            PathPurpose::Open => "project folder, project.json, or .glb/.gltf",
            PathPurpose::SaveAs => "project folder or .json file to write",
            PathPurpose::OpenCrowd => "folder written by bake --representation all",
            PathPurpose::AddToCrowd => "folder written by bake --representation all (of any character)",
        }
    }
    fn command(self, path: PathBuf) -> Command {
        match self {
            PathPurpose::NewFromGltf => Command::NewFromGltf(path),
            PathPurpose::Open => Command::Open(path),
            PathPurpose::SaveAs => Command::SaveAs(path),
            PathPurpose::OpenCrowd => Command::OpenCrowd(path),
            PathPurpose::AddToCrowd => Command::AddToCrowd(path),
        }
    }
}

struct PathPrompt {
    purpose: PathPurpose,
    text: String,
    /// Focus is given to the text field once, when the prompt opens.
    focused: bool,
}

impl PathPrompt {
    fn new(purpose: PathPurpose) -> Self {
        Self {
            purpose,
            text: String::new(),
            focused: false,
        }
    }
}

struct Loading {
    what: String,
    started: Instant,
    rx: Receiver<Result<Loaded, String>>,
}

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
    texture_preview: Option<(u64, egui::TextureHandle)>,
    next_generation: u64,
    show_about: bool,
    /// Close the window at the end of this frame.
    closing: bool,
    /// Where the 3D viewport was last laid out (points).
    pub viewport_rect: egui::Rect,
    pub crowd: super::crowd::CrowdPanel,
    /// Which tab of the side panel shows (when the crowd preview is closed).
    pub tab: SideTab,
    pub segment: super::segment::SegmentPanel,
    pub safety: super::safety::Safety,
    pub views: super::views::ViewsPanel,
    pub export: super::export::ExportDialog,
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
        remove_stale_temp_bakes();
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
            crowd: Default::default(),
            tab: SideTab::Character,
            segment: Default::default(),
            safety: Default::default(),
            views: Default::default(),
            export: Default::default(),
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

    /// Queues a command (applied at the start of the next frame).
    pub fn send(&mut self, command: Command) {
        self.commands.push(command);
    }

    // ----------------------------------------------------------------------------------
    // Commands

    fn apply_commands(&mut self, ctx: &egui::Context) {
        for command in std::mem::take(&mut self.commands) {
            self.apply(ctx, command);
        }
    }

    fn apply(&mut self, ctx: &egui::Context, command: Command) {
        // Replacing a document with unsaved changes asks first, as closing does.
        if matches!(command, Command::NewFromGltf(_) | Command::Open(_))
            && !std::mem::take(&mut self.safety.replace_confirmed)
            && self.doc.as_ref().is_some_and(|d| d.dirty)
        {
            self.safety.replace_prompt = Some(command);
            return;
        }
        match command {
            Command::NewFromGltf(path) => self.start_load(ctx, LoadRequest::Gltf(path)),
            Command::Open(path) => {
                if is_gltf(&path) {
                    self.start_load(ctx, LoadRequest::Gltf(path));
                } else {
                    self.start_load(ctx, LoadRequest::Project(path));
                }
            }
            Command::Save => match self.doc.as_ref().map(|d| d.project_file.clone()) {
                Some(Some(file)) => self.save_to(file),
                Some(None) => self.ask_path(PathPurpose::SaveAs),
                None => {}
            },
            Command::SaveAs(path) => {
                let file = if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("json")) {
                    path
                } else {
                    path.join(PROJECT_FILE)
                };
                self.save_to(file);
            }
            Command::SelectClip(clip) => {
                if let Some(doc) = &mut self.doc {
                    let clip = clip.filter(|&i| i < doc.character.clips.len());
                    if self.playback.clip != clip {
                        self.playback.clip = clip;
                        self.playback.time_secs = 0.0;
                        doc.project.view.clip = clip.map(|i| doc.character.clips[i].name.clone());
                        doc.dirty = true;
                    }
                }
            }
            Command::SetPlaying(p) => self.playback.playing = p,
            Command::TogglePlaying => self.playback.playing = !self.playback.playing,
            Command::Seek(t) => {
                let d = self.doc.as_ref().map_or(0.0, |d| d.clip_duration(self.playback.clip));
                self.playback.time_secs = t.clamp(0.0, d.max(0.0));
            }
            Command::StepFrames(n) => {
                self.playback.playing = false;
                let d = self.doc.as_ref().map_or(0.0, |d| d.clip_duration(self.playback.clip));
                let frame = (self.playback.time_secs * TIMELINE_FPS).round() + n as f32;
                let t = frame / TIMELINE_FPS;
                self.playback.time_secs = if d > 0.0 { t.rem_euclid(d) } else { 0.0 };
            }
            Command::SetSpeed(s) => {
                self.playback.speed = s;
                if let Some(doc) = &mut self.doc {
                    doc.project.view.playback_speed = Some(s);
                    doc.dirty = true;
                }
            }
            Command::FrameCharacter => self.frame_character(),
            Command::BakeCrowd => self.bake_crowd(),
            Command::OpenCrowd(folder) => {
                self.views.set_source(Some(&folder));
                let character = self.doc.as_ref().map(|d| d.character_path.clone());
                self.crowd.start_open(folder, character);
            }
            Command::AddToCrowd(folder) => self.crowd.start_add(folder),
            Command::RemoveFromCrowd(k) => self.crowd.remove_guest(k),
            Command::ShowCrowd(show) => self.crowd.open = show,
            Command::Export(req) => {
                // The clip set chosen is the project's from now on (Ctrl+B bakes it too).
                // The clip set and the settings chosen become the project's.
                let mut settings = self.doc.as_ref().map(|d| d.project.bake.clone()).unwrap_or_default();
                (settings.views, settings.resolution, settings.fps) = (req.views, req.resolution, req.fps);
                (settings.png, settings.textures) = (req.png, req.textures);
                if let Some(doc) = self.doc.as_mut()
                    && (doc.project.clips != req.clips || doc.project.bake != settings)
                {
                    doc.project.clips = req.clips.clone();
                    doc.project.bake = settings.clone();
                    doc.dirty = true;
                }
                let options = settings.options();
                self.bake_into(req.folder, options, req.set);
            }
            Command::Undo => {
                if let Some(label) = self.doc.as_mut().and_then(|d| d.undo()) {
                    self.info(format!("undid {label}"));
                }
            }
            Command::Redo => {
                if let Some(label) = self.doc.as_mut().and_then(|d| d.redo()) {
                    self.info(format!("redid {label}"));
                }
            }
        }
    }

    /// Bakes the open character with every representation beside the project (or in the
    /// temporary folder for an unsaved project) and opens the crowd preview on it.
    fn bake_crowd(&mut self) {
        let Some(doc) = &self.doc else {
            self.fail("open a character before baking it for the crowd".into());
            return;
        };
        let out = bake_dir(doc);
        // The project's bake settings; every representation (the crowd's mix needs them).
        let options = doc.project.bake.options();
        self.bake_into(out, options, polypostor::reps::RepSet::ALL);
    }

    /// Bakes `set` with `options` into `out` in the background, then previews it.
    fn bake_into(
        &mut self,
        out: PathBuf,
        options: polypostor::bake::pipeline::BakeOptions,
        set: polypostor::reps::RepSet,
    ) {
        let Some(doc) = &self.doc else {
            self.fail("open a character before baking it for the crowd".into());
            return;
        };
        if self.crowd.busy() {
            return;
        }
        let c = doc.character.clone();
        let segmentation = doc.segmentation.clone();
        if set.polypostor {
            self.views.set_source(Some(&out));
        }
        // The project's clip set (a whole-character pack), else the clip being viewed: the
        // rule every bake follows.
        let clips = polypostor::bake::job::ClipChoice::resolve(
            &c,
            polypostor::bake::job::ClipRequest {
                project_clips: &doc.project.clips,
                viewed: self.playback.clip,
                ..Default::default()
            },
        )
        .unwrap_or_default();
        let req = super::crowd::BakeRequest {
            character_path: doc.character_path.clone(),
            clip: clips.first,
            extra_clips: clips.extra,
            segmentation,
            caps: doc.project.caps.clone(),
            overrides: doc.project.overrides.clone(),
            previous: self
                .crowd
                .last_bake
                .as_ref()
                .filter(|(folder, _)| *folder == out)
                .map(|(_, b)| b.clone()),
            options,
            set,
            out: out.clone(),
            character: c,
        };
        self.info(format!("baking into {}", out.display()));
        self.crowd.start_bake(req);
    }

    fn frame_character(&mut self) {
        if let Some(doc) = &self.doc {
            let (min, max) = clip_bounds(&doc.character, self.playback.clip, 12);
            self.camera.frame(min, max);
        }
    }

    fn save_to(&mut self, file: PathBuf) {
        let Some(doc) = &mut self.doc else { return };
        // Save As never writes over a file that is not a project (a user's JSON, a folder).
        if doc.project_file.as_ref() != Some(&file)
            && std::fs::symlink_metadata(&file).is_ok()
            && Project::load(&file).is_err()
        {
            self.safety.close_after_save = false;
            self.safety.replace_after_save = None;
            self.fail(format!(
                "{} exists and is not a project file; it is left untouched: choose another place",
                file.display()
            ));
            return;
        }
        let old_autosave = super::safety::autosave_path(doc, self.options.recovery_dir.as_deref());
        let mut project = doc.project.clone();
        project.view.clip = self
            .playback
            .clip
            .and_then(|i| doc.character.clips.get(i))
            .map(|c| c.name.clone());
        project.view.playback_speed = Some(self.playback.speed);
        // Keep the character reference valid from the new location.
        let dir = file.parent().map(Path::to_owned).unwrap_or_default();
        project.character.path = polypostor::project::relative_path(&doc.character_path, &dir);
        if project.name.is_empty() || doc.project_file.is_none() {
            if let Some(stem) = file.parent().and_then(|p| p.file_name()) {
                project.name = stem.to_string_lossy().into_owned();
            }
        }
        match project.save(&file) {
            Ok(()) => {
                doc.project = project;
                doc.project_file = Some(file.clone());
                doc.dirty = false;
                if let Some(old) = old_autosave {
                    let _ = std::fs::remove_file(old);
                }
                self.safety.clear(doc, self.options.recovery_dir.as_deref());
                self.settings.touch_recent(&file);
                self.save_settings();
                self.info(format!("saved {}", file.display()));
                if self.safety.close_after_save {
                    self.safety.allow_close = true;
                    self.closing = true;
                }
                if let Some(next) = self.safety.replace_after_save.take() {
                    self.safety.replace_confirmed = true;
                    self.send(next);
                }
            }
            Err(e) => {
                self.safety.close_after_save = false;
                self.safety.replace_after_save = None;
                self.fail(e.to_string())
            }
        }
    }

    /// Writes the autosave now if anything changed since the last one (tests; the frame loop
    /// calls it every 30 s).
    #[cfg(test)]
    pub fn autosave_now(&mut self) -> bool {
        self.autosave(true)
    }

    fn autosave(&mut self, force: bool) -> bool {
        if !self.options.autosave {
            return false;
        }
        let Some(doc) = &self.doc else { return false };
        match self.safety.tick(doc, self.options.recovery_dir.as_deref(), force) {
            Ok(wrote) => wrote,
            Err(e) => {
                self.warn(e);
                false
            }
        }
    }

    fn save_settings(&mut self) {
        if let Err(e) = self.settings.save(self.options.settings_path.as_deref()) {
            self.warn(format!("cannot save editor settings: {e}"));
        }
    }

    fn start_load(&mut self, ctx: &egui::Context, request: LoadRequest) {
        let what = request.describe();
        if self.options.sync_loading {
            let result = request.run();
            self.finish_load(result);
            return;
        }
        let (tx, rx) = channel();
        let ctx = ctx.clone();
        let spawned = std::thread::Builder::new().name("load".into()).spawn(move || {
            let result = request.run();
            let _ = tx.send(result);
            ctx.request_repaint();
        });
        match spawned {
            Ok(_) => {
                self.loading = Some(Loading {
                    what,
                    started: Instant::now(),
                    rx,
                })
            }
            Err(e) => self.fail(format!("cannot start loading: {e}")),
        }
    }

    fn poll_loading(&mut self) {
        let Some(loading) = &self.loading else { return };
        match loading.rx.try_recv() {
            Ok(result) => {
                self.loading = None;
                self.finish_load(result);
            }
            Err(std::sync::mpsc::TryRecvError::Empty) => {}
            Err(std::sync::mpsc::TryRecvError::Disconnected) => {
                self.loading = None;
                self.fail("loading stopped unexpectedly".into());
            }
        }
    }

    fn finish_load(&mut self, result: Result<Loaded, String>) {
        let loaded = match result {
            Ok(l) => l,
            Err(e) => {
                // The open project (if any) stays as it was.
                self.fail(e);
                return;
            }
        };
        let c = &loaded.character;
        self.info(format!(
            "loaded {} ({} vertices, {} triangles, {} joints, {} clips)",
            loaded.character_path.display(),
            c.vertices.len(),
            c.triangle_count(),
            c.skeleton.joint_count(),
            c.clips.len()
        ));
        for w in &c.warnings {
            self.warn(w.clone());
        }
        let clip = loaded
            .project
            .view
            .clip
            .as_deref()
            .and_then(|name| c.find_clip(name))
            .or_else(|| (!c.clips.is_empty()).then_some(0));
        self.playback = Playback {
            clip,
            time_secs: 0.0,
            playing: true,
            speed: loaded
                .project
                .view
                .playback_speed
                .filter(|s| s.is_finite() && *s > 0.0)
                .unwrap_or(1.0),
        };
        if let Some(file) = &loaded.project_file {
            self.settings.touch_recent(file);
        } else if loaded.from_gltf {
            self.settings.touch_recent(&loaded.character_path);
        }
        self.save_settings();
        let generation = self.next_generation;
        self.next_generation += 1;
        let (segmentation, problem) = Document::decode_segmentation(&loaded.project, &loaded.character);
        if let Some(p) = problem {
            self.warn(p);
        }
        let doc = Document {
            project: loaded.project,
            dirty: loaded.project_file.is_none(),
            project_file: loaded.project_file,
            character_path: loaded.character_path,
            summary: polypostor::summary::Summary::of(&loaded.character),
            character: Arc::new(loaded.character),
            generation,
            segmentation,
            revision: 0,
            history: Default::default(),
        };
        if self.options.autosave
            && let Some(w) = self.safety.check_on_open(&doc, self.options.recovery_dir.as_deref())
        {
            self.warn(w);
        }
        self.views.set_source(Some(&bake_dir(&doc)));
        self.doc = Some(doc);
        self.frame_character();
    }

    /// Opens the native file dialog on a thread; a dialog that returns at once (no portal
    /// or dialog service on this desktop) falls back to the typed-path prompt.
    fn ask_path(&mut self, purpose: PathPurpose) {
        let (tx, rx) = channel();
        let start_dir = self
            .doc
            .as_ref()
            .and_then(|d| d.project_file.as_ref().and_then(|f| f.parent().map(Path::to_owned)));
        let spawned = std::thread::Builder::new().name("file dialog".into()).spawn(move || {
            let mut dialog = rfd::FileDialog::new();
            if let Some(dir) = start_dir {
                dialog = dialog.set_directory(dir);
            }
            let picked = match purpose {
                PathPurpose::NewFromGltf => dialog
                    .add_filter("glTF 2.0", &["glb", "gltf"])
                    .set_title(purpose.title())
                    .pick_file(),
                PathPurpose::Open => dialog
                    .set_title(purpose.title())
                    .add_filter("Project or glTF", &["json", "glb", "gltf"])
                    .pick_file(),
                PathPurpose::SaveAs | PathPurpose::OpenCrowd | PathPurpose::AddToCrowd => {
                    dialog.set_title(purpose.title()).pick_folder()
                }
            };
            let _ = tx.send(picked);
        });
        match spawned {
            Ok(_) => self.dialog = Some((purpose, Instant::now(), rx)),
            Err(_) => self.prompt = Some(PathPrompt::new(purpose)),
        }
    }

    fn poll_dialog(&mut self) {
        let Some((purpose, started, rx)) = &self.dialog else {
            return;
        };
        match rx.try_recv() {
            Ok(Some(path)) => {
                let cmd = purpose.command(path);
                self.dialog = None;
                self.send(cmd);
            }
            Ok(None) | Err(std::sync::mpsc::TryRecvError::Disconnected) => {
                // A dialog that closes within a fraction of a second never showed.
                let instant = started.elapsed() < Duration::from_millis(400);
                let purpose = *purpose;
                self.dialog = None;
                if instant {
                    self.prompt = Some(PathPrompt::new(purpose));
                } else if purpose == PathPurpose::SaveAs {
                    self.safety.close_after_save = false;
                    self.safety.replace_after_save = None;
                }
            }
            Err(std::sync::mpsc::TryRecvError::Empty) => {}
        }
    }

    // ----------------------------------------------------------------------------------
    // UI

    fn shortcuts(&mut self, ctx: &egui::Context) {
        use egui::{Key, KeyboardShortcut, Modifiers};
        let typing = ctx.egui_wants_keyboard_input();
        let (undo, redo) = if typing {
            (false, false)
        } else {
            ctx.input_mut(|i| {
                // Ctrl+Shift+Z first, or Ctrl+Z would take it.
                let redo = i.consume_shortcut(&KeyboardShortcut::new(Modifiers::COMMAND | Modifiers::SHIFT, Key::Z))
                    || i.consume_shortcut(&KeyboardShortcut::new(Modifiers::COMMAND, Key::Y));
                let undo = i.consume_shortcut(&KeyboardShortcut::new(Modifiers::COMMAND, Key::Z));
                (undo, redo)
            })
        };
        if undo {
            self.send(Command::Undo);
        }
        if redo {
            self.send(Command::Redo);
        }
        let (open, new, save_as, save, quit, bake) = ctx.input_mut(|i| {
            let open = i.consume_shortcut(&KeyboardShortcut::new(Modifiers::COMMAND, Key::O));
            let new = i.consume_shortcut(&KeyboardShortcut::new(Modifiers::COMMAND, Key::N));
            // Ctrl+Shift+S first, or Ctrl+S would take it.
            let save_as = i.consume_shortcut(&KeyboardShortcut::new(Modifiers::COMMAND | Modifiers::SHIFT, Key::S));
            let save = i.consume_shortcut(&KeyboardShortcut::new(Modifiers::COMMAND, Key::S));
            let quit = i.consume_shortcut(&KeyboardShortcut::new(Modifiers::COMMAND, Key::Q));
            let bake = i.consume_shortcut(&KeyboardShortcut::new(Modifiers::COMMAND, Key::B));
            (open, new, save_as, save, quit, bake)
        });
        if ctx.input_mut(|i| i.consume_shortcut(&KeyboardShortcut::new(Modifiers::COMMAND, Key::E)))
            && !self.crowd.busy()
            && let Some(doc) = &self.doc
        {
            self.export.show(doc, self.playback.clip);
        }
        if bake && self.doc.is_some() {
            self.send(Command::BakeCrowd);
        }
        if open {
            self.ask_path(PathPurpose::Open);
        }
        if new {
            self.ask_path(PathPurpose::NewFromGltf);
        }
        if save_as && self.doc.is_some() {
            self.ask_path(PathPurpose::SaveAs);
        }
        if save {
            self.send(Command::Save);
        }
        if quit {
            ctx.send_viewport_cmd(egui::ViewportCommand::Close);
        }
        if typing || self.prompt.is_some() {
            return;
        }
        let (tab, p) = ctx.input(|i| (i.key_pressed(Key::Tab), i.key_pressed(Key::P)));
        if tab {
            self.send(Command::ShowCrowd(!self.crowd.open));
        }
        if p && self.crowd.open {
            self.crowd.paused = !self.crowd.paused;
        }
        if self.tab == SideTab::Segment && !self.crowd.open {
            self.segment.shortcuts(ctx);
        }
        let (space, left, right, home, f) = ctx.input(|i| {
            (
                i.key_pressed(Key::Space),
                i.key_pressed(Key::ArrowLeft),
                i.key_pressed(Key::ArrowRight),
                i.key_pressed(Key::Home),
                i.key_pressed(Key::F),
            )
        });
        if space {
            self.send(Command::TogglePlaying);
        }
        if left {
            self.send(Command::StepFrames(-1));
        }
        if right {
            self.send(Command::StepFrames(1));
        }
        if home {
            self.send(Command::Seek(0.0));
        }
        if f {
            self.send(Command::FrameCharacter);
        }
    }

    fn dropped_files(&mut self, ctx: &egui::Context) {
        let dropped: Vec<PathBuf> = ctx.input(|i| {
            i.raw
                .dropped_files
                .iter()
                .map(|f| f.path().to_owned())
                .filter(|p| !p.as_os_str().is_empty())
                .collect()
        });
        if let Some(path) = dropped.into_iter().next() {
            if is_gltf(&path) {
                self.send(Command::NewFromGltf(path));
            } else {
                self.send(Command::Open(path));
            }
        }
    }

    fn menu_bar(&mut self, ui: &mut egui::Ui) {
        egui::MenuBar::new().ui(ui, |ui| {
            ui.menu_button("File", |ui| {
                if ui
                    .add(egui::Button::new("New from glTF…").shortcut_text("Ctrl+N"))
                    .clicked()
                {
                    self.ask_path(PathPurpose::NewFromGltf);
                }
                if ui.add(egui::Button::new("Open…").shortcut_text("Ctrl+O")).clicked() {
                    self.ask_path(PathPurpose::Open);
                }
                if ui.button("Open path…").clicked() {
                    self.prompt = Some(PathPrompt::new(PathPurpose::Open));
                }
                ui.menu_button("Open recent", |ui| {
                    if self.settings.recent.is_empty() {
                        ui.label("(none)");
                    }
                    for path in self.settings.recent.clone() {
                        if ui.button(path.display().to_string()).clicked() {
                            self.send(Command::Open(path));
                        }
                    }
                });
                ui.separator();
                let has_doc = self.doc.is_some();
                if ui
                    .add_enabled(has_doc, egui::Button::new("Save").shortcut_text("Ctrl+S"))
                    .clicked()
                {
                    self.send(Command::Save);
                }
                if ui
                    .add_enabled(has_doc, egui::Button::new("Save As…").shortcut_text("Ctrl+Shift+S"))
                    .clicked()
                {
                    self.ask_path(PathPurpose::SaveAs);
                }
                if ui.add_enabled(has_doc, egui::Button::new("Save As path…")).clicked() {
                    self.prompt = Some(PathPrompt::new(PathPurpose::SaveAs));
                }
                ui.separator();
                if ui
                    .add_enabled(
                        has_doc && !self.crowd.busy(),
                        egui::Button::new("Export…").shortcut_text("Ctrl+E"),
                    )
                    .clicked()
                    && let Some(doc) = &self.doc
                {
                    self.export.show(doc, self.playback.clip);
                }
                ui.separator();
                if ui.add(egui::Button::new("Quit").shortcut_text("Ctrl+Q")).clicked() {
                    ui.ctx().send_viewport_cmd(egui::ViewportCommand::Close);
                }
            });
            ui.menu_button("Edit", |ui| {
                let (undo, redo) = self.doc.as_ref().map_or((None, None), |d| {
                    (
                        d.history.undo_label().map(str::to_owned),
                        d.history.redo_label().map(str::to_owned),
                    )
                });
                let text = |verb: &str, l: &Option<String>| match l {
                    Some(l) => format!("{verb} {l}"),
                    None => verb.to_owned(),
                };
                if ui
                    .add_enabled(
                        undo.is_some(),
                        egui::Button::new(text("Undo", &undo)).shortcut_text("Ctrl+Z"),
                    )
                    .clicked()
                {
                    self.send(Command::Undo);
                }
                if ui
                    .add_enabled(
                        redo.is_some(),
                        egui::Button::new(text("Redo", &redo)).shortcut_text("Ctrl+Shift+Z"),
                    )
                    .clicked()
                {
                    self.send(Command::Redo);
                }
            });
            ui.menu_button("View", |ui| {
                for mode in ViewMode::ALL {
                    ui.radio_value(&mut self.view_mode, mode, mode.label());
                }
                ui.separator();
                ui.checkbox(&mut self.grid, "Ground grid");
                ui.checkbox(&mut self.show_log, "Log panel");
                if ui
                    .add(egui::Button::new("Frame character").shortcut_text("F"))
                    .clicked()
                {
                    self.send(Command::FrameCharacter);
                }
            });
            ui.menu_button("Crowd", |ui| {
                let has_doc = self.doc.is_some();
                let busy = self.crowd.busy();
                if ui
                    .add_enabled(
                        has_doc && !busy,
                        egui::Button::new("Bake for crowd preview").shortcut_text("Ctrl+B"),
                    )
                    .on_hover_text(
                        "Polypostors, classic and NP3D impostors and rigid meshes, same views and resolution",
                    )
                    .clicked()
                {
                    self.send(Command::BakeCrowd);
                }
                if ui.add_enabled(!busy, egui::Button::new("Open baked folder…")).clicked() {
                    self.ask_path(PathPurpose::OpenCrowd);
                }
                if ui
                    .add_enabled(!busy, egui::Button::new("Open baked folder path…"))
                    .clicked()
                {
                    self.prompt = Some(PathPrompt::new(PathPurpose::OpenCrowd));
                }
                ui.separator();
                let mut open = self.crowd.open;
                if ui.checkbox(&mut open, "Show crowd preview (Tab)").changed() {
                    self.send(Command::ShowCrowd(open));
                }
            });
            ui.menu_button("Help", |ui| {
                if ui.button("Controls and about").clicked() {
                    self.show_about = true;
                }
            });
            ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
                if let Some(doc) = &self.doc {
                    ui.label(egui::RichText::new(doc.title()).strong());
                }
            });
        });
    }

    fn status_bar(&mut self, ui: &mut egui::Ui) {
        self.crowd.job_ui(ui);
        ui.horizontal(|ui| {
            if let Some(l) = &self.loading {
                ui.spinner();
                ui.label(format!(
                    "Loading {} … {:.1} s",
                    l.what,
                    l.started.elapsed().as_secs_f32()
                ));
                ui.separator();
            }
            let errors = self.log.iter().filter(|e| e.level == LogLevel::Error).count();
            let warnings = self.log.iter().filter(|e| e.level == LogLevel::Warning).count();
            if ui
                .selectable_label(self.show_log, format!("⚠ {warnings}  ⛔ {errors}"))
                .on_hover_text("Show the log")
                .clicked()
            {
                self.show_log = !self.show_log;
            }
            ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
                ui.label(format!(
                    "{:.0} FPS · {:.0} ms · cpu {:.0} ms",
                    self.timer.fps(),
                    1000.0 / self.timer.fps().max(0.1),
                    self.timer.cpu_secs * 1000.0
                ));
                ui.separator();
                ui.label(self.adapter.as_deref().unwrap_or("no GPU"));
                if let Some(t) = self.safety.written_at {
                    ui.separator();
                    ui.label(egui::RichText::new(format!("autosaved {} s ago", t.elapsed().as_secs())).weak())
                        .on_hover_text("Unsaved changes are autosaved every 30 s and offered back after a crash");
                }
            });
        });
    }

    fn timeline(&mut self, ui: &mut egui::Ui) {
        let Some(doc) = &self.doc else {
            ui.label("No character loaded.");
            return;
        };
        let clips: Vec<String> = doc.character.clips.iter().map(|c| c.name.clone()).collect();
        let duration = doc.clip_duration(self.playback.clip);
        let mut commands = Vec::new();
        ui.horizontal(|ui| {
            let selected = self
                .playback
                .clip
                .and_then(|i| clips.get(i))
                .cloned()
                .unwrap_or_else(|| "(rest pose)".into());
            egui::ComboBox::from_label("Clip")
                .selected_text(selected)
                .show_ui(ui, |ui| {
                    if ui
                        .selectable_label(self.playback.clip.is_none(), "(rest pose)")
                        .clicked()
                    {
                        commands.push(Command::SelectClip(None));
                    }
                    for (i, name) in clips.iter().enumerate() {
                        if ui.selectable_label(self.playback.clip == Some(i), name).clicked() {
                            commands.push(Command::SelectClip(Some(i)));
                        }
                    }
                });
            ui.separator();
            let label = if self.playback.playing { "⏸ Pause" } else { "▶ Play" };
            if ui.button(label).on_hover_text("Space").clicked() {
                commands.push(Command::SetPlaying(!self.playback.playing));
            }
            if ui.button("⏮").on_hover_text("Previous frame (Left arrow)").clicked() {
                commands.push(Command::StepFrames(-1));
            }
            if ui.button("⏭").on_hover_text("Next frame (Right arrow)").clicked() {
                commands.push(Command::StepFrames(1));
            }
            let mut t = self.playback.time_secs;
            let width = (ui.available_width() - 420.0).max(120.0);
            ui.spacing_mut().slider_width = width;
            let slider = ui.add_enabled(
                duration > 0.0,
                egui::Slider::new(&mut t, 0.0..=duration.max(1e-3))
                    .show_value(false)
                    .text("Time"),
            );
            if slider.changed() {
                commands.push(Command::SetPlaying(false));
                commands.push(Command::Seek(t));
            }
            ui.monospace(format!(
                "{:6.3} / {:.3} s  frame {:>3}",
                self.playback.time_secs,
                duration,
                (self.playback.time_secs * TIMELINE_FPS).round() as i32
            ));
            let mut speed = self.playback.speed;
            egui::ComboBox::from_label("Speed")
                .selected_text(format!("{speed}×"))
                .width(60.0)
                .show_ui(ui, |ui| {
                    for s in [0.1f32, 0.25, 0.5, 1.0, 2.0] {
                        ui.selectable_value(&mut speed, s, format!("{s}×"));
                    }
                });
            if speed != self.playback.speed {
                commands.push(Command::SetSpeed(speed));
            }
        });
        self.commands.extend(commands);
    }

    fn side_panel(&mut self, ui: &mut egui::Ui) {
        let Some(doc) = &self.doc else {
            ui.heading("No character");
            ui.label("Open a project, or drop a .glb/.gltf here.");
            return;
        };
        let c = doc.character.clone();
        let s = doc.summary.clone();
        ui.heading(&s.name);
        ui.label(
            egui::RichText::new(doc.character_path.display().to_string())
                .small()
                .weak(),
        );
        if let Some(f) = &doc.project_file {
            ui.label(egui::RichText::new(format!("project: {}", f.display())).small().weak());
        } else {
            ui.label(egui::RichText::new("project: not saved yet").small().weak());
        }
        ui.separator();
        egui::Grid::new("summary").num_columns(2).striped(true).show(ui, |ui| {
            for (k, v) in [
                ("Vertices", s.vertices.to_string()),
                ("Triangles", s.triangles.to_string()),
                ("Joints", s.joints.to_string()),
                ("Skeleton nodes", s.nodes.to_string()),
                ("Materials", s.materials.to_string()),
                ("Clips", s.clips.len().to_string()),
                ("Textures", s.textures.len().to_string()),
                ("Warnings", s.warnings.len().to_string()),
            ] {
                ui.label(k);
                ui.label(v);
                ui.end_row();
            }
            ui.label("Height");
            ui.label(format!("{:.2} m", s.bounds_max[1] - s.bounds_min[1]));
            ui.end_row();
        });
        ui.separator();
        let mut select = None;
        egui::CollapsingHeader::new("Clips").default_open(true).show(ui, |ui| {
            for (i, clip) in s.clips.iter().enumerate() {
                let text = format!("{}  ({:.2} s)", clip.name, clip.duration_secs);
                if ui.selectable_label(self.playback.clip == Some(i), text).clicked() {
                    select = Some(i);
                }
            }
            if s.clips.is_empty() {
                ui.label("(no clips)");
            }
        });
        egui::CollapsingHeader::new("Joints")
            .default_open(false)
            .show(ui, |ui| {
                egui::ScrollArea::vertical()
                    .max_height(220.0)
                    .id_salt("joints")
                    .show(ui, |ui| {
                        for (i, n) in c.skeleton.nodes.iter().enumerate() {
                            let mut depth = 0;
                            let mut at = n.parent;
                            while let Some(p) = at {
                                depth += 1;
                                at = c.skeleton.nodes.get(p).and_then(|x| x.parent);
                            }
                            let text = format!(
                                "{}{}{}",
                                "  ".repeat(depth),
                                n.name,
                                if n.is_joint { "" } else { "  (helper)" }
                            );
                            ui.label(egui::RichText::new(text).monospace().small())
                                .on_hover_text(format!("node {i}"));
                        }
                    });
            });
        egui::CollapsingHeader::new("Textures")
            .default_open(true)
            .show(ui, |ui| {
                for t in &s.textures {
                    ui.label(format!("{}  {}×{}", t.name, t.width, t.height));
                }
                if let Some(tex) = c.textures.first() {
                    let generation = doc.generation;
                    if self.texture_preview.as_ref().is_none_or(|(g, _)| *g != generation) {
                        let image = egui::ColorImage::from_rgba_unmultiplied(
                            [tex.width as usize, tex.height as usize],
                            &tex.rgba8,
                        );
                        let handle = ui
                            .ctx()
                            .load_texture("texture preview", image, egui::TextureOptions::LINEAR);
                        self.texture_preview = Some((generation, handle));
                    }
                    if let Some((_, handle)) = &self.texture_preview {
                        let w = ui.available_width().min(240.0);
                        let h = w * tex.height as f32 / tex.width.max(1) as f32;
                        ui.image((handle.id(), egui::vec2(w, h)));
                    }
                }
            });
        if let Some(i) = select {
            self.send(Command::SelectClip(Some(i)));
        }
    }

    fn log_panel(&mut self, ui: &mut egui::Ui) {
        ui.horizontal(|ui| {
            ui.strong("Log");
            if ui.small_button("Clear").clicked() {
                self.log.clear();
            }
        });
        egui::ScrollArea::vertical()
            .stick_to_bottom(true)
            .auto_shrink([false, false])
            .show(ui, |ui| {
                for e in &self.log {
                    let (icon, color) = match e.level {
                        LogLevel::Info => ("ℹ", ui.visuals().text_color()),
                        LogLevel::Warning => ("⚠", ui.visuals().warn_fg_color),
                        LogLevel::Error => ("⛔", ui.visuals().error_fg_color),
                    };
                    ui.label(egui::RichText::new(format!("{icon} {}", e.text)).color(color));
                }
            });
    }

    fn viewport(&mut self, ui: &mut egui::Ui) {
        let rect = ui.available_rect_before_wrap();
        let response = ui.allocate_rect(rect, egui::Sense::click_and_drag());
        self.viewport_rect = rect;
        let painting = self.tab == SideTab::Segment && self.doc.is_some();
        if painting {
            let doc = self.doc.as_mut().unwrap();
            let pose = Pose::sample_index(&doc.character, self.playback.clip, self.playback.time_secs);
            let m = self
                .camera
                .camera()
                .clip_from_world(rect.width() / rect.height().max(1.0));
            self.segment.viewport_input(ui, &response, doc, m, &pose);
        }
        self.camera.handle_input(ui, &response, !painting);
        if response.double_clicked() && !painting {
            self.send(Command::FrameCharacter);
        }
        let Some(doc) = &self.doc else {
            let text = if self.loading.is_some() {
                "Loading…"
            } else {
                "Drop a .glb/.gltf here, or use File > New from glTF"
            };
            ui.painter().text(
                rect.center(),
                egui::Align2::CENTER_CENTER,
                text,
                egui::FontId::proportional(18.0),
                ui.visuals().weak_text_color(),
            );
            return;
        };
        if self.adapter.is_some() {
            let pose = Pose::sample_index(&doc.character, self.playback.clip, self.playback.time_secs);
            let ppp = ui.ctx().pixels_per_point();
            let (generation, character, mode) = if painting {
                let (g, c) = self.segment.display(doc);
                let mode = if self.segment.isolate {
                    self.view_mode
                } else {
                    ViewMode::Lit
                };
                (g, c, mode)
            } else {
                (doc.generation, doc.character.clone(), self.view_mode)
            };
            let callback = ViewportCallback {
                character,
                generation,
                pose: Arc::new(pose),
                camera: self.camera.camera(),
                size_px: [
                    (rect.width() * ppp).round() as u32,
                    (rect.height() * ppp).round() as u32,
                ],
                mode,
                grid: self.grid,
            };
            ui.painter()
                .add(egui_wgpu::Callback::new_paint_callback(rect, callback));
        }
        if painting {
            self.segment.overlay(ui, rect, doc);
        }
        // Overlay: view mode, grid, frame button; controls hint.
        let overlay = egui::Rect::from_min_size(rect.min + egui::vec2(8.0, 8.0), egui::vec2(rect.width() - 16.0, 28.0));
        let mut child = ui.new_child(
            egui::UiBuilder::new()
                .max_rect(overlay)
                .layout(egui::Layout::left_to_right(egui::Align::Center)),
        );
        egui::ComboBox::from_id_salt("view mode")
            .selected_text(self.view_mode.label())
            .width(80.0)
            .show_ui(&mut child, |ui| {
                for mode in ViewMode::ALL {
                    ui.selectable_value(&mut self.view_mode, mode, mode.label());
                }
            });
        child.checkbox(&mut self.grid, "Grid");
        if child.button("Frame (F)").clicked() {
            self.send(Command::FrameCharacter);
        }
        ui.painter().text(
            rect.left_bottom() + egui::vec2(8.0, -8.0),
            egui::Align2::LEFT_BOTTOM,
            if painting {
                "Paint: left drag · Orbit: middle drag · Pan: right drag · Zoom: wheel · Radius: [ ]"
            } else {
                "Orbit: left/middle drag · Pan: shift+middle or right drag · Zoom: wheel · Space: play/pause"
            },
            egui::FontId::proportional(12.0),
            egui::Color32::from_gray(150),
        );
    }

    /// The recovery prompt and the unsaved-changes prompts (closing, replacing the document).
    fn safety_dialogs(&mut self, ctx: &egui::Context) {
        if let Some((path, _, when)) = self.safety.recovery.clone() {
            let age = when
                .elapsed()
                .map_or("earlier".into(), |d| format!("{} s ago", d.as_secs()));
            let mut answer = None;
            super::modal(ctx, "recovery prompt").show(ctx, |ui| {
                ui.set_max_width(520.0);
                ui.heading("Recover unsaved changes?");
                ui.add_space(6.0);
                ui.label(format!(
                    "The editor closed without saving this project. An autosave from {age} holds changes the project file does not have:\n{}",
                    path.display()
                ));
                ui.add_space(8.0);
                ui.horizontal(|ui| {
                    if ui.button("Recover").clicked() {
                        answer = Some(true);
                    }
                    if ui.button("Discard autosave").clicked() {
                        answer = Some(false);
                    }
                });
            });
            match answer {
                Some(true) => {
                    if let (Some(doc), Some((_, project, _))) = (&mut self.doc, self.safety.recovery.take()) {
                        doc.history.record("Recover autosave", doc.project.clone());
                        doc.restore(project);
                        self.info(format!("recovered unsaved changes from {}", path.display()));
                    }
                }
                Some(false) => {
                    self.safety.recovery = None;
                    let _ = std::fs::remove_file(&path);
                    self.info(format!("discarded the autosave {}", path.display()));
                }
                None => {}
            }
        }
        if self.safety.close_prompt {
            match self.unsaved_prompt(ctx, "close prompt", "Save changes before closing?") {
                Some(UnsavedAnswer::Save) => {
                    self.safety.close_prompt = false;
                    self.safety.close_after_save = true;
                    self.send(Command::Save);
                }
                Some(UnsavedAnswer::Discard) => {
                    self.safety.close_prompt = false;
                    if let Some(doc) = &self.doc {
                        self.safety.clear(doc, self.options.recovery_dir.as_deref());
                    }
                    self.safety.allow_close = true;
                    self.closing = true;
                }
                Some(UnsavedAnswer::Cancel) => {
                    self.safety.close_prompt = false;
                    self.safety.close_after_save = false;
                }
                None => {}
            }
        } else if self.safety.replace_prompt.is_some() {
            let heading = match &self.safety.replace_prompt {
                Some(Command::NewFromGltf(_)) => "Save changes before starting a new project?",
                _ => "Save changes before opening another project?",
            };
            match self.unsaved_prompt(ctx, "replace prompt", heading) {
                Some(UnsavedAnswer::Save) => {
                    self.safety.replace_after_save = self.safety.replace_prompt.take();
                    self.send(Command::Save);
                }
                Some(UnsavedAnswer::Discard) => {
                    if let Some(doc) = &self.doc {
                        self.safety.clear(doc, self.options.recovery_dir.as_deref());
                    }
                    if let Some(next) = self.safety.replace_prompt.take() {
                        self.safety.replace_confirmed = true;
                        self.send(next);
                    }
                }
                Some(UnsavedAnswer::Cancel) => self.safety.replace_prompt = None,
                None => {}
            }
        }
    }

    /// The unsaved-changes prompt (closing, or replacing the document): Save, Don't save or
    /// Cancel (also Escape); `None` while unanswered.
    fn unsaved_prompt(&mut self, ctx: &egui::Context, id: &'static str, heading: &str) -> Option<UnsavedAnswer> {
        let name = self.doc.as_ref().map_or(String::new(), |d| {
            if d.project.name.is_empty() {
                "This project".to_owned()
            } else {
                format!("Project “{}”", d.project.name)
            }
        });
        let mut answer = None;
        super::modal(ctx, id).show(ctx, |ui| {
            ui.set_max_width(480.0);
            ui.heading(heading);
            ui.add_space(6.0);
            ui.label(format!("{name} has unsaved changes."));
            ui.add_space(8.0);
            ui.horizontal(|ui| {
                if ui.button("Save").clicked() {
                    answer = Some(UnsavedAnswer::Save);
                }
                if ui.button("Don't save").clicked() {
                    answer = Some(UnsavedAnswer::Discard);
                }
                if ui.button("Cancel").clicked() || ui.input(|i| i.key_pressed(egui::Key::Escape)) {
                    answer = Some(UnsavedAnswer::Cancel);
                }
            });
        });
        answer
    }

    fn dialogs(&mut self, ctx: &egui::Context) {
        if let Some(message) = self.error.clone() {
            let modal = super::modal(ctx, "error dialog").show(ctx, |ui| {
                ui.set_max_width(520.0);
                ui.heading("Something went wrong");
                ui.add_space(6.0);
                ui.label(&message);
                ui.add_space(6.0);
                if self.doc.is_some() {
                    ui.label(egui::RichText::new("The open project is unchanged.").weak());
                }
                ui.add_space(8.0);
                ui.button("OK").clicked()
            });
            if modal.inner || modal.should_close() {
                self.error = None;
            }
        }
        let mut submit = None;
        let mut cancel = false;
        if let Some(prompt) = &mut self.prompt {
            super::modal(ctx, "path prompt").show(ctx, |ui| {
                ui.set_min_width(520.0);
                ui.heading(prompt.purpose.title());
                let edit = ui.add(
                    egui::TextEdit::singleline(&mut prompt.text)
                        .hint_text(prompt.purpose.hint())
                        .desired_width(500.0),
                );
                if !prompt.focused {
                    edit.request_focus();
                    prompt.focused = true;
                }
                let enter = (edit.has_focus() || edit.lost_focus()) && ui.input(|i| i.key_pressed(egui::Key::Enter));
                ui.horizontal(|ui| {
                    if ui.button("OK").clicked() || enter {
                        submit = Some((prompt.purpose, prompt.text.trim().to_string()));
                    }
                    if ui.button("Cancel").clicked() || ui.input(|i| i.key_pressed(egui::Key::Escape)) {
                        cancel = true;
                    }
                });
            });
        }
        if let Some((purpose, text)) = submit {
            self.prompt = None;
            if !text.is_empty() {
                let path = expand_home(&text);
                self.send(purpose.command(path));
            }
        }
        if cancel {
            if self.prompt.as_ref().is_some_and(|p| p.purpose == PathPurpose::SaveAs) {
                self.safety.close_after_save = false;
                self.safety.replace_after_save = None;
            }
            self.prompt = None;
        }
        if self.show_about {
            egui::Window::new("Polypostor Studio")
                .open(&mut self.show_about)
                .collapsible(false)
                .show(ctx, |ui| {
                    ui.label(format!("Version {}", env!("CARGO_PKG_VERSION")));
                    ui.label("Turns skinned, animated glTF characters into crowd level-of-detail assets.");
                    ui.separator();
                    egui::Grid::new("controls").num_columns(2).show(ui, |ui| {
                        for (k, v) in [
                            ("Orbit", "left drag, or middle drag"),
                            ("Pan", "shift + middle drag, or right drag"),
                            ("Zoom", "mouse wheel"),
                            ("Frame character", "F, or double-click"),
                            ("Play / pause", "Space"),
                            ("Step frame", "Left / Right arrow"),
                            ("Go to start", "Home"),
                            ("New / Open / Save", "Ctrl+N / Ctrl+O / Ctrl+S"),
                        ] {
                            ui.label(k);
                            ui.label(v);
                            ui.end_row();
                        }
                    });
                });
        }
    }
}

/// Where the editor bakes a document: `crowd.pack` beside its project, or a temporary folder
/// for a project never saved.
fn bake_dir(doc: &Document) -> PathBuf {
    match &doc.project_file {
        Some(f) => f.parent().map(Path::to_owned).unwrap_or_default().join("crowd.pack"),
        None => temp_bake_dir(std::process::id()),
    }
}

/// Where an editor process bakes a project never saved; removed when the editor exits, and
/// by the next editor if that one was killed.
fn temp_bake_dir(pid: u32) -> PathBuf {
    std::env::temp_dir().join(format!("polypostor-crowd-{pid}.pack"))
}

/// Removes the temporary bake folders of editors that are no longer running.
fn remove_stale_temp_bakes() {
    let Ok(entries) = std::fs::read_dir(std::env::temp_dir()) else {
        return;
    };
    for e in entries.filter_map(Result::ok) {
        let name = e.file_name().to_string_lossy().into_owned();
        let pid = name
            .strip_prefix("polypostor-crowd-")
            .and_then(|r| r.strip_suffix(".pack"))
            .and_then(|p| p.parse::<u32>().ok());
        if let Some(pid) = pid
            && pid != std::process::id()
            && !polypostor::safe_fs::process_alive(pid)
            && e.file_type().is_ok_and(|t| t.is_dir())
        {
            let _ = std::fs::remove_dir_all(e.path());
        }
    }
}

fn expand_home(text: &str) -> PathBuf {
    if let Some(rest) = text.strip_prefix("~/") {
        if let Some(home) = std::env::var_os("HOME") {
            return PathBuf::from(home).join(rest);
        }
    }
    PathBuf::from(text)
}

fn is_gltf(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("glb") || e.eq_ignore_ascii_case("gltf"))
}

/// A background load: a project and its character, or a glTF as a new project.
enum LoadRequest {
    Project(PathBuf),
    Gltf(PathBuf),
}

impl LoadRequest {
    fn describe(&self) -> String {
        match self {
            LoadRequest::Project(p) | LoadRequest::Gltf(p) => p.display().to_string(),
        }
    }

    fn run(self) -> Result<Loaded, String> {
        match self {
            LoadRequest::Gltf(path) => {
                let character =
                    polypostor::import_path(&path).map_err(|e| format!("Cannot import {}:\n{e}", path.display()))?;
                let dir = path.parent().map(Path::to_owned).unwrap_or_default();
                let name = path
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_default();
                let project = Project::new_for_character(&name, &path, &dir);
                let character_path = std::fs::canonicalize(&path).unwrap_or(path);
                Ok(Loaded {
                    project,
                    project_file: None,
                    character_path,
                    character,
                    from_gltf: true,
                })
            }
            LoadRequest::Project(path) => {
                let (project, file) = Project::load(&path).map_err(|e| e.to_string())?;
                let character_path = project.character_path(&file);
                let character_path = std::fs::canonicalize(&character_path).unwrap_or(character_path);
                let character = polypostor::import_path(&character_path).map_err(|e| {
                    format!(
                        "Project {} refers to a character that cannot be imported:\n{e}",
                        file.display()
                    )
                })?;
                Ok(Loaded {
                    project,
                    project_file: Some(file),
                    character_path,
                    character,
                    from_gltf: false,
                })
            }
        }
    }
}

/// A docked panel's frame without a fill: the window is cleared to the panel colour instead
/// ([`eframe::App::clear_color`]). On a software rasteriser shading the panels' background
/// quads cost about 20 ms a frame at 1440×900, as much as all the rest of the UI; a clear
/// costs next to nothing.
fn panel_frame(style: &egui::Style) -> egui::Frame {
    egui::Frame::side_top_panel(style).fill(egui::Color32::TRANSPARENT)
}

impl eframe::App for EditorApp {
    /// The temporary bake of a never-saved project goes with the editor.
    fn on_exit(&mut self) {
        let _ = std::fs::remove_dir_all(temp_bake_dir(std::process::id()));
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
        self.dropped_files(&ctx);
        self.shortcuts(&ctx);
        self.apply_commands(&ctx);
        self.autosave(false);
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
        egui::Panel::left("character")
            .frame(panel_frame(ui.style()))
            .resizable(true)
            .default_size(300.0)
            .show(ui, |ui| {
                ui.horizontal(|ui| {
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
        if !self.crowd.open && self.tab == SideTab::Views && self.views.selected.is_some() && self.doc.is_some() {
            egui::Panel::right("fit inspector")
                .frame(panel_frame(ui.style()))
                .resizable(true)
                .default_size(470.0)
                .show(ui, |ui| {
                    egui::ScrollArea::vertical().id_salt("inspector scroll").show(ui, |ui| {
                        let doc = self.doc.as_mut().unwrap();
                        self.views.inspector_panel(ui, doc, dt);
                    });
                });
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
