//! The project document: a versioned JSON file that points at a character and keeps the
//! user's choices. Saving is atomic (write a temporary file beside it, then rename), so a
//! crash mid-save never leaves a half-written project; loading never modifies the file.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

/// The project file format version this build writes.
pub const FORMAT_VERSION: u32 = 1;
/// The file name of a project inside its folder.
pub const PROJECT_FILE: &str = "project.json";
/// The default project, relative to the repository root.
pub const DEFAULT_PROJECT_DIR: &str = "projects/default";

/// The folder, inside a project's folder, that the editor bakes the project into and its Views
/// tab and crowd preview read: the one place inside a project folder a bake may write.
pub const PROJECT_PACK: &str = "crowd.pack";
/// Largest project file read (segmentations are run-length encoded; corrections are small).
pub const MAX_PROJECT_BYTES: u64 = 256 << 20;

#[derive(Debug, thiserror::Error)]
pub enum ProjectError {
    #[error("cannot read project '{path}': {message}")]
    Read { path: PathBuf, message: String },
    #[error("project '{path}' is not a valid project file: {message}")]
    Parse { path: PathBuf, message: String },
    #[error("project '{path}' has format version {found}, newer than this build supports ({FORMAT_VERSION})")]
    TooNew { path: PathBuf, found: u32 },
    #[error("cannot save project to '{path}': {message}")]
    Write { path: PathBuf, message: String },
}

/// Which character the project works on.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CharacterRef {
    /// Path of the .glb/.gltf, relative to the project file's folder (or absolute).
    pub path: String,
    /// Which of the file's axes points up (absent: glTF's +y): set by the artist for a file
    /// exported lying down; every import of the project reads it so.
    #[serde(default, skip_serializing_if = "crate::import::UpAxis::is_default")]
    pub up: crate::import::UpAxis,
}

/// Viewer state worth keeping with the project.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ViewState {
    /// Name of the selected clip.
    pub clip: Option<String>,
    pub playback_speed: Option<f32>,
    /// The folder of the last pack the editor baked or exported for this project (relative
    /// to the project file's folder where it lies below it): what the Views tab shows when
    /// the project is opened again.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub last_pack: Option<String>,
}

/// A segmentation as stored: parts and run-length encoded per-triangle labels.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StoredSegmentation {
    pub parts: Vec<crate::bake::segment::Part>,
    /// Triangle count of the character it was made for.
    pub triangles: usize,
    /// `(label, run length)` pairs covering every triangle in order.
    pub runs: Vec<(u16, u32)>,
}

impl StoredSegmentation {
    pub fn from_segmentation(seg: &crate::bake::segment::Segmentation) -> Self {
        let mut runs: Vec<(u16, u32)> = Vec::new();
        for &l in &seg.labels {
            match runs.last_mut() {
                Some((x, n)) if *x == l => *n += 1,
                _ => runs.push((l, 1)),
            }
        }
        Self {
            parts: seg.parts.clone(),
            triangles: seg.labels.len(),
            runs,
        }
    }

    /// The segmentation, if it fits a character of `triangles` triangles and is consistent.
    pub fn to_segmentation(&self, triangles: usize) -> Result<crate::bake::segment::Segmentation, String> {
        if self.triangles != triangles {
            return Err(format!(
                "it was painted on {} triangles, the character has {triangles}",
                self.triangles
            ));
        }
        let mut labels = Vec::with_capacity(triangles);
        for &(l, n) in &self.runs {
            if l as usize >= self.parts.len() {
                return Err(format!("label {l} refers to a missing part"));
            }
            if labels.len() + n as usize > triangles {
                return Err("more labels than triangles".into());
            }
            labels.extend(std::iter::repeat_n(l, n as usize));
        }
        if labels.len() != triangles {
            return Err(format!("{} labels for {triangles} triangles", labels.len()));
        }
        // Every part named, each name once (a hand-edited file may repeat or empty one; the
        // pack, the inspector and the report tell parts apart by name).
        // The first part of each name keeps it; names are reserved before any rename, so a
        // rename never takes a name a later part has ("A", "A", "A (2)": the second is
        // "A (3)").
        let mut parts = self.parts.clone();
        let key = |n: &str| n.trim().to_lowercase();
        let mut taken: std::collections::HashSet<String> = parts.iter().map(|p| key(&p.name)).collect();
        let mut kept = std::collections::HashSet::new();
        for (i, p) in parts.iter_mut().enumerate() {
            let trimmed = p.name.trim().to_string();
            if !trimmed.is_empty() && kept.insert(key(&trimmed)) {
                p.name = trimmed;
                continue;
            }
            let base = if trimmed.is_empty() {
                format!("Part {}", i + 1)
            } else {
                trimmed
            };
            let mut name = base.clone();
            let mut n = 2;
            while taken.contains(&key(&name)) {
                name = format!("{base} ({n})");
                n += 1;
            }
            taken.insert(key(&name));
            kept.insert(key(&name));
            p.name = name;
        }
        Ok(crate::bake::segment::Segmentation { parts, labels })
    }

