//! Editor state that the UI reads and commands change: the open project, its character,
//! and playback.

use std::path::PathBuf;
use std::sync::Arc;

use polypostor::Character;
use polypostor::project::Project;

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
    /// Show the crowd preview (true) or the character (false).
    ShowCrowd(bool),
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
    pub summary: polypostor::character::Summary,
    /// Unsaved changes.
    pub dirty: bool,
    /// Increases with every loaded character (the viewport re-uploads on change).
    pub generation: u64,
}

impl Document {
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
