//! The crowd preview: bakes (or opens) a folder with every representation, then runs a live
//! crowd of up to 100,000 characters drawn with any one representation or the three-level
//! mix, with the camera in orbit or fly mode and live statistics.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, channel};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use eframe::egui_wgpu::{self, wgpu};
use glam::Vec3;

use polypostor::crowd::lod::{Level, LodDistances, LodPolicy};
use polypostor::gpu::{Camera, PolypostorStyle, RenderTarget};
use polypostor::scene::{CrowdAssets, CrowdScene};

use super::log_entry::LogLevel;
use super::viewport::{OrbitCamera, ViewportResources};

/// Largest crowd the slider offers.
pub const MAX_CROWD: usize = 100_000;

/// What the crowd is drawn with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PreviewMode {
    Only(Level),
    Mixed,
}

impl PreviewMode {
    pub const ALL: [PreviewMode; 6] = [
        PreviewMode::Mixed,
        PreviewMode::Only(Level::Skinned),
        PreviewMode::Only(Level::Rigid),
        PreviewMode::Only(Level::Polypostor),
        PreviewMode::Only(Level::Impostor),
        PreviewMode::Only(Level::Np3d),
    ];

    pub fn label(self) -> &'static str {
        match self {
            PreviewMode::Mixed => "Three-level mix",
            PreviewMode::Only(Level::Skinned) => "Skinned meshes",
            PreviewMode::Only(Level::Rigid) => "Rigid meshes",
            PreviewMode::Only(Level::Polypostor) => "Polypostors",
            PreviewMode::Only(Level::Impostor) => "Classic impostors",
            PreviewMode::Only(Level::Np3d) => "NP3D impostors",
        }
    }
}

/// Figures the render thread reports back to the panel.
#[derive(Clone, Debug, Default)]
pub struct PreviewStats {
    pub agents: usize,
    pub visible: usize,
    pub per_level: [usize; Level::COUNT],
    pub gpu_bytes: [u64; Level::COUNT],
    pub available: [bool; Level::COUNT],
    pub simulate_ms: f64,
    pub select_ms: f64,
    pub upload_ms: f64,
    pub draw_calls: usize,
    /// Agents walking, running and standing idle.
    pub gaits: [usize; 3],
    /// Agents of each character (the opened one first, then each added one).
    pub per_kind: Vec<usize>,
    /// Visible characters not drawn last frame (the crowd thinned to keep the window
    /// answering).
    pub skipped: usize,
    pub error: Option<String>,
}

struct Job {
    what: String,
    /// The folder opens as another character of the crowd, not in place of it.
    adds_guest: bool,
    started: Instant,
    progress: Arc<Mutex<polypostor::bake::eta::Eta>>,
    cancel: Arc<AtomicBool>,
    rx: Receiver<Result<JobDone, String>>,
}

/// A finished job: the folder, its assets, and for a bake the bake kept for the next
/// incremental one with a line saying what was re-done.
type JobDone = (
    PathBuf,
    CrowdAssets,
    Option<(Arc<polypostor::bake::pipeline::Bake>, String)>,
);

/// Another baked character in the crowd preview, with its share of the agents.
pub struct Guest {
    pub folder: PathBuf,
    pub assets: Arc<CrowdAssets>,
    pub share: f32,
}

/// What the crowd panel asks of the app.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PanelAsk {
    /// A folder to add to the crowd, from the file dialog.
    Browse,
    /// A folder to add to the crowd, typed.
    TypePath,
    /// Remove the `k`-th added character.
    Remove(usize),
}

/// The preview's state (UI side).
pub struct CrowdPanel {
    pub open: bool,
    pub count: usize,
    /// Shares of agents walking, running and standing idle.
    pub behaviour: polypostor::crowd::Behaviour,
    /// How strongly each agent's body parts are tinted (0: every character alike).
    pub variation: f32,
    pub mode: PreviewMode,
    pub lod: LodDistances,
    pub paused: bool,
    pub fly: bool,
    pub camera: OrbitCamera,
    pub stats: Arc<Mutex<PreviewStats>>,
    pub assets: Option<(u64, Arc<CrowdAssets>)>,
    pub folder: Option<PathBuf>,
    /// Share of the crowd that is the opened character (against [`CrowdPanel::guests`]').
    pub own_share: f32,
    /// Other baked characters sharing the crowd.
    pub guests: Vec<Guest>,
    /// What the panel asks the app for (a folder to add, a guest to remove).
    pub asks: Option<PanelAsk>,
    next_generation: u64,
    job: Option<Job>,
    /// The generation whose full-resolution impostor sheets are being (or were) read.
    full_requested: Option<u64>,
    /// The last bake this session made, and into which folder (the next bake there only
    /// re-does what changed).
    pub last_bake: Option<(PathBuf, Arc<polypostor::bake::pipeline::Bake>)>,
    /// How the last job ended (true: its folder is open), for the app to take once.
    pub outcome: Option<bool>,
    /// What the jobs have to say, for the editor's log (drained by the app; errors also open
    /// the error dialog).
    pub messages: Vec<(LogLevel, String)>,
}

impl Default for CrowdPanel {
    fn default() -> Self {
        Self {
            open: false,
            count: 2000,
            behaviour: Default::default(),
            variation: PolypostorStyle::default().tint,
            mode: PreviewMode::Mixed,
            lod: LodDistances::default(),
            paused: false,
            fly: false,
            camera: OrbitCamera {
                target: Vec3::new(0.0, 0.0, 0.0),
                yaw_rad: 0.6,
                pitch_rad: 0.35,
                distance: 40.0,
                fov_y_rad: 50f32.to_radians(),
                scale: 1.0,
            },
            stats: Default::default(),
            assets: None,
            folder: None,
            own_share: 1.0,
            guests: Vec::new(),
            asks: None,
            next_generation: 1,
            job: None,
            full_requested: None,
            last_bake: None,
            messages: Vec::new(),
            outcome: None,
        }
    }
}