    /// What [`StoredSegmentation::to_segmentation`] renamed in `decoded` (empty or repeated
    /// part names), as a warning; `None` when every name is as stored.
    pub fn renamed_note(&self, decoded: &crate::bake::segment::Segmentation) -> Option<String> {
        let renamed: Vec<String> = self
            .parts
            .iter()
            .zip(&decoded.parts)
            .filter(|(a, b)| a.name != b.name)
            .map(|(a, b)| format!("'{}' to '{}'", a.name, b.name))
            .collect();
        (!renamed.is_empty()).then(|| {
            format!(
                "the project's segmentation has empty, repeated or space-padded part names; renamed {}",
                renamed.join(", ")
            )
        })
    }
}

/// The project document.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Project {
    pub format_version: u32,
    pub name: String,
    pub character: CharacterRef,
    #[serde(default)]
    pub view: ViewState,
    /// The painted segmentation (absent: automatic).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub segmentation: Option<StoredSegmentation>,
    /// Cap colours chosen by the artist.
    #[serde(default)]
    pub caps: crate::bake::caps::CapOverrides,
    /// Per-view corrections of the bake (key frame, drawing order, pinned correspondences).
    #[serde(default, skip_serializing_if = "crate::bake::overrides::BakeOverrides::is_empty")]
    pub overrides: crate::bake::overrides::BakeOverrides,
    /// The artist's clip set: the clips a whole-character bake puts in one pack, in order
    /// (empty: one clip, the viewed one).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub clips: Vec<String>,
    /// The bake's settings (absent: the defaults): what `polypostor bake` starts from (its
    /// flags override single fields), what the editor's bake and export use and write back.
    #[serde(default, skip_serializing_if = "crate::bake::settings::BakeSettings::is_default")]
    pub bake: crate::bake::settings::BakeSettings,
}

impl Project {
    /// A new project for a character file, with the path stored relative to `project_dir`
    /// when possible.
    pub fn new_for_character(name: &str, character: &Path, project_dir: &Path) -> Self {
        Self {
            format_version: FORMAT_VERSION,
            name: name.to_string(),
            character: CharacterRef {
                path: relative_path(character, project_dir),
                up: Default::default(),
            },
            view: ViewState::default(),
            segmentation: None,
            caps: Default::default(),
            overrides: Default::default(),
            clips: Vec::new(),
            bake: Default::default(),
        }
    }

    /// The character's absolute path, resolved against the project file's folder.
    /// How to import the project's character.
    pub fn import_options(&self) -> crate::import::ImportOptions {
        crate::import::ImportOptions { up: self.character.up }
    }

    pub fn character_path(&self, project_file: &Path) -> PathBuf {
        resolve_beside(&self.character.path, project_file)
    }

    /// The last pack the editor baked or exported, resolved against the project file's
    /// folder; `None` if none is recorded.
    pub fn last_pack_path(&self, project_file: &Path) -> Option<PathBuf> {
        self.view
            .last_pack
            .as_deref()
            .filter(|p| !p.is_empty())
            .map(|p| resolve_beside(p, project_file))
    }

