//! Editor state that the UI reads and commands change: the open project, its character,
//! and playback.

use std::path::PathBuf;
use std::sync::Arc;

use polypostor::Character;
use polypostor::bake::caps::CapOverrides;
use polypostor::bake::segment::{Segmentation, auto_segment};
use polypostor::edit::history::History;
use polypostor::project::{Project, StoredSegmentation};

/// Everything the user can ask for; queued by the UI and applied once per frame.
#[derive(Clone, Debug, PartialEq)]
pub enum Command {
    /// Start a new (unsaved) project from a .glb/.gltf.
    NewFromGltf(PathBuf),
    /// Open a project folder or project.json (or a glTF, as New from glTF).
    Open(PathBuf),
    Save,
    SaveAs(PathBuf),
    SelectClip(Option<usize>),
    SetPlaying(bool),
    TogglePlaying,
    Seek(f32),
    StepFrames(i32),
    SetSpeed(f32),
    FrameCharacter,
    /// Bake the open character with every representation and open the crowd preview.
    BakeCrowd,
    /// Open a baked folder in the crowd preview.
    OpenCrowd(PathBuf),
    /// Adds another baked character (folder) to the crowd preview.
    AddToCrowd(PathBuf),
    /// Removes the `k`-th character added to the crowd preview.
    RemoveFromCrowd(usize),
    /// Show the crowd preview (true) or the character (false).
    ShowCrowd(bool),
    Undo,
    Redo,
    /// Read the character file with another of its axes as up (undoable; re-imports it).
    SetUpAxis(polypostor::UpAxis),
    /// Bake and write the chosen representations, then preview them.
    Export(ExportRequest),
}

/// What the user asked to export.
#[derive(Clone, Debug, PartialEq)]
pub struct ExportRequest {
    pub folder: PathBuf,
    pub set: polypostor::reps::RepSet,
    pub views: usize,
    pub resolution: u32,
    pub fps: f32,
    pub png: polypostor::bake::pipeline::PngCompression,
    pub textures: polypostor::bake::pipeline::TextureEncoding,
    /// Vertices of each part's polygon.
    pub polygon_vertices: usize,
    /// The clips to bake, in the character's order (the project's clip set from now on).
    pub clips: Vec<String>,
}

/// The open project and its loaded character.
pub struct Document {
    pub project: Project,
    /// Where the project is saved; `None` for a new, never-saved project.
    pub project_file: Option<PathBuf>,
    /// The character file the project points at (absolute).
    pub character_path: PathBuf,
    pub character: Arc<Character>,
    /// Computed once on load (the side panel shows it every frame).
    pub summary: polypostor::summary::Summary,
    /// Unsaved changes.
    pub dirty: bool,
    /// The project as last saved or opened (`None`: never saved): undoing or redoing back to
    /// it leaves no unsaved changes.
    pub saved: Option<Project>,
    /// Increases with every loaded character (the viewport re-uploads on change).
    pub generation: u64,
    /// The working segmentation (the project's, decoded; automatic when it has none).
    pub segmentation: Segmentation,
    /// Increases with every change of the segmentation or the caps (displays rebuild).
    pub revision: u64,
    /// Undo/redo of every edit, as project snapshots.
    pub history: History<Project>,
}

impl Document {
    /// The segmentation a project asks for on `c`: its stored one, or the automatic one
    /// (with the reason when the stored one does not fit).
    pub fn decode_segmentation(project: &Project, c: &Character) -> (Segmentation, Option<String>) {
        match project.segmentation.as_ref() {
            Some(s) => match s.to_segmentation(c.triangle_count()) {
                Ok(seg) => {
                    let note = s.renamed_note(&seg);
                    (seg, note)
                }
                Err(e) => (
                    auto_segment(c),
                    Some(format!(
                        "the project's segmentation does not fit ({e}); using the automatic one"
                    )),
                ),
            },
            None => (auto_segment(c), None),
        }
    }

