//! Commands: the one place the editor changes its document, bakes and previews (the UI
//! sends [`Command`]s; [`EditorApp::apply`] carries them out).

use super::*;

impl EditorApp {
    /// Queues a command (applied at the start of the next frame).
    pub fn send(&mut self, command: Command) {
        self.commands.push(command);
    }

    pub(super) fn apply_commands(&mut self, ctx: &egui::Context) {
        for command in std::mem::take(&mut self.commands) {
            self.apply(ctx, command);
        }
    }

    pub(super) fn apply(&mut self, ctx: &egui::Context, command: Command) {
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
                // A path naming something that is not a folder (a user's file) is not a
                // project folder to save into: said as such, and left untouched.
                if let Ok(meta) = std::fs::metadata(&path)
                    && !meta.is_dir()
                    && !path.extension().is_some_and(|e| e.eq_ignore_ascii_case("json"))
                {
                    self.safety.close_after_save = false;
                    self.safety.replace_after_save = None;
                    self.fail(format!(
                        "{} exists and is {}, not a project folder; it is left untouched: choose a new or project folder",
                        path.display(),
                        polypostor::safe_fs::kind_of(&meta.file_type())
                    ));
                    return;
                }
                let file = if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("json")) {
                    path
                } else {
                    path.join(PROJECT_FILE)
                };
                // Another project (or any file) already there is never replaced: Save As
                // wrote one project over another without a word, its painting, caps and
                // corrections lost.
                let own = self
                    .doc
                    .as_ref()
                    .and_then(|d| d.project_file.as_deref())
                    .is_some_and(|f| polypostor::safe_fs::resolved(f) == polypostor::safe_fs::resolved(&file));
                if !own && std::fs::symlink_metadata(&file).is_ok() {
                    self.safety.close_after_save = false;
                    self.safety.replace_after_save = None;
                    let what = polypostor::project::Project::load(&file)
                        .map(|(p, _)| format!("project '{}'", p.name))
                        .unwrap_or_else(|_| "a file".into());
                    self.fail(format!(
                        "{} already holds {what}; Save As never replaces it: choose a new folder (or open that project to work on it)",
                        file.display()
                    ));
                    return;
                }
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
            Command::ShowCrowd(show) => {
                self.crowd.open = show;
                // Nothing in the preview yet, but the project has a bake: it is opened (the
                // tab said "No crowd yet" beside a crowd.pack baked last session).
                if show
                    && self.crowd.assets.is_none()
                    && !self.crowd.busy()
                    && let Some(doc) = &self.doc
                {
                    let folder = views_source_on_open(doc);
                    if polypostor::safe_fs::bake_folder_format(&folder).is_some() {
                        self.commands.push(Command::OpenCrowd(folder));
                    }
                }
            }
            Command::Export(req) => {
                // The clip set chosen is the project's from now on (Ctrl+B bakes it too).
                // The clip set and the settings chosen become the project's.
                let mut settings = self.doc.as_ref().map(|d| d.project.bake.clone()).unwrap_or_default();
                (settings.views, settings.resolution, settings.fps) = (req.views, req.resolution, req.fps);
                (settings.png, settings.textures) = (req.png, req.textures);
                settings.polygon_vertices = req.polygon_vertices;
                settings.representations = req.set.words();
                // Made the project's when the bake succeeds (see `pending_export`).
                let options = settings.options();
                let busy = self.crowd.busy();
                self.bake_into(req.folder, options, req.set, Some(&req.clips));
                if !busy && self.crowd.busy() {
                    self.pending_export = Some((req.clips.clone(), settings));
                }
            }
            Command::SetUpAxis(up) => {
                if let Some(doc) = self.doc.as_mut()
                    && doc.project.character.up != up
                {
                    let before = doc.project.clone();
                    doc.project.character.up = up;
                    doc.history.record("up axis", before);
                    doc.dirty = true;
                    // The character is read again by the next frame's check.
                }
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
    pub(super) fn bake_crowd(&mut self) {
        let Some(doc) = &self.doc else {
            self.fail("open a character before baking it for the crowd".into());
            return;
        };
        let out = bake_dir(doc);
        // The project's bake settings; every representation (the crowd's mix needs them).
        let options = doc.project.bake.options();
        self.bake_into(out, options, polypostor::reps::RepSet::ALL, None);
    }

    /// Bakes `set` with `options` into `out` in the background, then previews it: the clips
    /// of `clip_set` (the export dialog's choice, made the project's once the bake succeeds),
    /// else the project's clip set, else the clip being viewed.
    pub(super) fn bake_into(
        &mut self,
        out: PathBuf,
        options: polypostor::bake::pipeline::BakeOptions,
        set: polypostor::reps::RepSet,
        clip_set: Option<&[String]>,
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
            self.source_before_bake = Some(self.views.source.clone());
            self.views.set_source(Some(&out));
        }
        // The clip set asked for, else the project's (a whole-character pack), else the clip
        // being viewed: the rule every bake follows.
        let asked = clip_set.unwrap_or(&doc.project.clips);
        let clips = polypostor::job::ClipChoice::resolve(
            &c,
            polypostor::job::ClipRequest {
                project_clips: asked,
                viewed: self.playback.clip,
                ..Default::default()
            },
        )
        .unwrap_or_default();
        let lost = polypostor::job::lost_clips_warning(&c, asked, &clips);
        let req = crate::editor::crowd::BakeRequest {
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
        if let Some(w) = lost {
            self.warn(w);
        }
        self.info(format!("baking into {}", out.display()));
        self.crowd.start_bake(req);
    }

    pub(super) fn frame_character(&mut self) {
        if let Some(doc) = &self.doc {
            let (min, max) = clip_bounds(&doc.character, self.playback.clip, 12);
            self.camera.frame(min, max);
        }
    }
}

/// Where the editor bakes a document: `crowd.pack` beside its project, or a temporary folder
/// for a project never saved.
pub(super) fn bake_dir(doc: &Document) -> PathBuf {
    match &doc.project_file {
        Some(f) => f
            .parent()
            .map(Path::to_owned)
            .unwrap_or_default()
            .join(polypostor::project::PROJECT_PACK),
        None => temp_bake_dir(std::process::id(), doc.generation),
    }
}

/// What the Views tab shows when a document is opened: the last pack baked or exported for
/// its project, where that folder still holds one of this tool's bakes, else where the
/// editor bakes it ([`bake_dir`]).
pub(super) fn views_source_on_open(doc: &Document) -> PathBuf {
    doc.project_file
        .as_deref()
        .and_then(|f| doc.project.last_pack_path(f))
        .filter(|dir| polypostor::safe_fs::bake_folder_format(dir).is_some())
        .unwrap_or_else(|| bake_dir(doc))
}

/// Where an editor process bakes a document never saved (each its own: `generation` is the
/// document's, so a second import never shows the first one's bake); removed when the editor
/// exits, and by the next editor if that one was killed.
pub(super) fn temp_bake_dir(pid: u32, generation: u64) -> PathBuf {
    std::env::temp_dir().join(format!("polypostor-crowd-{pid}-{generation}.pack"))
}

/// The editor process a temporary bake folder's name says wrote it.
fn temp_bake_pid(name: &str) -> Option<u32> {
    let rest = name.strip_prefix("polypostor-crowd-")?.strip_suffix(".pack")?;
    let pid = rest.split_once('-').map_or(rest, |(pid, generation)| {
        if generation.bytes().all(|b| b.is_ascii_digit()) {
            pid
        } else {
            ""
        }
    });
    pid.parse().ok()
}

/// Removes the temporary bake folders of editors that are no longer running (`mine`: this
/// editor's too, as it exits).
pub(super) fn remove_temp_bakes(mine: bool) {
    let Ok(entries) = std::fs::read_dir(std::env::temp_dir()) else {
        return;
    };
    let me = std::process::id();
    for e in entries.filter_map(Result::ok) {
        let name = e.file_name().to_string_lossy().into_owned();
        // Only a folder this tool wrote and nothing else put in (what a bake would replace).
        if let Some(pid) = temp_bake_pid(&name)
            && (if pid == me {
                mine
            } else {
                !polypostor::safe_fs::process_alive(pid)
            })
            && e.file_type().is_ok_and(|t| t.is_dir())
            && polypostor::safe_fs::check_bake_output(&e.path(), &[]).is_ok()
        {
            let _ = std::fs::remove_dir_all(e.path());
        }
    }
}

#[cfg(test)]
mod tests {
    /// A temporary bake folder of an editor no longer running is removed only when it holds
    /// nothing but what the tool writes: a folder of that name holding a user's file stays.
    #[test]
    fn stale_temporary_bakes_are_removed_only_when_the_tool_s() {
        // A process number above Linux's largest (4,194,304) is never alive.
        let (empty, foreign) = (super::temp_bake_dir(4_194_400, 3), super::temp_bake_dir(4_194_401, 0));
        let old_style = std::env::temp_dir().join("polypostor-crowd-4194402.pack");
        let not_ours = std::env::temp_dir().join("polypostor-crowd-4194403-x.pack");
        for d in [&empty, &foreign, &old_style, &not_ours] {
            let _ = std::fs::remove_dir_all(d);
            std::fs::create_dir_all(d).unwrap();
        }
        std::fs::write(foreign.join("notes.txt"), "mine").unwrap();
        super::remove_temp_bakes(false);
        assert!(!empty.exists(), "an empty stale folder is removed");
        assert!(!old_style.exists(), "so is one named as before (no generation)");
        assert!(not_ours.exists(), "a name this tool does not give stays");
        assert_eq!(std::fs::read_to_string(foreign.join("notes.txt")).unwrap(), "mine");
        std::fs::remove_dir_all(&foreign).unwrap();
        std::fs::remove_dir_all(&not_ours).unwrap();
        // Each unsaved document bakes into a folder of its own.
        assert_ne!(super::temp_bake_dir(7, 1), super::temp_bake_dir(7, 2));
    }
}