/// What a bake for the preview needs from the open document.
pub struct BakeRequest {
    pub character: Arc<polypostor::Character>,
    pub character_path: PathBuf,
    pub clip: Option<usize>,
    /// Clips after `clip` in the same whole-character pack.
    pub extra_clips: Vec<usize>,
    pub segmentation: polypostor::bake::segment::Segmentation,
    pub caps: polypostor::bake::caps::CapOverrides,
    pub overrides: polypostor::bake::overrides::BakeOverrides,
    pub out: PathBuf,
    /// The previous bake into `out`, for an incremental bake.
    pub previous: Option<Arc<polypostor::bake::pipeline::Bake>>,
    /// Views, resolution, frame rate, compression (clip and corrections are set from the
    /// fields above).
    pub options: polypostor::bake::pipeline::BakeOptions,
    pub set: polypostor::reps::RepSet,
}

impl CrowdPanel {
    /// Asks the running job to stop (the status bar's Cancel).
    pub fn cancel_job(&self) {
        if let Some(job) = &self.job {
            job.cancel.store(true, Ordering::Relaxed);
        }
    }

    pub fn busy(&self) -> bool {
        self.job.is_some()
    }

    /// Bakes every representation into `req.out` on a background thread, then opens it.
    pub fn start_bake(&mut self, req: BakeRequest) {
        if self.job.is_some() {
            return;
        }
        let (tx, rx) = channel();
        let progress = Arc::new(Mutex::new(polypostor::bake::eta::Eta::starting("starting", 1)));
        let cancel = Arc::new(AtomicBool::new(false));
        let (p, c) = (progress.clone(), cancel.clone());
        self.job = Some(Job {
            what: format!("Baking {} for the crowd", req.character.name),
            adds_guest: false,
            started: Instant::now(),
            progress,
            cancel,
            rx,
        });
        std::thread::spawn(move || {
            // Before the device: llvmpipe's render threads inherit the priority.
            super::lower_thread_priority();
            let result = (|| -> Result<JobDone, String> {
                let ctx = polypostor::gpu::GpuContext::from_env().map_err(|e| e.to_string())?;
                let options = polypostor::bake::pipeline::BakeOptions {
                    clip: req.clip,
                    extra_clips: req.extra_clips.clone(),
                    overrides: req.overrides.clone(),
                    ..req.options.clone()
                };
                let job = polypostor::job::BakeJob {
                    character: &req.character,
                    character_path: &req.character_path,
                    segmentation: &req.segmentation,
                    caps: &req.caps,
                    options: &options,
                    set: req.set,
                    out: &req.out,
                    previous: req.previous.as_deref(),
                    reuse_representations: true,
                };
                let progress = |pr: polypostor::bake::pipeline::Progress| {
                    if let Ok(mut g) = p.lock() {
                        g.update(pr.stage, pr.done, pr.total, Instant::now());
                    }
                };
                let done =
                    polypostor::job::run(&ctx, &job, &progress, &c, &|_, _| Ok(())).map_err(|e| e.to_string())?;
                let labels = req.segmentation.labels.iter().map(|&l| l as u32).collect();
                let assets = CrowdAssets::load(&req.out, Some(&req.character_path), Some(labels))?;
                let what = match done.reuse {
                    Some(r) if !r.full => format!(
                        "re-baked {} of {} views ({} parts) after the corrections; other representations kept",
                        r.views_refit, r.views, r.parts_refit
                    ),
                    _ => "baked every view and representation".to_owned(),
                };
                Ok((req.out.clone(), assets, done.bake.map(|b| (Arc::new(b), what))))
            })();
            let _ = tx.send(result);
        });
    }

    /// Opens a baked folder on a background thread.
    pub fn start_open(&mut self, folder: PathBuf, character: Option<PathBuf>) {
        let what = format!("Opening {}", folder.display());
        self.start_loading(what, false, move || {
            // The open character first; a folder baked from another character (its clip or
            // frames do not match) opens with the character it names.
            CrowdAssets::load(&folder, character.as_deref(), None)
                .or_else(|e| match character {
                    Some(_) => CrowdAssets::load(&folder, None, None).map_err(|_| e),
                    None => Err(e),
                })
                .map(|a| (folder, a, None))
        });
    }

    /// Opens another baked character (a folder, with the character its representations
    /// name) on a background thread, to share the crowd with the one open.
    pub fn start_add(&mut self, folder: PathBuf) {
        if self.guests.len() + 1 >= polypostor::crowd::MAX_SPECIES {
            self.messages.push((
                LogLevel::Error,
                format!(
                    "crowd preview: at most {} characters in one crowd",
                    polypostor::crowd::MAX_SPECIES
                ),
            ));
            return;
        }
        // The same pack twice is one character counted twice (and two rows of one name).
        let same = |f: &Path| polypostor::safe_fs::resolved(f) == polypostor::safe_fs::resolved(&folder);
        if self.folder.as_deref().is_some_and(same) || self.guests.iter().any(|g| same(&g.folder)) {
            self.messages.push((
                LogLevel::Warning,
                format!("crowd preview: {} is in the crowd already", folder.display()),
            ));
            return;
        }
        let what = format!("Adding {}", folder.display());
        self.start_loading(what, true, move || {
            CrowdAssets::load(&folder, None, None).map(|a| (folder, a, None))
        });
    }

    /// Runs `load` on a background thread as the panel's job (none when one runs already).
    fn start_loading(
        &mut self,
        what: String,
        adds_guest: bool,
        load: impl FnOnce() -> Result<JobDone, String> + Send + 'static,
    ) {
        if self.job.is_some() {
            return;
        }
        let (tx, rx) = channel();
        self.job = Some(Job {
            what,
            adds_guest,
            started: Instant::now(),
            progress: Arc::new(Mutex::new(polypostor::bake::eta::Eta::starting("loading", 1))),
            cancel: Arc::new(AtomicBool::new(false)),
            rx,
        });
        std::thread::spawn(move || {
            let _ = tx.send(load());
        });
    }

