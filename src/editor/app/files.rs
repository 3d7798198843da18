//! Opening and saving: loading a character or project in the background, Save / Save As,
//! autosave, the settings file, files dropped on the window.

use super::*;

impl EditorApp {
    pub(super) fn save_to(&mut self, file: PathBuf) {
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
        let old_autosave = crate::editor::safety::autosave_path(doc, self.options.recovery_dir.as_deref());
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
        // And the last pack's, when saved into another folder: it stays where it was (a path
        // the artist gave as absolute stays absolute).
        if let Some(old) = doc.project_file.as_deref()
            && old.parent() != file.parent()
            && let Some(stored) = doc.project.view.last_pack.as_deref()
            && !Path::new(stored).is_absolute()
            && let Some(pack) = doc.project.last_pack_path(old)
            && let (Ok(pack), Ok(dir)) = (std::path::absolute(&pack), std::path::absolute(&dir))
        {
            project.view.last_pack = Some(polypostor::project::relative_path(&pack, &dir));
        }
        if project.name.is_empty() || doc.project_file.is_none() {
            if let Some(stem) = file.parent().and_then(|p| p.file_name()) {
                project.name = stem.to_string_lossy().into_owned();
            }
        }
        match project.save(&file) {
            Ok(()) => {
                doc.saved = Some(project.clone());
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

    pub(super) fn autosave(&mut self, force: bool) -> bool {
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

    pub(super) fn save_settings(&mut self) {
        if let Err(e) = self.settings.save(self.options.settings_path.as_deref()) {
            self.warn(format!("cannot save editor settings: {e}"));
        }
    }

    pub(super) fn start_load(&mut self, ctx: &egui::Context, request: LoadRequest) {
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

    pub(super) fn poll_loading(&mut self) {
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

    pub(super) fn finish_load(&mut self, result: Result<Loaded, String>) {
        let discard = std::mem::take(&mut self.safety.discard_on_replace);
        let loaded = match result {
            Ok(l) => l,
            Err(e) => {
                // The open project (if any) stays as it was, with its autosave.
                self.fail(e);
                return;
            }
        };
        // The document replaced: its autosave is stale when it had nothing unsaved (the
        // project file holds it all: an undone recovery left one behind, offered again on
        // the next open) — unless its recovery is still being asked about — and unwanted
        // when the user chose "Don't save".
        if !loaded.only_character
            && let Some(old) = &self.doc
            && (discard || (!old.dirty && self.options.autosave && self.safety.recovery.is_none()))
        {
            self.safety.clear(old, self.options.recovery_dir.as_deref());
        }
        if loaded.only_character {
            self.replace_character(loaded.character);
            return;
        }
        // A bake of the project left behind would land in the next one's crowd preview (and
        // its settings in the next project): it is cancelled.
        if self.crowd.busy() {
            self.crowd.cancel_job();
            self.pending_export = None;
            self.source_before_bake = None;
            self.info("the running bake belonged to the project left: cancelled".into());
        }
        let c = &loaded.character;
        self.info(format!(
            "loaded {} ({} vertices, {} triangles, {} joints, {})",
            loaded.character_path.display(),
            c.vertices.len(),
            c.triangle_count(),
            c.skeleton.joint_count(),
            polypostor::import::plural(c.clips.len(), "clip")
        ));
        for w in &c.warnings {
            self.warn(w.clone());
        }
        if let Some(w) = loaded.project_file.as_deref().and_then(Project::unknown_keys_warning) {
            self.warn(w);
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
        // Bake settings out of range (a file edited by hand) are named and put back to their
        // defaults, so an export does not fail on them later.
        let mut loaded = loaded;
        let (settings, wrong) = loaded.project.bake.repaired();
        let repaired = !wrong.is_empty();
        for e in wrong {
            let file = loaded.project_file.as_ref().map(|f| f.display().to_string());
            self.warn(format!(
                "{}the project's bake setting {} {}: its default is used (save to keep it)",
                file.map(|f| format!("{f}: ")).unwrap_or_default(),
                e.setting.replace('-', "_"),
                e.message
            ));
        }
        loaded.project.bake = settings;
        let doc = Document {
            saved: loaded.project_file.is_some().then(|| loaded.project.clone()),
            project: loaded.project,
            // A character just imported holds no work yet: closing it asks nothing (it is
            // saved as a project on the first Save, which asks where).
            dirty: repaired,
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
        self.views.forget_inspector();
        self.views.set_source(Some(&views_source_on_open(&doc)));
        // The crowd (its characters, its pack, the bake to re-bake from) was the project left's.
        self.crowd.forget_project();
        self.doc = Some(doc);
        self.frame_character();
    }

    /// Puts a re-imported character (the same file, another up axis) into the open document,
    /// keeping the project, its history and the segmentation (the triangles are the same).
    fn replace_character(&mut self, character: Character) {
        let Some(doc) = &mut self.doc else { return };
        let up = character.up_axis;
        let mut lines = vec![format!("read {} with {up} as up", doc.character_path.display())];
        // The import's own note that it stood the character up says the same as the first line.
        lines.extend(
            character
                .warnings
                .iter()
                .filter(|w| !w.starts_with("read with "))
                .cloned(),
        );
        doc.summary = polypostor::summary::Summary::of(&character);
        doc.segmentation = Document::decode_segmentation(&doc.project, &character).0;
        doc.character = Arc::new(character);
        doc.generation = self.next_generation;
        self.next_generation += 1;
        doc.revision += 1;
        if !doc.project.overrides.is_empty() {
            lines.push(
                "the project's per-view corrections (key frames, orders, pins) were made with the character \
                 standing another way: check them in the Views tab"
                    .into(),
            );
        }
        let (first, rest) = lines.split_first().expect("one line");
        self.info(first.clone());
        for w in rest {
            self.warn(w.clone());
        }
        self.frame_character();
        // Changed again while this one loaded: the next frame's check reads it again.
    }

    /// Re-imports the open character when the project asks for another up axis than it was
    /// read with (after the Up axis choice, or an undo or redo of it). Checked every frame.
    pub(super) fn reimport_if_needed(&mut self, ctx: &egui::Context) {
        let Some(doc) = &self.doc else { return };
        let up = doc.project.character.up;
        if up == doc.character.up_axis {
            self.reimport_tried = None;
            return;
        }
        if self.loading.is_some() {
            return;
        }
        let attempt = (doc.character_path.clone(), up);
        if self.reimport_tried.as_ref() == Some(&attempt) {
            return;
        }
        self.reimport_tried = Some(attempt.clone());
        let (path, up) = attempt;
        self.start_load(ctx, LoadRequest::Reimport { path, up });
    }

    pub(super) fn dropped_files(&mut self, ctx: &egui::Context) {
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
}

/// A loaded project, ready to become the document.
pub(super) struct Loaded {
    pub(super) project: Project,
    pub(super) project_file: Option<PathBuf>,
    pub(super) character_path: PathBuf,
    pub(super) character: Character,
    pub(super) from_gltf: bool,
    /// A [`LoadRequest::Reimport`]: replaces the open document's character only.
    pub(super) only_character: bool,
}

pub(super) struct Loading {
    pub(super) what: String,
    pub(super) started: Instant,
    pub(super) rx: Receiver<Result<Loaded, String>>,
}

pub(super) fn expand_home(text: &str) -> PathBuf {
    if let Some(rest) = text.strip_prefix("~/") {
        if let Some(home) = std::env::var_os("HOME") {
            return PathBuf::from(home).join(rest);
        }
    }
    PathBuf::from(text)
}

pub(super) fn is_gltf(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("glb") || e.eq_ignore_ascii_case("gltf"))
}

/// A background load: a project and its character, or a glTF as a new project.
pub(super) enum LoadRequest {
    Project(PathBuf),
    Gltf(PathBuf),
    /// The open document's character file again, read with `up` as its up axis: only the
    /// character changes (the project, its history and the view stay).
    Reimport {
        path: PathBuf,
        up: polypostor::UpAxis,
    },
}

impl LoadRequest {
    pub(super) fn describe(&self) -> String {
        match self {
            LoadRequest::Project(p) | LoadRequest::Gltf(p) => p.display().to_string(),
            LoadRequest::Reimport { path, up } => format!("{} with {up} up", path.display()),
        }
    }

    pub(super) fn run(self) -> Result<Loaded, String> {
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
                    only_character: false,
                })
            }
            LoadRequest::Project(path) => {
                let (project, file) = Project::load(&path).map_err(|e| e.to_string())?;
                let character_path = project.character_path(&file);
                let character_path = std::fs::canonicalize(&character_path).unwrap_or(character_path);
                let character =
                    polypostor::import_path_with(&character_path, project.import_options()).map_err(|e| {
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
                    only_character: false,
                })
            }
            LoadRequest::Reimport { path, up } => {
                let character = polypostor::import_path_with(&path, polypostor::ImportOptions { up })
                    .map_err(|e| format!("Cannot import {} with {up} up:\n{e}", path.display()))?;
                Ok(Loaded {
                    project: Project::new_for_character("", &path, Path::new("")),
                    project_file: None,
                    character_path: path,
                    character,
                    from_gltf: false,
                    only_character: true,
                })
            }
        }
    }
}