    /// Loads a project from a `project.json` or from the folder that holds one.
    pub fn load(path: &Path) -> Result<(Self, PathBuf), ProjectError> {
        let file = resolve_project_file(path);
        let text = crate::safe_fs::read_regular_string(&file, MAX_PROJECT_BYTES, "a project file").map_err(|e| {
            ProjectError::Read {
                path: file.clone(),
                message: match e {
                    crate::safe_fs::FsError::Io { message, .. } => message,
                    other => other.to_string(),
                },
            }
        })?;
        // A byte-order mark (Windows editors write one) is no JSON.
        let text = text.strip_prefix('\u{feff}').map(str::to_owned).unwrap_or(text);
        // Read the version first so a newer file is reported as such, not as a parse error.
        #[derive(Deserialize)]
        struct Version {
            format_version: Option<u32>,
        }
        let v: Version = serde_json::from_str(&text).map_err(|e| ProjectError::Parse {
            path: file.clone(),
            message: e.to_string(),
        })?;
        match v.format_version {
            Some(found) if found > FORMAT_VERSION => {
                return Err(ProjectError::TooNew { path: file, found });
            }
            None => {
                return Err(ProjectError::Parse {
                    path: file,
                    message: "missing field `format_version`".into(),
                });
            }
            _ => {}
        }
        // Named by where it is in the file (`bake.views: invalid value …`): "line 1 column
        // 1419" says nothing to someone editing a one-line file.
        let project: Project = serde_json::from_str(&text).map_err(|e| ProjectError::Parse {
            path: file.clone(),
            message: match json_path_at(&text, e.line(), e.column()) {
                Some(at) if !at.is_empty() => format!("{at}: {e}"),
                _ => e.to_string(),
            },
        })?;
        Ok((project, file))
    }

    /// Keys of the project file at `path` that no version of the format reads (a typo such
    /// as `"veiws"`, or `"clip"` at the top instead of in `view`), as `bake.veiws`: the load
    /// ignores them, so the bake would go on with the defaults without a word. Checked at the
    /// top level and in `character`, `view` and `bake`, the objects people edit by hand.
    /// Empty when the file cannot be read (its load says why).
    pub fn unknown_keys(path: &Path) -> Vec<String> {
        let file = resolve_project_file(path);
        let Ok(text) = crate::safe_fs::read_regular_string(&file, MAX_PROJECT_BYTES, "a project file") else {
            return Vec::new();
        };
        let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
        let Ok(serde_json::Value::Object(top)) = serde_json::from_str::<serde_json::Value>(text) else {
            return Vec::new();
        };
        let keys = |v: serde_json::Value| -> Vec<String> {
            match v {
                serde_json::Value::Object(m) => m.keys().cloned().collect(),
                _ => Vec::new(),
            }
        };
        // Every key the format has: a project with every optional part present.
        let mut full = Project::new_for_character("x", Path::new("c.glb"), Path::new("."));
        full.segmentation = Some(StoredSegmentation {
            parts: Vec::new(),
            triangles: 0,
            runs: Vec::new(),
        });
        full.overrides.views.insert(
            0,
            crate::bake::overrides::ViewOverride {
                key_frame: Some(0),
                ..Default::default()
            },
        );
        full.clips = vec!["a".into()];
        full.bake.views += 1;
        let known_top = keys(serde_json::to_value(&full).unwrap_or_default());
        let known = |section: &str| -> Vec<String> {
            match section {
                "character" => keys(
                    serde_json::to_value(CharacterRef {
                        path: String::new(),
                        up: crate::import::UpAxis::PosZ,
                    })
                    .unwrap_or_default(),
                ),
                "view" => keys(
                    serde_json::to_value(ViewState {
                        clip: Some(String::new()),
                        playback_speed: Some(1.0),
                        last_pack: Some(String::new()),
                    })
                    .unwrap_or_default(),
                ),
                _ => keys(serde_json::to_value(crate::bake::settings::BakeSettings::default()).unwrap_or_default()),
            }
        };
        let mut unknown = Vec::new();
        for (k, v) in &top {
            if !known_top.contains(k) {
                unknown.push(k.clone());
            } else if let (true, serde_json::Value::Object(inner)) =
                (["character", "view", "bake"].contains(&k.as_str()), v)
            {
                let names = known(k);
                unknown.extend(inner.keys().filter(|i| !names.contains(i)).map(|i| format!("{k}.{i}")));
            }
        }
        unknown.sort();
        unknown
    }

    /// What to say of [`Project::unknown_keys`] of the project file at `path`, if any.
    pub fn unknown_keys_warning(path: &Path) -> Option<String> {
        let unknown = Self::unknown_keys(path);
        (!unknown.is_empty()).then(|| {
            format!(
                "{}: {} the project format does not have, ignored (a typo?): {}",
                path.display(),
                if unknown.len() == 1 { "a key" } else { "keys" },
                unknown.join(", ")
            )
        })
    }