    /// Removes every added character (another project was opened: they were added beside
    /// the one left).
    pub fn clear_guests(&mut self) {
        // One still loading is dropped too (it would land in the next project's crowd).
        if self.job.as_ref().is_some_and(|j| j.adds_guest) {
            self.job = None;
        }
        if self.guests.is_empty() {
            return;
        }
        let n = self.guests.len();
        self.guests.clear();
        self.messages.push((
            LogLevel::Info,
            format!(
                "crowd preview: the {} added beside the project left {} no longer shown",
                polypostor::import::plural(n, "character"),
                if n == 1 { "is" } else { "are" }
            ),
        ));
        self.bump_generation();
    }

    /// Removes the `k`-th added character from the crowd.
    pub fn remove_guest(&mut self, k: usize) {
        if k < self.guests.len() {
            let g = self.guests.remove(k);
            self.messages.push((
                LogLevel::Info,
                format!("crowd preview: {} removed", g.assets.character.name),
            ));
            self.bump_generation();
        }
    }

    /// A new crowd scene on the next frame (characters added or removed).
    /// Forgets the crowd of the project left (another one is opened): its characters, the
    /// pack shown and the bake an incremental re-bake would start from. The preview showed
    /// the previous project's crowd, and its header named that project's pack.
    pub fn forget_project(&mut self) {
        self.clear_guests();
        if self.assets.is_some() {
            self.messages.push((
                LogLevel::Info,
                "crowd preview: the project left's crowd is no longer shown (Crowd > Bake for crowd preview)".into(),
            ));
        }
        self.assets = None;
        self.folder = None;
        self.last_bake = None;
        self.full_requested = None;
        // The new character in the viewport, not an empty preview.
        self.open = false;
    }

    fn bump_generation(&mut self) {
        if let Some((g, _)) = &mut self.assets {
            *g = self.next_generation;
            self.next_generation += 1;
        }
    }

    /// Picks up a finished job.
    pub fn poll(&mut self) {
        let Some(job) = &self.job else { return };
        match job.rx.try_recv() {
            // Cancelled (by the user, or because another project was opened) but finished
            // anyway: what it wrote stays on disk, nothing of it is shown (it filled the next
            // project's crowd preview).
            Ok(Ok((folder, _, _))) if job.cancel.load(Ordering::Relaxed) => {
                self.messages.push((
                    LogLevel::Info,
                    format!(
                        "cancelled as it finished: {} is on disk but not opened",
                        folder.display()
                    ),
                ));
                self.job = None;
                self.outcome = Some(false);
            }
            Ok(Ok((folder, assets, _))) if job.adds_guest => {
                self.messages.push((
                    LogLevel::Info,
                    format!(
                        "crowd preview: {} ({}) added ({:.1} s)",
                        assets.character.name,
                        folder.display(),
                        job.started.elapsed().as_secs_f64()
                    ),
                ));
                self.guests.push(Guest {
                    folder,
                    assets: Arc::new(assets),
                    share: 1.0,
                });
                let heights: Vec<f32> = self
                    .assets
                    .iter()
                    .map(|(_, a)| a.size.height)
                    .chain(self.guests.iter().map(|g| g.assets.size.height))
                    .collect();
                if let Some(note) = polypostor::crowd::size_spread_note(&heights) {
                    self.messages
                        .push((LogLevel::Warning, format!("crowd preview: {note}")));
                }
                self.bump_generation();
                self.job = None;
            }
            Ok(Ok((folder, assets, bake))) => {
                if let Some((b, what)) = bake {
                    self.messages.push((
                        LogLevel::Info,
                        format!("{what} in {:.1} s", job.started.elapsed().as_secs_f64()),
                    ));
                    // Corrections the bake could not apply are said, never dropped silently
                    // (the Views tab shows them too, from the report).
                    for line in b.dropped_corrections().lines() {
                        self.messages.push((LogLevel::Warning, line));
                    }
                    self.last_bake = Some((folder.clone(), b));
                }
                self.messages.push((
                    LogLevel::Info,
                    format!(
                        "crowd preview: {} ({:.1} s)",
                        folder.display(),
                        job.started.elapsed().as_secs_f64()
                    ),
                ));
                self.lod.texels = assets.resolution() as f32;
                // The view follows the character's real size: a mouse is looked at from
                // centimetres, a giant from hundreds of metres (the same picture).
                let s = assets.size.scale();
                let first = self.assets.is_none();
                let rescaled = self
                    .assets
                    .as_ref()
                    .is_some_and(|(_, a)| (a.size.scale() / s - 1.0).abs() > 0.01);
                if first || rescaled {
                    self.camera.distance = 40.0 * s;
                    self.camera.scale = s;
                    self.camera.target = Vec3::new(0.0, assets.size.ground_y, 0.0);
                }
                self.assets = Some((self.next_generation, Arc::new(assets)));
                self.next_generation += 1;
                // A guest that is this very pack (added while another project was open)
                // leaves the guests: it is the opened character now.
                let this = polypostor::safe_fs::resolved(&folder);
                let before = self.guests.len();
                self.guests.retain(|g| polypostor::safe_fs::resolved(&g.folder) != this);
                if self.guests.len() < before {
                    self.messages.push((
                        LogLevel::Info,
                        format!(
                            "crowd preview: {} is the opened character now, not an added one",
                            folder.display()
                        ),
                    ));
                }
                self.folder = Some(folder);
                self.open = true;
                self.job = None;
                self.outcome = Some(true);
            }
            Ok(Err(e)) => {
                self.outcome = Some(false);
                // A cancel is not an error: it is logged, no dialog.
                let cancelled = job.cancel.load(Ordering::Relaxed);
                self.messages.push(if cancelled {
                    (LogLevel::Info, "bake cancelled: nothing was written".into())
                } else {
                    (LogLevel::Error, format!("crowd preview: {e}"))
                });
                self.job = None;
            }
            Err(std::sync::mpsc::TryRecvError::Empty) => {}
            Err(std::sync::mpsc::TryRecvError::Disconnected) => {
                self.messages
                    .push((LogLevel::Error, "crowd preview: the background job stopped".into()));
                self.job = None;
                self.outcome = Some(false);
            }
        }
    }

