//! Dialogs: file pickers and typed paths, unsaved-changes and recovery prompts, the
//! export and about windows.

use super::*;

impl EditorApp {
    /// Opens the native file dialog on a thread; a dialog that returns at once (no portal
    /// or dialog service on this desktop) falls back to the typed-path prompt.
    pub(super) fn ask_path(&mut self, purpose: PathPurpose) {
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

    pub(super) fn poll_dialog(&mut self) {
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

    /// The recovery prompt and the unsaved-changes prompts (closing, replacing the document).
    pub(super) fn safety_dialogs(&mut self, ctx: &egui::Context) {
        if let Some((path, _, when)) = self.safety.recovery.clone() {
            let age = when
                .elapsed()
                .map_or("earlier".into(), |d| format!("{} s ago", d.as_secs()));
            let mut answer = None;
            crate::editor::modal(ctx, "recovery prompt").show(ctx, |ui| {
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
                    self.safety.discard_on_replace = true;
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
    pub(super) fn unsaved_prompt(
        &mut self,
        ctx: &egui::Context,
        id: &'static str,
        heading: &str,
    ) -> Option<UnsavedAnswer> {
        // An error on screen is read and closed first; the question waits behind it (both
        // modal at once stacked one on the other).
        if self.error.is_some() {
            return None;
        }
        let name = self.doc.as_ref().map_or(String::new(), |d| {
            if d.project.name.is_empty() {
                "This project".to_owned()
            } else {
                format!("Project “{}”", d.project.name)
            }
        });
        let mut answer = None;
        crate::editor::modal(ctx, id).show(ctx, |ui| {
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

    pub(super) fn dialogs(&mut self, ctx: &egui::Context) {
        if let Some(message) = self.error.clone() {
            let modal = crate::editor::modal(ctx, "error dialog").show(ctx, |ui| {
                ui.set_max_width(520.0);
                ui.heading("Something went wrong");
                ui.add_space(6.0);
                ui.label(&message);
                ui.add_space(6.0);
                if self.doc.is_some() {
                    ui.label(egui::RichText::new("The open project is unchanged.").weak());
                }
                ui.add_space(8.0);
                // OK, Enter or Escape (the modal's own) close it.
                ui.button("OK").clicked() || ui.input(|i| i.key_pressed(egui::Key::Enter))
            });
            if modal.inner || modal.should_close() {
                self.error = None;
            }
        }
        let mut submit = None;
        let mut cancel = false;
        if let Some(prompt) = &mut self.prompt {
            crate::editor::modal(ctx, "path prompt").show(ctx, |ui| {
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
                    // Every shortcut the editor answers (the list said 8 of them), by where
                    // it works.
                    egui::Grid::new("controls").num_columns(2).striped(true).show(ui, |ui| {
                        for (k, v) in [
                            ("Viewport", ""),
                            ("Orbit", "left drag (middle drag in the Segment tab)"),
                            ("Pan", "shift + middle drag, or right drag"),
                            ("Zoom", "mouse wheel"),
                            ("Frame character", "F, or double-click"),
                            ("Play / pause", "Space"),
                            ("Step frame", "Left / Right arrow"),
                            ("Go to start", "Home"),
                            ("Project", ""),
                            ("New / Open / Save", "Ctrl+N / Ctrl+O / Ctrl+S"),
                            ("Save As", "Ctrl+Shift+S"),
                            ("Undo / Redo", "Ctrl+Z / Ctrl+Shift+Z or Ctrl+Y"),
                            ("Bake for the crowd preview", "Ctrl+B"),
                            ("Export", "Ctrl+E"),
                            ("Quit", "Ctrl+Q"),
                            ("Segment tab", ""),
                            ("Paint", "left drag"),
                            ("Brush / Fill connected / Fill by joint", "B / G / J"),
                            ("Mirror across X", "M"),
                            ("Brush radius", "[ and ]"),
                            ("Crowd preview", ""),
                            ("Show / hide it", "Tab"),
                            ("Pause", "P"),
                            ("Fly (when ticked)", "W A S D, Q / E down and up"),
                        ] {
                            if v.is_empty() {
                                ui.label(egui::RichText::new(k).strong());
                            } else {
                                ui.label(k);
                            }
                            ui.label(v);
                            ui.end_row();
                        }
                    });
                });
        }
    }
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
    pub(super) fn title(self) -> &'static str {
        match self {
            PathPurpose::NewFromGltf => "New project from glTF",
            PathPurpose::Open => "Open project",
            PathPurpose::SaveAs => "Save project as",
            PathPurpose::OpenCrowd => "Open a baked folder in the crowd preview",
            PathPurpose::AddToCrowd => "Add another baked character to the crowd",
        }
    }
    pub(super) fn hint(self) -> &'static str {
        match self {
            PathPurpose::NewFromGltf => "path to a .glb or .gltf file",
            PathPurpose::Open => "project folder, project.json, or .glb/.gltf",
            PathPurpose::SaveAs => "project folder or .json file to write",
            PathPurpose::OpenCrowd => "folder written by bake --representation all",
            PathPurpose::AddToCrowd => "folder written by bake --representation all (of any character)",
        }
    }
    pub(super) fn command(self, path: PathBuf) -> Command {
        match self {
            PathPurpose::NewFromGltf => Command::NewFromGltf(path),
            PathPurpose::Open => Command::Open(path),
            PathPurpose::SaveAs => Command::SaveAs(path),
            PathPurpose::OpenCrowd => Command::OpenCrowd(path),
            PathPurpose::AddToCrowd => Command::AddToCrowd(path),
        }
    }
}

pub(super) struct PathPrompt {
    pub(super) purpose: PathPurpose,
    pub(super) text: String,
    /// Focus is given to the text field once, when the prompt opens.
    pub(super) focused: bool,
}

impl PathPrompt {
    pub(super) fn new(purpose: PathPurpose) -> Self {
        Self {
            purpose,
            text: String::new(),
            focused: false,
        }
    }
}