    /// Saves atomically to `file` (a temporary file in the same folder, then a rename).
    pub fn save(&self, file: &Path) -> Result<(), ProjectError> {
        let werr = |message: String| ProjectError::Write {
            path: file.to_owned(),
            message,
        };
        let text = serde_json::to_string_pretty(self).map_err(|e| werr(e.to_string()))?;
        write_atomic(file, text.as_bytes()).map_err(|e| werr(e.to_string()))
    }
}

/// Where the editor autosaves a project saved at `project_file`: beside it, with
/// `.autosave` appended (`project.json.autosave`). Saving removes it; finding it newer than
/// the project on open offers recovery.
pub fn autosave_file(project_file: &Path) -> PathBuf {
    let name = project_file
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| PROJECT_FILE.into());
    project_file.with_file_name(format!("{name}.autosave"))
}

/// `path` itself if it is a file, else `path/project.json`.
pub fn resolve_project_file(path: &Path) -> PathBuf {
    if path.is_dir() {
        path.join(PROJECT_FILE)
    } else {
        path.to_owned()
    }
}

pub use crate::safe_fs::write_atomic;

/// `target` relative to `base` when they share a prefix, else `target` as given.
/// `path` as stored in a project: absolute, or relative to the project file's folder.
fn resolve_beside(path: &str, project_file: &Path) -> PathBuf {
    let p = Path::new(path);
    if p.is_absolute() {
        p.to_owned()
    } else {
        project_file.parent().unwrap_or(Path::new(".")).join(p)
    }
}

pub fn relative_path(target: &Path, base: &Path) -> String {
    let abs = |p: &Path| std::fs::canonicalize(p).unwrap_or_else(|_| p.to_owned());
    let (t, b) = (abs(target), abs(base));
    let tc: Vec<_> = t.components().collect();
    let bc: Vec<_> = b.components().collect();
    let common = tc.iter().zip(&bc).take_while(|(a, b)| a == b).count();
    if common == 0 {
        return t.to_string_lossy().into_owned();
    }
    let mut rel = PathBuf::new();
    for _ in common..bc.len() {
        rel.push("..");
    }
    for c in &tc[common..] {
        rel.push(c);
    }
    rel.to_string_lossy().replace('\\', "/")
}