    /// Progress line and a cancel button, while a job runs.
    pub fn job_ui(&mut self, ui: &mut egui::Ui) {
        let Some(job) = &self.job else { return };
        let eta = job.progress.lock().map(|g| g.clone()).unwrap_or_default();
        let (done, total) = eta.counts();
        // No spinner: it redraws the window every frame, which on a software rasteriser takes
        // the CPU from the bake; the app redraws a few times a second while a job runs.
        ui.horizontal(|ui| {
            // Cancel first: on a narrow window the row is cut on the right, never the button.
            if ui.button("Cancel").clicked() {
                self.cancel_job();
            }
            ui.label(format!("{} — {}", job.what, eta.stage()));
            ui.add(
                egui::ProgressBar::new(done as f32 / total.max(1) as f32)
                    .desired_width(160.0)
                    .text(format!("{done}/{total}")),
            );
            let left = eta.describe(Instant::now());
            ui.label(format!(
                "{}{}",
                polypostor::bake::eta::human(job.started.elapsed()),
                if left.is_empty() {
                    String::new()
                } else {
                    format!(" · {left}")
                }
            ))
            .on_hover_text(
                "Time so far, and what is left of this stage at its own pace so far; writing \
                 the pack and any other representations come after it.",
            );
        });
    }

    fn policy(&self) -> LodPolicy {
        match self.mode {
            PreviewMode::Only(l) => LodPolicy::Only(l),
            PreviewMode::Mixed => LodPolicy::Mixed(self.lod),
        }
    }

