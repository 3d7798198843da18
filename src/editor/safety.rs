//! Document safety: autosave every 30 seconds beside the project (or in the recovery folder
//! for a project never saved), recovery of an autosave found newer than the project on open,
//! and a prompt before closing with unsaved changes. The project file itself is only ever
//! written by an explicit save.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime};

use polypostor::project::{Project, autosave_file};

use super::document::Document;

/// How often unsaved changes are autosaved.
pub const AUTOSAVE_EVERY: Duration = Duration::from_secs(30);

/// Where a document's autosave goes: beside its project file, or for a never-saved project
/// in `recovery_dir`, named after its character.
pub fn autosave_path(doc: &Document, recovery_dir: Option<&Path>) -> Option<PathBuf> {
    match &doc.project_file {
        Some(f) => Some(autosave_file(f)),
        None => untitled_autosave(&doc.character_path, recovery_dir?),
    }
}

/// The recovery file of a never-saved project on `character`.
pub fn untitled_autosave(character: &Path, recovery_dir: &Path) -> Option<PathBuf> {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    character.hash(&mut h);
    let stem = character.file_stem()?.to_string_lossy();
    Some(recovery_dir.join(format!("untitled-{stem}-{:08x}.json", h.finish() as u32)))
}

/// The autosave state of the app.
#[derive(Default)]
pub struct Safety {
    last: Option<Instant>,
    /// The project last written to the autosave file (nothing is written while unchanged).
    written: Option<Project>,
    /// When the last autosave was written (for the status bar).
    pub written_at: Option<Instant>,
    /// An autosave found on open: its file and project, waiting for the user's answer.
    pub recovery: Option<(PathBuf, Project, SystemTime)>,
    /// The close prompt is showing.
    pub close_prompt: bool,
    /// The user chose to close (after saving or discarding).
    pub allow_close: bool,
    /// Close once the pending save succeeds.
    pub close_after_save: bool,
    /// A command that would replace the document (New from glTF, Open) while it has unsaved
    /// changes: the same Save / Don't save / Cancel prompt shows first.
    pub replace_prompt: Option<super::document::Command>,
    /// Run this replacing command once the pending save succeeds.
    pub replace_after_save: Option<super::document::Command>,
    /// The next replacing command was confirmed (saved or discarded): no prompt for it.
    pub replace_confirmed: bool,
    /// "Don't save" was chosen before replacing the document: its autosave goes once the
    /// next document has opened (a load that fails keeps the document, and its autosave).
    pub discard_on_replace: bool,
}

impl Safety {
    /// Writes the autosave if `AUTOSAVE_EVERY` has passed (or `now`) and the project differs
    /// from the last one written. Returns an error message on failure.
    pub fn tick(&mut self, doc: &Document, recovery_dir: Option<&Path>, force: bool) -> Result<bool, String> {
        let due = force || self.last.is_none_or(|t| t.elapsed() >= AUTOSAVE_EVERY);
        if !due {
            return Ok(false);
        }
        self.last = Some(Instant::now());
        if !doc.dirty || self.written.as_ref() == Some(&doc.project) {
            return Ok(false);
        }
        let Some(path) = autosave_path(doc, recovery_dir) else {
            return Ok(false);
        };
        let mut project = doc.project.clone();
        if doc.project_file.is_none() {
            // Recovered without a project folder: keep the character reachable.
            project.character.path = doc.character_path.to_string_lossy().into_owned();
        }
        project.save(&path).map_err(|e| format!("autosave failed: {e}"))?;
        self.written = Some(doc.project.clone());
        self.written_at = Some(Instant::now());
        Ok(true)
    }

    /// How long until the next autosave is due (zero when it is): the window asks to be
    /// drawn then, so an idle editor autosaves too (it only ticked when something redrew it).
    pub fn next_due(&self) -> Duration {
        self.last
            .map_or(Duration::ZERO, |t| AUTOSAVE_EVERY.saturating_sub(t.elapsed()))
    }

    /// Forgets the autosave (after a save or an explicit discard) and removes its file.
    pub fn clear(&mut self, doc: &Document, recovery_dir: Option<&Path>) {
        self.written = None;
        self.written_at = None;
        if let Some(path) = autosave_path(doc, recovery_dir) {
            let _ = std::fs::remove_file(path);
        }
    }

    /// After a project is opened: an autosave beside it (or for its character, if never
    /// saved) that is newer than the project file and differs from it waits for recovery.
    /// Returns a warning for an autosave that cannot be read (it is left in place).
    pub fn check_on_open(&mut self, doc: &Document, recovery_dir: Option<&Path>) -> Option<String> {
        self.recovery = None;
        self.written = None;
        // The status bar's "autosaved N s ago" was the previous project's.
        self.written_at = None;
        self.last = Some(Instant::now());
        let path = autosave_path(doc, recovery_dir)?;
        let saved_at = std::fs::metadata(&path).and_then(|m| m.modified()).ok()?;
        let project_at = doc
            .project_file
            .as_ref()
            .and_then(|f| std::fs::metadata(f).and_then(|m| m.modified()).ok());
        if project_at.is_some_and(|p| p > saved_at) {
            return None;
        }
        match Project::load(&path) {
            Ok((mut project, _)) => {
                // The autosave of a never-saved project names its character absolutely.
                project.character = doc.project.character.clone();
                if project != doc.project {
                    self.recovery = Some((path, project, saved_at));
                }
                None
            }
            Err(e) => Some(format!("an autosave was found but cannot be read, left in place: {e}")),
        }
    }
}