    /// One undoable edit of the segmentation and cap colours: `f` changes them and says
    /// whether anything changed; only then is a step recorded.
    pub fn edit(&mut self, label: &str, f: impl FnOnce(&mut Segmentation, &mut CapOverrides) -> bool) -> bool {
        let before = self.project.clone();
        if !f(&mut self.segmentation, &mut self.project.caps) {
            return false;
        }
        self.history.record(label, before);
        self.store_segmentation();
        true
    }

    /// [`Document::edit`] folded into the step recorded last (a colour dragged in an open
    /// picker is one step, not one per frame): changes as `f` says, records nothing.
    pub fn amend(&mut self, f: impl FnOnce(&mut Segmentation, &mut CapOverrides) -> bool) -> bool {
        if !f(&mut self.segmentation, &mut self.project.caps) {
            return false;
        }
        self.store_segmentation();
        true
    }

    /// Adds a part (no triangles yet) as one undoable step; every hand-set drawing order
    /// draws it in front. Returns the part and how many orders were extended.
    pub fn add_part(&mut self, name: &str) -> Result<(u16, usize), String> {
        let before = self.project.clone();
        let p = polypostor::edit::paint::add_part(&mut self.segmentation, name)?;
        let extended = self.project.overrides.add_part(p as usize);
        self.history.record("Add part", before);
        self.store_segmentation();
        Ok((p, extended))
    }

    /// Removes part `p`, its triangles going to `into`, as one undoable step with what
    /// refers to part numbers: cap colours, drawing orders and pins follow the renumbering
    /// (the pins of `p` and `into`, whose outlines change, are dropped). Returns how many pins
    /// were dropped.
    pub fn remove_part(&mut self, p: u16, into: u16) -> Result<usize, String> {
        let before = self.project.clone();
        polypostor::edit::paint::remove_part(&mut self.segmentation, &mut self.project.caps, p, into)?;
        let dropped = self.project.overrides.remove_part(p as usize, into as usize);
        self.history.record("Remove part", before);
        self.store_segmentation();
        Ok(dropped)
    }

    /// One undoable edit of the bake corrections (key frames, orders, pins).
    pub fn edit_overrides(
        &mut self,
        label: &str,
        f: impl FnOnce(&mut polypostor::bake::overrides::BakeOverrides) -> bool,
    ) -> bool {
        let before = self.project.clone();
        if !f(&mut self.project.overrides) {
            return false;
        }
        self.project.overrides.tidy();
        self.history.record(label, before);
        self.dirty = true;
        true
    }

    /// Writes the working segmentation into the project (after a change) and marks it.
    pub fn store_segmentation(&mut self) {
        self.project.segmentation = Some(StoredSegmentation::from_segmentation(&self.segmentation));
        self.dirty = true;
        self.revision += 1;
    }

    /// Puts back a project state from the history.
    pub fn restore(&mut self, project: Project) {
        self.project = project;
        self.segmentation = Self::decode_segmentation(&self.project, &self.character).0;
        self.dirty = self.saved.as_ref() != Some(&self.project);
        self.revision += 1;
    }

    pub fn undo(&mut self) -> Option<String> {
        let (label, state) = self.history.undo(self.project.clone())?;
        self.restore(state);
        Some(label)
    }

    pub fn redo(&mut self) -> Option<String> {
        let (label, state) = self.history.redo(self.project.clone())?;
        self.restore(state);
        Some(label)
    }

    pub fn title(&self) -> String {
        let name = if self.project.name.is_empty() {
            "untitled"
        } else {
            &self.project.name
        };
        format!("{name}{}", if self.dirty { " •" } else { "" })
    }

    pub fn clip_duration(&self, clip: Option<usize>) -> f32 {
        clip.and_then(|i| self.character.clips.get(i))
            .map_or(0.0, |c| c.duration_secs)
    }
}

/// Animation playback.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Playback {
    pub clip: Option<usize>,
    pub time_secs: f32,
    pub playing: bool,
    pub speed: f32,
}

impl Default for Playback {
    fn default() -> Self {
        Self {
            clip: None,
            time_secs: 0.0,
            playing: true,
            speed: 1.0,
        }
    }
}

/// Frame rate of the timeline's frame numbers and steps.
pub const TIMELINE_FPS: f32 = 30.0;