    /// The controls and statistics (side panel).
    pub fn controls(&mut self, ui: &mut egui::Ui, ui_fps: f32) {
        ui.heading("Crowd preview");
        let Some((_, assets)) = &self.assets else {
            ui.label("Bake the open character for the crowd (Crowd > Bake for crowd preview), or open a baked folder.");
            return;
        };
        ui.label(
            egui::RichText::new(format!(
                "{} · {}",
                assets.character.name,
                self.folder
                    .as_ref()
                    .map(|f| f.display().to_string())
                    .unwrap_or_default()
            ))
            .small()
            .weak(),
        );
        let stats = self.stats.lock().map(|s| s.clone()).unwrap_or_default();
        ui.add(
            egui::Slider::new(&mut self.count, 1..=MAX_CROWD)
                .logarithmic(true)
                .text("characters"),
        );
        ui.horizontal(|ui| {
            for n in [2_000, 20_000, 100_000] {
                if ui.button(format!("{}k", n / 1000)).clicked() {
                    self.count = n;
                }
            }
        });
        // Several baked characters in one crowd, in chosen shares.
        let agents = |k: usize| stats.per_kind.get(k).copied().unwrap_or(0);
        egui::Grid::new("crowd characters")
            .num_columns(4)
            .striped(true)
            .show(ui, |ui| {
                ui.strong("character");
                ui.strong("share");
                ui.strong("agents");
                ui.label("");
                ui.end_row();
                ui.label(assets.character.name.as_str());
                ui.add_enabled(
                    !self.guests.is_empty(),
                    egui::Slider::new(&mut self.own_share, 0.0..=1.0).show_value(false),
                );
                ui.label(agents(0).to_string());
                ui.label("");
                ui.end_row();
                // Two characters of one name (two bakes of one file) are told apart by folder.
                let names: Vec<&str> = std::iter::once(assets.character.name.as_str())
                    .chain(self.guests.iter().map(|g| g.assets.character.name.as_str()))
                    .collect();
                let labels: Vec<String> = self
                    .guests
                    .iter()
                    .map(|g| {
                        let name = g.assets.character.name.as_str();
                        if names.iter().filter(|&&n| n == name).count() > 1 {
                            let folder = g.folder.file_name().map(|f| f.to_string_lossy().into_owned());
                            format!("{name} ({})", folder.unwrap_or_default())
                        } else {
                            name.to_string()
                        }
                    })
                    .collect();
                for (k, (g, label)) in self.guests.iter_mut().zip(labels).enumerate() {
                    ui.label(label).on_hover_text(g.folder.display().to_string());
                    ui.add(egui::Slider::new(&mut g.share, 0.0..=1.0).show_value(false));
                    ui.label(agents(k + 1).to_string());
                    if ui.small_button("✖").on_hover_text("Remove from the crowd").clicked() {
                        self.asks = Some(PanelAsk::Remove(k));
                    }
                    ui.end_row();
                }
            });
        ui.horizontal(|ui| {
            let room = self.guests.len() + 1 < polypostor::crowd::MAX_SPECIES && self.job.is_none();
            if ui
                .add_enabled(room, egui::Button::new("Add character…"))
                .on_hover_text("Another baked folder (any character, any size) shares this crowd")
                .clicked()
            {
                self.asks = Some(PanelAsk::Browse);
            }
            if ui.add_enabled(room, egui::Button::new("Add by path…")).clicked() {
                self.asks = Some(PanelAsk::TypePath);
            }
        });
        egui::ComboBox::from_label("representation")
            .selected_text(self.mode.label())
            .show_ui(ui, |ui| {
                for m in PreviewMode::ALL {
                    let ok = match m {
                        PreviewMode::Only(l) => stats.available[l as usize],
                        PreviewMode::Mixed => true,
                    };
                    ui.add_enabled_ui(ok, |ui| ui.selectable_value(&mut self.mode, m, m.label()));
                }
            });
        ui.add_enabled_ui(self.mode == PreviewMode::Mixed, |ui| {
            ui.label("LOD switch points (screen pixels per baked texel):");
            ui.add(egui::Slider::new(&mut self.lod.mesh_above, 0.25..=4.0).text("mesh above"));
            ui.add(egui::Slider::new(&mut self.lod.impostor_below, 0.05..=1.0).text("impostor below"));
            ui.add(egui::Slider::new(&mut self.lod.hysteresis, 0.0..=0.5).text("hysteresis"));
            self.lod.impostor_below = self.lod.impostor_below.min(self.lod.mesh_above);
        });
        // What the agents do: the packs' clips by measured ground speed. A share is offered
        // where any character of the crowd has the clips for it (the added ones too: a guest
        // that runs beside a host that only walks used a share no slider could change).
        let all_gaits: Vec<polypostor::crowd::Gaits> = std::iter::once(assets)
            .chain(self.guests.iter().map(|g| &g.assets))
            .map(|a| polypostor::crowd::Gaits::new(&a.timeline.spans, a.timeline.fps))
            .collect();
        let (walk, run, idle) = (
            all_gaits.iter().any(|g| g.walk.is_some()),
            all_gaits.iter().any(|g| g.run.is_some()),
            all_gaits.iter().any(|g| !g.idle.is_empty()),
        );
        let gaits = &all_gaits[0];
        ui.label("Behaviour (shares of the crowd):");
        let b = &mut self.behaviour;
        ui.add_enabled(walk, egui::Slider::new(&mut b.walk, 0.0..=1.0).text("walking"));
        ui.add_enabled(run, egui::Slider::new(&mut b.run, 0.0..=1.0).text("running"))
            .on_disabled_hover_text("no character of the crowd has a clip moving clearly faster than its walk");
        ui.add_enabled(idle, egui::Slider::new(&mut b.idle, 0.0..=1.0).text("standing"))
            .on_disabled_hover_text("no character of the crowd has a clip that stands still");
        ui.add(egui::Slider::new(&mut self.variation, 0.0..=1.0).text("appearance variation"))
            .on_hover_text("How strongly each character's body parts are tinted (0: all alike)");
        ui.checkbox(&mut self.paused, "Paused (P)");
        ui.horizontal(|ui| {
            ui.label("Camera:");
            ui.radio_value(&mut self.fly, false, "orbit");
            ui.radio_value(&mut self.fly, true, "fly (WASD, Q/E)");
        });
        ui.separator();
        ui.strong("Statistics");
        egui::Grid::new("crowd stats")
            .num_columns(2)
            .striped(true)
            .show(ui, |ui| {
                let row = |ui: &mut egui::Ui, k: &str, v: String| {
                    ui.label(k);
                    ui.label(v);
                    ui.end_row();
                };
                row(ui, "frame rate", format!("{ui_fps:.1} FPS"));
                row(
                    ui,
                    "CPU per frame",
                    format!(
                        "{:.2} ms (sim {:.2}, select {:.2}, upload {:.2})",
                        stats.simulate_ms + stats.select_ms + stats.upload_ms,
                        stats.simulate_ms,
                        stats.select_ms,
                        stats.upload_ms
                    ),
                );
                row(ui, "draw calls", stats.draw_calls.to_string());
                row(ui, "agents / visible", format!("{} / {}", stats.agents, stats.visible));

                // The size the crowd follows (measured over the clip, in the file's metres);
                // in a mix each character keeps its own spacing (a pair the mean of theirs).
                let p = assets.crowd_params(stats.agents);
                row(
                    ui,
                    "character",
                    format!(
                        "{} tall, {} long (×{} a 1.8 m person)",
                        metres(assets.size.height),
                        metres(assets.size.length),
                        ratio(p.scale())
                    ),
                );
                for g in &self.guests {
                    let a = &g.assets;
                    let gaits = polypostor::crowd::Gaits::new(&a.timeline.spans, a.timeline.fps);
                    let speed = |c: Option<usize>| {
                        c.map_or("none".to_string(), |c| {
                            format!("{}/s", metres(a.timeline.spans[c].ground_speed))
                        })
                    };
                    row(
                        ui,
                        a.character.name.as_str(),
                        format!(
                            "{} tall, {} long; {} clip{} (walk {}, run {}, {} standing)",
                            metres(a.size.height),
                            metres(a.size.length),
                            a.timeline.spans.len(),
                            if a.timeline.spans.len() == 1 { "" } else { "s" },
                            speed(gaits.walk),
                            speed(gaits.run),
                            gaits.idle.len()
                        ),
                    );
                }
                // Speeds come from the clips (below) when the pack measured them.
                let others: Vec<String> = self
                    .guests
                    .iter()
                    .map(|g| {
                        let q = g.assets.crowd_params(1);
                        format!("{} {}", g.assets.character.name, metres(q.min_distance))
                    })
                    .collect();
                if !others.is_empty() {
                    row(
                        ui,
                        "spacing",
                        format!(
                            "{} apart; {} (a pair: the mean of theirs)",
                            metres(p.min_distance),
                            others.join(", ")
                        ),
                    );
                } else if gaits.walk.is_none() && gaits.run.is_none()
                    || assets.timeline.spans.iter().any(|c| c.ground_speed > 0.0)
                {
                    // Nobody walks (a prop, a pack of standing clips), or the clips say how
                    // fast: no speed of the crowd's own to show.
                    row(ui, "spacing", format!("{} apart", metres(p.min_distance)));
                } else {
                    row(
                        ui,
                        "spacing / speed",
                        format!(
                            "{} apart, {}–{} /s",
                            metres(p.min_distance),
                            metres(p.speed.0),
                            metres(p.speed.1)
                        ),
                    );
                }
            });
        ui.add_space(4.0);
        // Per clip: what it is used for, its measured speed, and how many agents play it
        // (with added characters: how many of the whole crowd walk, run or stand).
        let agents_heading = if self.guests.is_empty() {
            "agents"
        } else {
            "agents (whole crowd)"
        };
        egui::Grid::new("crowd clips")
            .num_columns(4)
            .striped(true)
            .show(ui, |ui| {
                ui.strong("clip");
                ui.strong("frames");
                ui.strong("ground speed");
                ui.strong(agents_heading);
                ui.end_row();
                for (i, c) in assets.timeline.spans.iter().enumerate() {
                    use polypostor::crowd::Gait;
                    let role = gaits.role(i);
                    ui.label(format!("{} ({})", c.name, role.map_or("unused", Gait::name)));
                    ui.label(c.frames.to_string());
                    ui.label(match role {
                        Some(Gait::Walk | Gait::Run) => format!("{}/s", metres(c.ground_speed)),
                        _ => "still".into(),
                    });
                    ui.label(match role {
                        None => "does not loop".to_string(),
                        Some(Gait::Idle) if gaits.idle.len() == 1 || gaits.walk.is_none() => stats.gaits[2].to_string(),
                        Some(Gait::Idle) => format!("{} standing in all", stats.gaits[2]),
                        Some(g) => stats.gaits[g as usize].to_string(),
                    });
                    ui.end_row();
                }
            });
        if stats.skipped > 0 {
            ui.add(
                egui::Label::new(
                    egui::RichText::new(format!(
                        "{} of the visible characters not drawn: frames took over {:.0} ms, so the crowd is thinned to keep the window answering (fewer characters, or a lighter representation, draws them all)",
                        stats.skipped,
                        polypostor::scene::SLOW_FRAME_SECS * 1e3
                    ))
                    .color(ui.visuals().warn_fg_color),
                )
                .wrap(),
            );
        }
        ui.add_space(4.0);
        egui::Grid::new("crowd levels")
            .num_columns(3)
            .striped(true)
            .show(ui, |ui| {
                ui.strong("representation");
                ui.strong("drawn");
                ui.strong("GPU memory");
                ui.end_row();
                for l in Level::ALL {
                    ui.label(l.name());
                    ui.label(stats.per_level[l as usize].to_string());
                    ui.label(if stats.available[l as usize] {
                        format!("{:.1} MB", stats.gpu_bytes[l as usize] as f64 / 1e6)
                    } else {
                        "not baked".into()
                    });
                    ui.end_row();
                }
            });
        if let Some(e) = &stats.error {
            ui.colored_label(ui.visuals().error_fg_color, e);
        }
    }