/// Where in a JSON document a position (serde_json's 1-based line and byte column) lies, as
/// the keys and indices leading to it: `bake.views`, `overrides.views.3.order[2]`. `None` for
/// a position past the text. Only the structure before the position is read, so a document
/// that is malformed further on still says where the first fault is.
pub fn json_path_at(text: &str, line: usize, column: usize) -> Option<String> {
    enum Frame {
        Object { key: Option<String>, wants_key: bool },
        Array(usize),
    }
    let mut offset = None;
    let mut before = 0usize;
    for (i, l) in text.split_inclusive('\n').enumerate() {
        if i + 1 == line {
            offset = Some(before + column.min(l.len()));
            break;
        }
        before += l.len();
    }
    let offset = offset?;
    let bytes = text.as_bytes();
    let end = offset.min(bytes.len());
    let mut stack: Vec<Frame> = Vec::new();
    let mut i = 0;
    while i < end {
        match bytes[i] {
            b'"' => {
                let start = i + 1;
                i += 1;
                while i < bytes.len() && bytes[i] != b'"' {
                    i += if bytes[i] == b'\\' { 2 } else { 1 };
                }
                let s = text.get(start..i.min(bytes.len())).unwrap_or("");
                if let Some(Frame::Object { key, wants_key: true }) = stack.last_mut() {
                    *key = Some(serde_json::from_str(&format!("\"{s}\"")).unwrap_or_else(|_| s.to_owned()));
                }
            }
            b'{' => stack.push(Frame::Object {
                key: None,
                wants_key: true,
            }),
            b'[' => stack.push(Frame::Array(0)),
            b'}' | b']' => {
                stack.pop();
            }
            b':' => {
                if let Some(Frame::Object { wants_key, .. }) = stack.last_mut() {
                    *wants_key = false;
                }
            }
            b',' => match stack.last_mut() {
                Some(Frame::Object { key, wants_key }) => {
                    *key = None;
                    *wants_key = true;
                }
                Some(Frame::Array(n)) => *n += 1,
                None => {}
            },
            _ => {}
        }
        i += 1;
    }
    let mut path = String::new();
    for f in &stack {
        match f {
            Frame::Object { key: Some(k), .. } => {
                if !path.is_empty() {
                    path.push('.');
                }
                path.push_str(k);
            }
            Frame::Object { key: None, .. } => {}
            Frame::Array(n) => path.push_str(&format!("[{n}]")),
        }
    }
    Some(path)
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_position_in_a_json_document_is_named_by_its_keys() {
        use super::json_path_at;
        // Checked against serde_json's own error positions, one line and pretty-printed.
        #[derive(serde::Deserialize, Debug)]
        #[allow(dead_code)]
        struct Bake {
            views: usize,
        }
        #[derive(serde::Deserialize, Debug)]
        #[allow(dead_code)]
        struct Doc {
            name: String,
            bake: Bake,
            list: Vec<Vec<u8>>,
        }
        let at = |text: &str| {
            let e = serde_json::from_str::<Doc>(text).unwrap_err();
            json_path_at(text, e.line(), e.column()).unwrap()
        };
        assert_eq!(at(r#"{"name":"a","bake":{"views":-3},"list":[]}"#), "bake.views");
        assert_eq!(
            at(r#"{"name":"a, b","bake":{"views":3},"list":[[1],[2,300]]}"#),
            "list[1][1]"
        );
        assert_eq!(
            at("{\n  \"name\": 5,\n  \"bake\": {\"views\": 1}, \"list\": []\n}"),
            "name"
        );
        // Keys with escapes and braces inside strings do not confuse it.
        assert_eq!(
            at(r#"{"name":"{[\"}","bake":{"views":"many"},"list":[]}"#),
            "bake.views"
        );
        // A missing field: the object that lacks it.
        assert_eq!(at(r#"{"name":"a","bake":{},"list":[]}"#), "bake");
        assert_eq!(json_path_at("{}", 5, 1), None);
    }

    use super::*;

    /// Keys the format does not have (typos) are found, at the top and in the objects people
    /// edit; a saved project, full or minimal, has none.
    #[test]
    fn unknown_keys_are_found() {
        let dir = crate::safe_fs::TempDir::new("polypostor-project-keys").unwrap();
        let file = dir.path().join("project.json");
        let mut p = Project::new_for_character("p", Path::new("c.glb"), dir.path());
        p.save(&file).unwrap();
        assert!(Project::unknown_keys(&file).is_empty());
        p.bake.views = 40;
        p.clips = vec!["Walk".into()];
        p.view.last_pack = Some("x.pack".into());
        p.save(&file).unwrap();
        assert!(
            Project::unknown_keys(&file).is_empty(),
            "{:?}",
            Project::unknown_keys(&file)
        );
        let text = r#"{"format_version": 1, "name": "p", "clip": "Wave",
            "character": {"path": "c.glb", "Up": "z"}, "view": {"clip": "Walk"},
            "bake": {"veiws": 4, "resolution": 64}}"#;
        std::fs::write(&file, text).unwrap();
        assert_eq!(Project::unknown_keys(&file), ["bake.veiws", "character.Up", "clip"]);
        assert!(Project::load(&file).is_ok(), "still loads");
    }

    /// A project saved by an editor that writes a byte-order mark, and an up axis written
    /// as the command line spells it (`z`), load.
    #[test]
    fn a_byte_order_mark_and_a_bare_axis_load() {
        let dir = crate::safe_fs::TempDir::new("polypostor-project-bom").unwrap();
        let file = dir.path().join("project.json");
        let text = r#"{"format_version": 1, "name": "p", "character": {"path": "c.glb", "up": "z"}}"#;
        std::fs::write(&file, format!("\u{feff}{text}")).unwrap();
        let (p, _) = Project::load(&file).unwrap();
        assert_eq!(p.character.up, crate::import::UpAxis::PosZ);
        assert_eq!(p.name, "p");
    }

    /// Empty and repeated part names (a hand-edited project) decode to named, distinct parts,
    /// and the rename is said; a segmentation with good names is left as it is.
    #[test]
    fn part_names_decode_named_and_distinct() {
        let part = |name: &str| crate::bake::segment::Part {
            name: name.into(),
            color: [1, 2, 3],
        };
        let stored = StoredSegmentation {
            parts: vec![part("A"), part("a"), part(" "), part("A"), part("B"), part("A (2)")],
            triangles: 6,
            runs: vec![(0, 1), (1, 1), (2, 1), (3, 1), (4, 1), (5, 1)],
        };
        let seg = stored.to_segmentation(6).unwrap();
        let names: Vec<&str> = seg.parts.iter().map(|p| p.name.as_str()).collect();
        assert_eq!(names, ["A", "a (3)", "Part 3", "A (4)", "B", "A (2)"]);
        let note = stored.renamed_note(&seg).expect("said");
        assert!(
            note.contains("'a' to 'a (3)'") && note.contains("'A' to 'A (4)'"),
            "{note}"
        );
        let good = StoredSegmentation::from_segmentation(&seg);
        assert_eq!(good.to_segmentation(6).unwrap(), seg);
        assert_eq!(good.renamed_note(&seg), None);
    }

    #[test]
    fn the_up_axis_is_stored_only_when_it_is_not_gltfs() {
        let dir = std::path::Path::new("/p");
        let mut p = Project::new_for_character("t", &dir.join("a.glb"), dir);
        let plain = serde_json::to_string(&p).unwrap();
        assert!(!plain.contains("\"up\""), "glTF's +y is left out: {plain}");
        p.character.up = crate::import::UpAxis::NegZ;
        let text = serde_json::to_string(&p).unwrap();
        assert!(text.contains("\"up\":\"-z\""), "{text}");
        let back: Project = serde_json::from_str(&text).unwrap();
        assert_eq!(back.character.up, crate::import::UpAxis::NegZ);
        assert_eq!(back.import_options().up, crate::import::UpAxis::NegZ);
        let wrong = text.replace("\"-z\"", "\"sideways\"");
        assert!(
            serde_json::from_str::<Project>(&wrong).is_err(),
            "an unknown axis is refused"
        );
        let old: Project = serde_json::from_str(&plain).unwrap();
        assert_eq!(old.character.up, crate::import::UpAxis::PosY);
    }

    #[test]
    fn save_then_load_round_trips() {
        let dir = std::env::temp_dir().join(format!("pp-project-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut p = Project::new_for_character("t", &dir.join("chars/a.glb"), &dir);
        p.view.clip = Some("Walk".into());
        let file = dir.join(PROJECT_FILE);
        p.save(&file).unwrap();
        let (q, f) = Project::load(&dir).unwrap();
        assert_eq!(p, q);
        assert_eq!(f, file);
        assert_eq!(q.character.path, "chars/a.glb");
        assert_eq!(q.character_path(&file), dir.join("chars/a.glb"));
        // No temporary file is left behind.
        let leftovers: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .filter_map(|e| e.ok())
            .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
            .collect();
        assert!(leftovers.is_empty());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn segmentation_round_trips_through_run_lengths() {
        let c = crate::default_character::generate();
        let seg = crate::bake::segment::auto_segment(&c);
        let stored = StoredSegmentation::from_segmentation(&seg);
        assert!(
            stored.runs.len() < seg.labels.len() / 4,
            "runs do not compress: {}",
            stored.runs.len()
        );
        assert_eq!(stored.to_segmentation(c.triangle_count()).unwrap(), seg);
        assert!(stored.to_segmentation(c.triangle_count() + 1).is_err());
        let mut bad = stored.clone();
        bad.runs[0].0 = 99;
        assert!(bad.to_segmentation(c.triangle_count()).is_err());
    }

    #[test]
    fn broken_and_newer_files_are_reported_and_untouched() {
        let dir = std::env::temp_dir().join(format!("pp-project-bad-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join(PROJECT_FILE);
        std::fs::write(&file, "{ not json").unwrap();
        let e = Project::load(&file).unwrap_err();
        assert!(matches!(e, ProjectError::Parse { .. }), "{e}");
        assert_eq!(std::fs::read_to_string(&file).unwrap(), "{ not json");
        std::fs::write(
            &file,
            r#"{"format_version": 99, "name": "x", "character": {"path": "a"}}"#,
        )
        .unwrap();
        let e = Project::load(&file).unwrap_err();
        assert!(e.to_string().contains("99"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