    /// The crowd image (central area) with camera input.
    pub fn viewport(&mut self, ui: &mut egui::Ui, dt: f32) {
        let rect = ui.available_rect_before_wrap();
        let response = ui.allocate_rect(rect, egui::Sense::click_and_drag());
        self.camera.handle_input(ui, &response, true);
        if self.fly && (response.hovered() || response.has_focus()) {
            let (w, a, s, d, q, e) = ui.input(|i| {
                (
                    i.key_down(egui::Key::W),
                    i.key_down(egui::Key::A),
                    i.key_down(egui::Key::S),
                    i.key_down(egui::Key::D),
                    i.key_down(egui::Key::Q),
                    i.key_down(egui::Key::E),
                )
            });
            let forward = Vec3::new(-self.camera.yaw_rad.sin(), 0.0, -self.camera.yaw_rad.cos());
            let right = forward.cross(Vec3::Y);
            // Half the viewing distance per second: slow up close, quick over a big crowd
            // (bounds in the character's own size).
            let (scale, ground) = self
                .assets
                .as_ref()
                .map_or((1.0, 0.0), |(_, a)| (a.size.scale(), a.size.ground_y));
            let speed = (0.5 * self.camera.distance).clamp(2.0 * scale, 200.0 * scale) * dt;
            let mut step = Vec3::ZERO;
            step += forward * (w as i32 - s as i32) as f32;
            step += right * (d as i32 - a as i32) as f32;
            step += Vec3::Y * (e as i32 - q as i32) as f32;
            self.camera.target += step * speed;
            // Not past a kilometre per metre of character above the ground (below it:
            // `keep_above_ground`).
            self.camera.target.y = self.camera.target.y.min(ground + 1000.0 * scale);
        }
        if let Some((_, a)) = &self.assets {
            keep_above_ground(&mut self.camera, a.size.ground_y, a.size.scale());
        }
        let Some((generation, assets)) = &self.assets else {
            ui.painter().text(
                rect.center(),
                egui::Align2::CENTER_CENTER,
                "No crowd yet: Crowd > Bake for crowd preview",
                egui::FontId::proportional(18.0),
                ui.visuals().weak_text_color(),
            );
            return;
        };
        // The impostor level on its own draws from the full-resolution sheets: read them in
        // the background (hundreds of megabytes for a big bake), never on the UI thread.
        let all = || std::iter::once(assets).chain(self.guests.iter().map(|g| &g.assets));
        if self.mode == PreviewMode::Only(Level::Impostor) {
            if self.full_requested != Some(*generation) {
                self.full_requested = Some(*generation);
                let list: Vec<Arc<CrowdAssets>> = all().cloned().collect();
                std::thread::spawn(move || {
                    for a in list {
                        let _ = a.full_impostors();
                    }
                });
            }
        }
        let reading_full = self.mode == PreviewMode::Only(Level::Impostor) && !all().all(|a| a.full_impostors_ready());
        let ppp = ui.ctx().pixels_per_point();
        // Every character's share (all zero: equal shares).
        let mut shares: Vec<f32> = std::iter::once(self.own_share)
            .chain(self.guests.iter().map(|g| g.share))
            .map(|s| if s.is_finite() { s.max(0.0) } else { 0.0 })
            .collect();
        if !(shares.iter().sum::<f32>() > 0.0) {
            shares.iter_mut().for_each(|s| *s = 1.0);
        }
        let callback = CrowdCallback {
            assets: assets.clone(),
            guests: self.guests.iter().map(|g| g.assets.clone()).collect(),
            shares,
            generation: *generation,
            count: self.count,
            behaviour: self.behaviour,
            variation: self.variation,
            policy: self.policy(),
            paused: self.paused,
            camera: self.camera.camera(),
            size_px: [
                (rect.width() * ppp).round() as u32,
                (rect.height() * ppp).round() as u32,
            ],
            dt,
            stats: self.stats.clone(),
        };
        ui.painter()
            .add(egui_wgpu::Callback::new_paint_callback(rect, callback));
        if reading_full {
            ui.painter().text(
                rect.center_top() + egui::vec2(0.0, 12.0),
                egui::Align2::CENTER_TOP,
                "Reading the full-resolution impostor sheets… (the far ones are drawn meanwhile)",
                egui::FontId::proportional(14.0),
                egui::Color32::from_gray(230),
            );
            ui.ctx().request_repaint_after(std::time::Duration::from_millis(200));
        }
        ui.painter().text(
            rect.left_bottom() + egui::vec2(8.0, -8.0),
            egui::Align2::LEFT_BOTTOM,
            if self.fly {
                "Fly: WASD move · Q/E down/up · drag to look · wheel: speed"
            } else {
                "Orbit: left drag · Pan: right drag · Zoom: wheel"
            },
            egui::FontId::proportional(12.0),
            egui::Color32::from_gray(170),
        );
    }
}

/// The crowd's GPU state, an entry of egui_wgpu's callback resources beside the viewport's.
pub struct CrowdGpu {
    generation: u64,
    scene: CrowdScene,
    target: RenderTarget,
    blit: wgpu::BindGroup,
    /// When the crowd was last drawn (the interval its draw budget adapts to).
    drawn_at: Option<Instant>,
    /// The representation and size last drawn: a change starts the draw budget afresh.
    drawn_as: Option<(LodPolicy, usize)>,
}

/// One frame's crowd draw request.
pub struct CrowdCallback {
    assets: Arc<CrowdAssets>,
    /// Other characters sharing the crowd.
    guests: Vec<Arc<CrowdAssets>>,
    /// Shares of the agents: the opened character, then each guest.
    shares: Vec<f32>,
    generation: u64,
    count: usize,
    behaviour: polypostor::crowd::Behaviour,
    variation: f32,
    policy: LodPolicy,
    paused: bool,
    camera: Camera,
    size_px: [u32; 2],
    dt: f32,
    stats: Arc<Mutex<PreviewStats>>,
}

impl egui_wgpu::CallbackTrait for CrowdCallback {
    fn prepare(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        _screen: &egui_wgpu::ScreenDescriptor,
        _encoder: &mut wgpu::CommandEncoder,
        resources: &mut egui_wgpu::CallbackResources,
    ) -> Vec<wgpu::CommandBuffer> {
        // The crowd's state is an entry of its own beside the viewport's (taken out while
        // both are needed, then put back).
        let mut slot = resources.remove::<CrowdGpu>();
        if let Some(res) = resources.get_mut::<ViewportResources>() {
            self.prepare_crowd(device, queue, res, &mut slot);
        }
        if let Some(crowd) = slot {
            resources.insert(crowd);
        }
        Vec::new()
    }

    fn paint(
        &self,
        _info: egui::PaintCallbackInfo,
        pass: &mut wgpu::RenderPass<'static>,
        resources: &egui_wgpu::CallbackResources,
    ) {
        let (Some(res), Some(crowd)) = (resources.get::<ViewportResources>(), resources.get::<CrowdGpu>()) else {
            return;
        };
        res.blit(pass, &crowd.blit, true);
    }
}

impl CrowdCallback {
    /// Builds or updates the crowd's scene in `slot` and draws a frame into its target.
    fn prepare_crowd(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        res: &mut ViewportResources,
        slot: &mut Option<CrowdGpu>,
    ) {
        let [w, h] = [self.size_px[0].max(1), self.size_px[1].max(1)];
        let params = self.assets.crowd_params(self.count);
        // Full-resolution impostor sheets only for the impostor level on its own (the mix
        // draws far characters from the far ones), once read from the folder in the
        // background ([`CrowdPanel::viewport`]); the far ones stand in meanwhile.
        let full = matches!(self.policy, LodPolicy::Only(Level::Impostor))
            && std::iter::once(&self.assets)
                .chain(&self.guests)
                .all(|a| a.full_impostors_ready());
        let stale = slot
            .as_ref()
            .is_none_or(|c| c.generation != self.generation || (full && !c.scene.renderers.has_full_impostors()));
        if stale {
            *slot = None;
            let scene = if self.guests.is_empty() {
                CrowdScene::with_impostors(device, queue, &self.assets, params.clone(), full)
            } else {
                let all: Vec<&CrowdAssets> = std::iter::once(&*self.assets)
                    .chain(self.guests.iter().map(|g| &**g))
                    .collect();
                CrowdScene::mixed(device, queue, &all, &self.shares, self.count, full)
            };
            match scene {
                Ok(mut scene) => {
                    // The selection stays on this thread: rayon's pool belongs to the bakes,
                    // whose threads yield to the window, and waiting on them would stall it.
                    scene.crowd.set_parallel(false);
                    let target = res.new_target(device, w, h);
                    let blit = res.blit_group(device, &target);
                    *slot = Some(CrowdGpu {
                        generation: self.generation,
                        scene,
                        target,
                        blit,
                        drawn_at: None,
                        drawn_as: None,
                    });
                }
                Err(e) => {
                    if let Ok(mut s) = self.stats.lock() {
                        s.error = Some(format!("cannot draw this crowd: {e}"));
                    }
                    return;
                }
            }
        }
        let resize = slot
            .as_ref()
            .is_some_and(|c| c.target.width != w || c.target.height != h);
        if resize {
            let target = res.new_target(device, w, h);
            let blit = res.blit_group(device, &target);
            if let Some(c) = slot.as_mut() {
                c.target = target;
                c.blit = blit;
            }
        }
        let Some(crowd) = slot.as_mut() else {
            return;
        };
        if crowd.scene.crowd.params.count != self.count {
            crowd.scene.respawn(params);
        }
        let mix_error = crowd
            .scene
            .set_shares(&self.shares)
            .err()
            .map(|e| format!("cannot mix these characters: {e}"));
        // A new behaviour mix: agents take it up as they next change gait (no jump).
        crowd.scene.crowd.params.behaviour = self.behaviour;
        crowd.scene.style.tint = self.variation;
        crowd.scene.crowd.set_paused(self.paused);
        if crowd.drawn_as != Some((self.policy, self.count)) {
            crowd.scene.draw_budget = usize::MAX;
            crowd.drawn_as = Some((self.policy, self.count));
        }
        let s = crowd.scene.frame(
            device,
            queue,
            &crowd.target,
            &self.camera,
            &self.policy,
            self.dt,
            wgpu::Color {
                r: 0.05,
                g: 0.06,
                b: 0.07,
                a: 1.0,
            },
        );
        // A crowd too heavy for this machine (20,000 skinned meshes on a software rasteriser
        // took seconds a frame and the window stopped answering) draws fewer characters,
        // evenly spread, until frames come back under about 150 ms; the panel says so.
        let records = s.frame.per_level.iter().sum::<usize>() + s.skipped;
        let now = Instant::now();
        if let Some(then) = crowd.drawn_at {
            crowd.scene.adapt_budget((now - then).as_secs_f32(), records);
        }
        crowd.drawn_at = Some(now);
        if let Ok(mut out) = self.stats.lock() {
            out.skipped = s.skipped;
            out.agents = crowd.scene.crowd.len();
            out.visible = s.frame.visible;
            out.per_level = s.frame.per_level;
            out.simulate_ms = s.frame.simulate_secs * 1e3;
            out.select_ms = s.frame.select_secs * 1e3;
            out.upload_ms = s.upload_secs * 1e3;
            out.draw_calls = s.draw_calls;
            out.gaits = crowd.scene.crowd.gait_counts();
            out.per_kind = crowd.scene.crowd.kind_counts();
            out.error = mix_error;
            for l in Level::ALL {
                out.available[l as usize] = crowd.scene.renderers.has(l);
                out.gpu_bytes[l as usize] = crowd.scene.gpu_bytes(l);
            }
        }
    }
}

/// A size ratio for people to read: two decimals near 1, three significant figures with a
/// power of ten far from it (a character 0.02 mm tall is ×8.6e-6 a person, not ×0.00).
pub(crate) fn ratio(x: f32) -> String {
    if x == 0.0 || (0.01..10_000.0).contains(&x.abs()) {
        format!("{x:.2}")
    } else {
        format!("{x:.2e}")
    }
}

pub(crate) use polypostor::crowd::metres;

/// Keeps the crowd preview's orbit above the ground it looks at: the point it turns about
/// no lower than the ground, and the eye at least a fifth of the character's height above it
/// (orbiting down ends at a view along the ground instead of passing under it).
fn keep_above_ground(camera: &mut super::viewport::OrbitCamera, ground: f32, scale: f32) {
    if !(ground.is_finite() && scale.is_finite()) {
        return;
    }
    camera.target.y = camera.target.y.max(ground);
    let lowest = ground + 0.2 * polypostor::crowd::CharacterSize::REFERENCE_METRES * scale;
    let eye_y = camera.target.y + camera.distance * camera.pitch_rad.sin();
    if eye_y < lowest && camera.distance > 0.0 {
        let sin = ((lowest - camera.target.y) / camera.distance).clamp(-1.0, 0.999);
        camera.pitch_rad = sin.asin();
    }
}

#[cfg(test)]
mod orbit_tests {
    use super::*;

    /// Whatever the orbit's pitch, distance, target and the character's size and ground, the
    /// eye (from the camera the renderer gets) ends at least a fifth of the character's height
    /// above the ground; an orbit already above it is left as it was.
    /// Sizes read in the unit they ask for, from micrometres to kilometres, and ratios to a
    /// person keep their figures far from 1.
    #[test]
    fn lengths_and_ratios_read_at_any_size() {
        assert_eq!(metres(15.4e-6), "15.4 µm");
        assert_eq!(metres(0.0052), "5.2 mm");
        assert_eq!(metres(0.5), "50.0 cm");
        assert_eq!(metres(1.8), "1.80 m");
        assert_eq!(metres(150_700.0), "150.70 km");
        assert_eq!(ratio(1.0), "1.00");
        assert_eq!(ratio(0.05), "0.05");
        assert_eq!(ratio(8.6e-6), "8.60e-6");
        assert_eq!(ratio(83_000.0), "8.30e4");
    }

    #[test]
    fn the_crowd_orbit_never_goes_under_the_ground() {
        let mut moved = 0;
        for &(ground, scale) in &[(0.0f32, 1.0f32), (-3.0, 0.01), (250.0, 100.0)] {
            for k in 0..=30 {
                let pitch = -1.55 + 3.1 * k as f32 / 30.0;
                for &d in &[0.5f32, 5.0, 400.0] {
                    for &ty in &[ground - 2.0 * scale, ground, ground + 3.0 * scale] {
                        let mut cam = super::super::viewport::OrbitCamera {
                            target: Vec3::new(1.0, ty, -2.0),
                            pitch_rad: pitch,
                            distance: d * scale,
                            ..Default::default()
                        };
                        let before = cam;
                        keep_above_ground(&mut cam, ground, scale);
                        let lowest = ground + 0.36 * scale;
                        let eye = cam.camera().eye;
                        assert!(
                            eye.y >= lowest - 1e-3 * scale.max(1.0),
                            "{ground} {scale} {pitch} {d} {ty}: eye {eye}"
                        );
                        assert!(cam.target.y >= ground);
                        let was = before.target.y.max(ground) + before.distance * before.pitch_rad.sin();
                        if before.target.y >= ground && was >= lowest {
                            assert_eq!(cam, before);
                        } else {
                            moved += 1;
                        }
                    }
                }
            }
        }
        assert!(moved > 100, "the cases never went under: {moved}");
    }
}
