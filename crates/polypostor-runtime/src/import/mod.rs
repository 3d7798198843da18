//! glTF 2.0 import: `.glb`, and `.gltf` with external or data-URI buffers and images.
//!
//! [`import_path`] / [`import_slice`] turn a file into a [`Character`]: the default scene's
//! skinned primitives merged into one mesh with its skeleton and all animation clips. Meshes
//! without a skin join rigidly bound to their own node (props parented to a joint follow it);
//! a file with no skin at all becomes a one-joint static character, unless its animations
//! move its mesh nodes (an animated prop): then each mesh node is a rigid bone following its
//! node, as the skinned files' rigid meshes are. Every offset and count is checked
//! against the data before use, so malformed files give an [`ImportError`] naming the
//! problem, never a panic or an unbounded allocation. Harmless problems become
//! [`Character::warnings`].

mod accessor;
mod build;
mod glb;

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::{Mat4, Quat, Vec3};
use gltf::json;
use json::validation::Checked;

use crate::character::{Channel, ChannelValues, Character, Clip, Interpolation, Material, Texture, Transform, Vertex};

/// Largest file (and external buffer or image) the importer reads.
pub use crate::limits::MAX_IMPORT_FILE_BYTES as MAX_FILE_BYTES;
/// Largest texture side accepted.
pub const MAX_TEXTURE_SIDE: u32 = crate::limits::MAX_IMPORT_TEXTURE_SIDE;

/// Why a file could not be imported.
#[derive(Debug, thiserror::Error)]
pub enum ImportError {
    /// The model file could not be read, or is not a regular file. (An external buffer that
    /// cannot be read surfaces as [`ImportError::Invalid`], an unreadable image as a warning.)
    #[error("cannot read '{path}': {message}")]
    Io {
        /// The file that could not be read.
        path: PathBuf,
        /// What went wrong: the system's message, or what kind of file it is instead.
        message: String,
    },
    /// The model file is larger than [`MAX_FILE_BYTES`].
    #[error("'{0}' is too large to import")]
    TooLarge(PathBuf),
    /// The binary GLB container is malformed (header, length, chunk layout or chunk types).
    #[error("invalid GLB container: {0}")]
    Glb(String),
    /// The glTF JSON is empty, starts with a byte-order mark, or does not parse as glTF.
    #[error("invalid JSON: {0}")]
    Json(String),
    /// The asset's `version` or `minVersion` is not of the form `MAJOR.MINOR`.
    #[error("invalid glTF: {0}")]
    Validation(String),
    /// A file this importer does not take: a glTF version other than 2.x, a required extension it
    /// does not implement, more than 65,535 bones, or an accessor layout it cannot read.
    #[error("unsupported glTF: {0}")]
    Unsupported(String),
    /// The file's data is inconsistent: missing or out-of-range references, a node hierarchy
    /// that is not a forest, accessors of the wrong type or size, more nodes than
    /// [`crate::limits::MAX_NODES`], or a buffer that could not be loaded where it is needed.
    #[error("invalid glTF data: {0}")]
    Invalid(String),
    /// A buffer could not be loaded: no URI and no GLB BIN chunk, an unreadable or refused URI,
    /// or fewer bytes than it declares. It reaches callers inside [`ImportError::Invalid`],
    /// naming the buffer view that needed it.
    #[error("buffer {index}: {message}")]
    Buffer {
        /// Index of the buffer in the file's `buffers`.
        index: usize,
        /// Why it could not be loaded.
        message: String,
    },
    /// The default scene has no triangles to import (no meshes, or only points and lines).
    #[error("the default scene has no triangle meshes to import")]
    NoGeometry,
}

/// A clip whose keys all start later than this (seconds) is played from its first key. One
/// frame at the default 10 fps: a shorter hold never shows in a bake, and the one frame at
/// 24 fps that converters leave before the first key (CesiumMan, RiggedSimple) stays as
/// authored.
pub const LATE_START_SECS: f32 = 0.1;

pub use crate::character::UpAxis;

/// How to read a file beyond what it says itself.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ImportOptions {
    /// Which of the file's axes points up ([`UpAxis::PosY`], glTF's, unless the artist said
    /// otherwise).
    pub up: UpAxis,
}

/// Imports a `.glb` or `.gltf` file from disk.
pub fn import_path(path: &Path) -> Result<Character, ImportError> {
    import_path_with(path, ImportOptions::default())
}

/// [`import_path`] with the artist's [`ImportOptions`].
pub fn import_path_with(path: &Path, options: ImportOptions) -> Result<Character, ImportError> {
    let bytes = read_file(path)?;
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "character".into());
    import_slice_with(&bytes, path.parent(), &name, options)
}

fn read_file(path: &Path) -> Result<Vec<u8>, ImportError> {
    use crate::safe_fs::FsError;
    crate::safe_fs::read_regular(path, MAX_FILE_BYTES, "a glTF file or its external data").map_err(|e| match e {
        FsError::TooLarge { path, .. } => ImportError::TooLarge(path),
        FsError::NotRegular { path, kind } => ImportError::Io {
            path,
            message: format!("is {kind}, not a regular file"),
        },
        FsError::Io { path, message } => ImportError::Io { path, message },
    })
}

/// Imports from bytes. `base_dir` resolves relative URIs of external buffers and images
/// (`None`: only embedded data is allowed).
pub fn import_slice(bytes: &[u8], base_dir: Option<&Path>, name: &str) -> Result<Character, ImportError> {
    import_slice_with(bytes, base_dir, name, ImportOptions::default())
}

/// [`import_slice`] with the artist's [`ImportOptions`].
pub fn import_slice_with(
    bytes: &[u8],
    base_dir: Option<&Path>,
    name: &str,
    options: ImportOptions,
) -> Result<Character, ImportError> {
    if let Some(why) = lfs_pointer(bytes) {
        return Err(ImportError::Io {
            path: PathBuf::from(name),
            message: why,
        });
    }
    let mut warnings = Vec::new();
    // A binary file that is not JSON is read as GLB, so a bad header is reported as such.
    let binary = !bytes.starts_with(&[0xEF, 0xBB, 0xBF]) && bytes.iter().take(12).any(|&b| b == 0 || b >= 0x80);
    let (json_bytes, bin) = if glb::looks_like_glb(bytes) || binary {
        let g = glb::parse(bytes, &mut warnings)?;
        (g.json, g.bin)
    } else {
        (bytes, None)
    };
    if json_bytes.is_empty() {
        return Err(ImportError::Json("the file is empty".into()));
    }
    if json_bytes.starts_with(&[0xEF, 0xBB, 0xBF]) {
        return Err(ImportError::Json(
            "the JSON starts with a byte-order mark (BOM), which glTF forbids".into(),
        ));
    }
    // Neither GLB nor JSON (a text file given a .glb name): said as such, not as bad JSON.
    if bin.is_none() && json_bytes.iter().find(|b| !b.is_ascii_whitespace()) != Some(&b'{') {
        return Err(ImportError::Json(
            "neither a GLB (which starts with 'glTF') nor glTF JSON (an object, '{'): not a glTF file".into(),
        ));
    }
    let root: json::Root = json::deserialize::from_slice(json_bytes).map_err(|e| ImportError::Json(e.to_string()))?;
    check_asset(&root, &mut warnings)?;
    // Every index is checked where it is used (`get`, never `[]`), so no separate
    // validation pass is needed; gltf's own is stricter than the spec (it rejects accessors
    // without a bufferView) and indexes unchecked in places.
    let buffers = load_buffers(&root, bin, base_dir);
    Builder {
        root: &root,
        buffers: &buffers,
        base_dir,
        warnings,
        decoded_texture_bytes: Default::default(),
    }
    .build(name)
    .map(|mut character| {
        // Materials that cut out every fragment they could draw.
        // (Materials none of whose submeshes draw: the vertices' colour alpha differs.)
        let nothing = character.submeshes_drawing_nothing();
        let mut hidden: Vec<usize> = character
            .submeshes
            .iter()
            .zip(&nothing)
            .filter(|(_, n)| **n)
            .map(|(s, _)| s.material)
            .collect();
        hidden.sort_unstable();
        hidden.dedup();
        hidden.retain(|&m| {
            character
                .submeshes
                .iter()
                .zip(&nothing)
                .all(|(s, n)| s.material != m || *n)
        });
        for m in hidden {
            let mat = &character.materials[m];
            character.warnings.push(format!(
                "material '{}' draws nothing: its alpha never reaches its cut-off of {:.2} (alpha mode MASK, or BLEND drawn as a cut-out at 0.5)",
                mat.name, mat.alpha_cutoff
            ));
        }
        // Stood up first: where its origin lies and which way it walks are read upright.
        character.up_axis = options.up;
        if options.up != UpAxis::PosY {
            character.move_rigidly(options.up.rotation(), Vec3::ZERO);
            character.warnings.push(format!(
                "read with {} as up (as asked: --up or the project; glTF's is +y): stood up",
                options.up
            ));
        } else if let Some(hint) = lying_hint(&character) {
            character.warnings.push(hint);
        }
        if let Some(hint) = upside_down_hint(&character) {
            character.warnings.push(hint);
        }
        if let Some(shift) = crate::timeline::off_origin(&character) {
            character.move_rigidly(glam::Quat::IDENTITY, shift);
            character.warnings.push(format!(
                "it stands {:.3} units from its origin, off its own footprint: moved there (horizontally) \
                 so that crowds place and turn it about its middle",
                shift.length()
            ));
        }
        if let (Some(turn), _) = crate::timeline::face_forward_and_play_in_place(&mut character) {
            character.warnings.push(format!(
                "its walking clips head {:.0}° away from +z, the front glTF specifies: turned {:.0}° \
                 about the vertical so that it walks forward in crowds",
                -turn.to_degrees(),
                turn.to_degrees()
            ));
        }
        character
    })
}

/// A hint for a character that stands on its head as read (an up axis of the wrong sign,
/// `--up -z` for a Z-up export): its joints named for the head sit lower, by more than a
/// quarter of its height, than those named for the feet (foot, toe, ankle). Only said: a
/// rig without such names, or an acrobat, is not judged.
fn upside_down_hint(character: &Character) -> Option<String> {
    let world = character.skeleton.rest_world();
    let (mut head, mut feet) = ((0.0f32, 0usize), (0.0f32, 0usize));
    for (n, m) in character.skeleton.nodes.iter().zip(&world) {
        let name = n.name.to_ascii_lowercase();
        let y = m.w_axis.y;
        if !y.is_finite() {
            continue;
        }
        if name.contains("head") {
            head = (head.0 + y, head.1 + 1);
        } else if name.contains("foot") || name.contains("toe") || name.contains("ankle") {
            feet = (feet.0 + y, feet.1 + 1);
        }
    }
    if head.1 == 0 || feet.1 == 0 {
        return None;
    }
    let (head_y, feet_y) = (head.0 / head.1 as f32, feet.0 / feet.1 as f32);
    let pose = crate::animation::Pose::rest(character);
    let (skinned, _) = crate::animation::skin_vertices(character, &pose);
    let (min, max) = crate::character::bounds(skinned.iter().copied());
    let height = max.y - min.y;
    let up = character.up_axis;
    let flipped = match up {
        UpAxis::PosY => UpAxis::NegY,
        UpAxis::NegY => UpAxis::PosY,
        UpAxis::PosZ => UpAxis::NegZ,
        UpAxis::NegZ => UpAxis::PosZ,
        UpAxis::PosX => UpAxis::NegX,
        UpAxis::NegX => UpAxis::PosX,
    };
    (height > 0.0 && head_y < feet_y - 0.25 * height).then(|| {
        format!(
            "read with {up} as up, its head joints are below its feet: it may stand on its head; \
             read it with {flipped} as up (`--up {flipped}`, or the editor's Up axis beside the character's summary)"
        )
    })
}

/// A hint for a character that may lie on its back: one whose rest pose is more than four
/// times as long along z as it is tall, as a Z-up export read as glTF shows a standing
/// figure (its height along z, its depth along y; the rest pose, since a walk's first pose
/// spreads the legs along the depth). Only said, never acted on: snakes, carpets and swords
/// lying flat are that shape too.
fn lying_hint(character: &Character) -> Option<String> {
    let pose = crate::animation::Pose::rest(character);
    let (skinned, _) = crate::animation::skin_vertices(character, &pose);
    let (min, max) = crate::character::bounds(skinned.iter().copied());
    let size = max - min;
    (size.y > 0.0 && size.z > 4.0 * size.y).then(|| {
        format!(
            "it is {:.1} times as long (along z) as it is tall: if it lies on its back or front \
             (a Z-up export), read it with +z or -z as up (`--up z`, or the editor's Up axis beside the character's summary)",
            size.z / size.y
        )
    })
}

fn check_asset(root: &json::Root, warnings: &mut Vec<String>) -> Result<(), ImportError> {
    let parse = |v: &str| -> Option<(u32, u32)> {
        let (a, b) = v.split_once('.')?;
        if a.is_empty() || b.is_empty() || !a.bytes().chain(b.bytes()).all(|c| c.is_ascii_digit()) {
            return None;
        }
        Some((a.parse().ok()?, b.parse().ok()?))
    };
    let version = &root.asset.version;
    match parse(version) {
        Some((2, _)) => {}
        Some((major, minor)) => {
            return Err(ImportError::Unsupported(format!(
                "asset version {major}.{minor} (only glTF 2.x is supported)"
            )));
        }
        None => {
            return Err(ImportError::Validation(format!(
                "asset.version '{version}' is not of the form MAJOR.MINOR"
            )));
        }
    }
    if let Some(min) = &root.asset.min_version {
        match parse(min) {
            Some((2, 0)) => {}
            Some((major, minor)) => {
                return Err(ImportError::Unsupported(format!(
                    "asset minVersion {major}.{minor} is newer than 2.0"
                )));
            }
            None => {
                return Err(ImportError::Validation(format!(
                    "asset.minVersion '{min}' is not of the form MAJOR.MINOR"
                )));
            }
        }
    }
    for ext in &root.extensions_required {
        match ext.as_str() {
            // Quantized attributes are read natively.
            "KHR_mesh_quantization" => {}
            // The base colour texture's placement is applied to its texture coordinates.
            "KHR_texture_transform" => {}
            // Purely visual extensions: the base colour is still right without them.
            e if e.starts_with("KHR_materials_") => {
                warnings.push(format!("required extension {e} is ignored"));
            }
            // Lights and metadata: the bake lights every view its own way, and neither changes
            // the character's shape, colours or motion.
            e @ ("KHR_lights_punctual" | "EXT_lights_image_based" | "KHR_xmp_json_ld" | "KHR_xmp") => {
                warnings.push(format!(
                    "required extension {e} is ignored (it does not change the character)"
                ));
            }
            e => {
                return Err(ImportError::Unsupported(format!("the file requires extension {e}")));
            }
        }
    }
    Ok(())
}

/// Decodes a `data:` URI's base64 payload.
fn decode_data_uri(uri: &str) -> Option<Result<Vec<u8>, String>> {
    let rest = uri.strip_prefix("data:")?;
    let Some((header, payload)) = rest.split_once(',') else {
        return Some(Err("malformed data URI (no comma)".into()));
    };
    if !header.ends_with(";base64") {
        return Some(Err("data URI is not base64-encoded".into()));
    }
    use base64::Engine;
    Some(
        base64::engine::general_purpose::STANDARD
            .decode(payload.trim())
            .map_err(|e| format!("bad base64 in data URI: {e}")),
    )
}

fn percent_decode(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' && i + 2 < b.len() {
            if let Some(v) = std::str::from_utf8(&b[i + 1..i + 3])
                .ok()
                .and_then(|h| u8::from_str_radix(h, 16).ok())
            {
                out.push(v);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Resolves a relative URI to a file path inside `base_dir`, the model's folder: URIs are
/// relative references without a scheme, and the file they name (after symbolic links) must
/// lie in that folder or below it. `..` that leaves the folder, absolute paths and links
/// pointing elsewhere are refused, so a model never reads other files of the machine.
fn resolve_uri(uri: &str, base_dir: Option<&Path>) -> Result<PathBuf, String> {
    if uri.is_empty() {
        return Err("empty URI".into());
    }
    if let Some(colon) = uri.find(':') {
        let scheme = &uri[..colon];
        let is_scheme = !scheme.is_empty() && scheme.chars().all(|c| c.is_ascii_alphanumeric() || "+-.".contains(c));
        if is_scheme || colon == 0 {
            return Err(format!(
                "URI '{uri}' is not a relative file reference (only relative paths and data URIs are read)"
            ));
        }
    }
    let decoded = percent_decode(uri);
    let rel = Path::new(&decoded);
    if rel.is_absolute() || decoded.starts_with('/') || decoded.starts_with('\\') || decoded.contains('\0') {
        return Err(format!(
            "URI '{uri}' is an absolute path (only files in the model's folder are read)"
        ));
    }
    let base = base_dir.ok_or_else(|| format!("URI '{uri}' refers to an external file, but no folder is known"))?;
    // Lexically first: the path, its `..` taken against the folder's own names, must stay in
    // the folder (`../x/t.png` from folder `x` comes back into it).
    if rel.components().any(|c| {
        !matches!(
            c,
            std::path::Component::ParentDir | std::path::Component::Normal(_) | std::path::Component::CurDir
        )
    }) {
        return Err(format!("URI '{uri}' is not a relative path"));
    }
    let lexical = |p: &Path| -> PathBuf {
        let mut out = PathBuf::new();
        for c in p.components() {
            match c {
                std::path::Component::ParentDir => {
                    out.pop();
                }
                std::path::Component::CurDir => {}
                other => out.push(other),
            }
        }
        out
    };
    let here = if base.as_os_str().is_empty() {
        Path::new(".")
    } else {
        base
    };
    let absolute_base = std::path::absolute(here).map_err(|e| format!("URI '{uri}': {e}"))?;
    if !lexical(&absolute_base.join(rel)).starts_with(lexical(&absolute_base)) {
        return Err(format!(
            "URI '{uri}' leaves the model's folder (only files in {} and below are read)",
            base.display()
        ));
    }
    let path = here.join(rel);
    // Then for real, through symbolic links. A folder that cannot be resolved refuses every
    // external file (a model opened from the current folder has the empty folder "": its
    // resolution failed, and the link check was skipped); a missing file is reported when it
    // is read, any other failure to resolve it refuses it.
    let real_base = std::fs::canonicalize(here).map_err(|e| {
        format!(
            "URI '{uri}': the model's folder {} cannot be resolved ({e})",
            here.display()
        )
    })?;
    let real = match std::fs::canonicalize(&path) {
        Ok(real) => Some(real),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
        Err(e) => return Err(format!("URI '{uri}' cannot be resolved ({e})")),
    };
    if let Some(real) = real
        && !real.starts_with(&real_base)
    {
        return Err(format!(
            "URI '{uri}' leads outside the model's folder (to {}; only files in {} and below are read)",
            real.display(),
            here.display()
        ));
    }
    Ok(path)
}

fn load_uri(uri: &str, base_dir: Option<&Path>) -> Result<Vec<u8>, String> {
    if let Some(r) = decode_data_uri(uri) {
        return r;
    }
    let path = resolve_uri(uri, base_dir)?;
    let bytes = read_file(&path).map_err(|e| e.to_string())?;
    match lfs_pointer(&bytes) {
        Some(why) => Err(format!("'{uri}': {why}")),
        None => Ok(bytes),
    }
}

/// What to say when `bytes` are a Git LFS pointer: the few lines of text a repository cloned
/// without Git LFS holds in place of each large file (models, buffers, textures); `None` for
/// anything else. Read as glTF it would fail as "invalid JSON" or a short buffer, which sends
/// the user looking for damage that is not there.
pub fn lfs_pointer(bytes: &[u8]) -> Option<String> {
    const HEADER: &[u8] = b"version https://git-lfs.github.com/spec/";
    if bytes.len() > 1024 || !bytes.starts_with(HEADER) {
        return None;
    }
    let text = String::from_utf8_lossy(bytes);
    let size = text
        .lines()
        .find_map(|l| l.strip_prefix("size "))
        .and_then(|s| s.trim().parse::<u64>().ok());
    let standing = match size {
        Some(n) => format!("{} bytes of text standing for a file of {n} bytes", bytes.len()),
        None => format!("{} bytes of text", bytes.len()),
    };
    Some(format!(
        "it is a Git LFS pointer ({standing}), not the file itself: fetch the real file (`git lfs pull` in the repository it came from)"
    ))
}

/// Loads every buffer. A buffer that cannot be loaded is kept as its error, reported only
/// if the character actually reads from it.
fn load_buffers(root: &json::Root, bin: Option<&[u8]>, base_dir: Option<&Path>) -> Vec<Result<Vec<u8>, ImportError>> {
    let load = |index: usize, b: &json::buffer::Buffer| -> Result<Vec<u8>, ImportError> {
        let err = |message: String| ImportError::Buffer { index, message };
        let mut data = match &b.uri {
            None => match (index, bin) {
                (0, Some(bin)) => bin.to_vec(),
                (0, None) => return Err(err("has no URI and the file has no GLB BIN chunk".into())),
                _ => return Err(err("has no URI (only buffer 0 may refer to the GLB BIN chunk)".into())),
            },
            Some(uri) => load_uri(uri, base_dir).map_err(err)?,
        };
        let declared = b.byte_length.0;
        if (data.len() as u64) < declared {
            return Err(err(format!(
                "declares {declared} bytes but only {} are present",
                data.len()
            )));
        }
        data.truncate(declared as usize);
        Ok(data)
    };
    root.buffers.iter().enumerate().map(|(i, b)| load(i, b)).collect()
}

fn node_local(n: &json::scene::Node) -> Transform {
    if let Some(m) = n.matrix {
        let t = Transform::from_mat4(Mat4::from_cols_array(&m));
        if t.translation.is_finite() && t.rotation.is_finite() && t.scale.is_finite() {
            return t;
        }
        return Transform::IDENTITY;
    }
    let translation = n.translation.map_or(Vec3::ZERO, Vec3::from_array);
    let rotation = n.rotation.map_or(Quat::IDENTITY, |q| Quat::from_array(q.0).normalize());
    let scale = n.scale.map_or(Vec3::ONE, Vec3::from_array);
    Transform {
        translation: if translation.is_finite() {
            translation
        } else {
            Vec3::ZERO
        },
        rotation: if rotation.is_finite() { rotation } else { Quat::IDENTITY },
        scale: if scale.is_finite() { scale } else { Vec3::ONE },
    }
}

/// Where a mesh node's vertices are bound.
enum Binding {
    /// Skinned: bone index of each skin joint slot.
    Skin(Vec<u16>),
    /// Rigid: all vertices follow one bone.
    Rigid(u16),
}

struct Builder<'a> {
    root: &'a json::Root,
    buffers: &'a [Result<Vec<u8>, ImportError>],
    base_dir: Option<&'a Path>,
    warnings: Vec<String>,
    /// Bytes of the textures decoded so far (RGBA8), bounded by
    /// [`crate::limits::MAX_IMPORT_TEXTURE_BYTES`].
    decoded_texture_bytes: std::cell::Cell<u64>,
}

impl Builder<'_> {
    fn warn(&mut self, w: impl Into<String>) {
        let w = w.into();
        if !self.warnings.contains(&w) {
            self.warnings.push(w);
        }
    }

    /// Parent of every node, checking that the hierarchy is a forest.
    fn parents(&self) -> Result<Vec<Option<usize>>, ImportError> {
        let n = self.root.nodes.len();
        if n > crate::limits::MAX_NODES {
            return Err(ImportError::Invalid(format!(
                "{n} nodes, more than the limit of {}",
                crate::limits::MAX_NODES
            )));
        }
        let mut parent = vec![None; n];
        for (i, node) in self.root.nodes.iter().enumerate() {
            for c in node.children.iter().flatten() {
                let c = c.value();
                if c >= n {
                    return Err(ImportError::Invalid(format!("node {i} has missing child {c}")));
                }
                if c == i {
                    return Err(ImportError::Invalid(format!("node {i} is its own child")));
                }
                if let Some(p) = parent[c] {
                    return Err(ImportError::Invalid(format!("node {c} has two parents ({p} and {i})")));
                }
                parent[c] = Some(i);
            }
        }
        // With one parent per node, a cycle is a walk up that never ends. Each node is
        // walked over once: a walk stops at a node already known to reach a root.
        let mut state = vec![0u8; n]; // 0: unknown, 1: on the current walk, 2: reaches a root
        let mut walk = Vec::new();
        for start in 0..n {
            let mut at = start;
            walk.clear();
            while state[at] == 0 {
                state[at] = 1;
                walk.push(at);
                match parent[at] {
                    Some(p) => at = p,
                    None => break,
                }
            }
            if state[at] == 1 && parent[at].is_some() {
                return Err(ImportError::Invalid(format!(
                    "the node hierarchy has a cycle through node {at}"
                )));
            }
            for &w in &walk {
                state[w] = 2;
            }
        }
        Ok(parent)
    }

    /// The nodes of the scene to import, in pre-order.
    /// Whether any node under scene `s`'s roots carries a mesh (a bounded walk: each node
    /// once).
    fn scene_has_mesh(&self, s: usize) -> bool {
        let Some(scene) = self.root.scenes.get(s) else {
            return false;
        };
        let mut seen = vec![false; self.root.nodes.len()];
        let mut stack: Vec<usize> = scene.nodes.iter().map(|n| n.value()).collect();
        while let Some(i) = stack.pop() {
            let Some(node) = self.root.nodes.get(i) else { continue };
            if std::mem::replace(&mut seen[i], true) {
                continue;
            }
            // A mesh with triangles (strips and fans count; points and lines do not).
            if let Some(mesh) = node.mesh.and_then(|m| self.root.meshes.get(m.value()))
                && mesh.primitives.iter().any(|p| {
                    matches!(
                        p.mode,
                        Checked::Valid(
                            json::mesh::Mode::Triangles
                                | json::mesh::Mode::TriangleStrip
                                | json::mesh::Mode::TriangleFan
                        )
                    )
                })
            {
                return true;
            }
            stack.extend(node.children.iter().flatten().map(|c| c.value()));
        }
        false
    }

    /// The scene to import: the file's default; without one, the first scene that holds a
    /// mesh (else the first), said when that is not the first.
    fn chosen_scene(&mut self) -> Option<usize> {
        if let Some(s) = self.root.scene {
            return Some(s.value());
        }
        if self.root.scenes.is_empty() {
            return None;
        }
        let s = (0..self.root.scenes.len())
            .find(|&s| self.scene_has_mesh(s))
            .unwrap_or(0);
        if s != 0 {
            self.warn(format!(
                "the file names no default scene and its first holds no mesh: scene {s}{} imported",
                self.root.scenes[s]
                    .name
                    .as_ref()
                    .map(|n| format!(" ('{n}')"))
                    .unwrap_or_default()
            ));
        }
        Some(s)
    }

    fn scene_nodes(&mut self, parent: &[Option<usize>]) -> Result<Vec<usize>, ImportError> {
        let roots: Vec<usize> = match self.chosen_scene() {
            Some(s) => {
                let scene = self
                    .root
                    .scenes
                    .get(s)
                    .ok_or_else(|| ImportError::Invalid(format!("default scene {s} does not exist")))?;
                scene.nodes.iter().map(|n| n.value()).collect()
            }
            None => (0..self.root.nodes.len()).filter(|&i| parent[i].is_none()).collect(),
        };
        let mut out = Vec::new();
        let mut seen = vec![false; self.root.nodes.len()];
        let mut stack: Vec<usize> = roots.into_iter().rev().collect();
        while let Some(i) = stack.pop() {
            let Some(node) = self.root.nodes.get(i) else {
                return Err(ImportError::Invalid(format!("scene refers to missing node {i}")));
            };
            if std::mem::replace(&mut seen[i], true) {
                continue; // listed twice in the scene; already taken
            }
            out.push(i);
            for c in node.children.iter().flatten().rev() {
                stack.push(c.value());
            }
        }
        Ok(out)
    }

    fn material(
        &mut self,
        index: Option<usize>,
        textures: &mut Vec<Texture>,
        texture_map: &mut HashMap<usize, Option<usize>>,
    ) -> Result<Material, ImportError> {
        let Some(i) = index else {
            return Ok(Material::default());
        };
        let Some(m) = self.root.materials.get(i) else {
            return Err(ImportError::Invalid(format!("material {i} does not exist")));
        };
        let pbr = &m.pbr_metallic_roughness;
        let mut factor = pbr.base_color_factor.0;
        if !factor.iter().all(|x| x.is_finite()) {
            factor = [1.0; 4];
        }
        let base_color_texture = match &pbr.base_color_texture {
            Some(info) => {
                let t = info.index.value();
                match texture_map.get(&t) {
                    Some(&k) => k,
                    None => {
                        let k = match self.texture(t) {
                            Ok(tex) => {
                                textures.push(tex);
                                Some(textures.len() - 1)
                            }
                            Err(e) => {
                                self.warn(format!(
                                    "base colour texture {t} (first used by material {i}) could not be loaded ({e}); every material using it is drawn in its base colour alone"
                                ));
                                None
                            }
                        };
                        texture_map.insert(t, k);
                        k
                    }
                }
            }
            None => None,
        };
        // Emission (a glowing visor, a sign) is not drawn: every representation is lit base
        // colour. Said, so that a dark character with a glowing face is not a surprise.
        let emissive = m.emissive_factor.0;
        if m.emissive_texture.is_some() || emissive.iter().any(|&x| x.is_finite() && x > 0.0) {
            let name = m.name.as_deref().map_or(String::new(), |n| format!(" '{n}'"));
            self.warn(format!(
                "material {i}{name}: its emissive (glowing) colour is not drawn; only the base colour is"
            ));
        }
        use json::material::AlphaMode;
        let alpha_cutoff = match m.alpha_mode {
            Checked::Valid(AlphaMode::Opaque) => 0.0,
            Checked::Valid(AlphaMode::Mask) => {
                let c = m.alpha_cutoff.map_or(0.5, |c| c.0);
                if c.is_finite() { c.clamp(0.0, 1.0) } else { 0.5 }
            }
            Checked::Valid(AlphaMode::Blend) => {
                self.warn(format!(
                    "material {i}: alpha blending is drawn as a cut-out at alpha 0.5"
                ));
                0.5
            }
            Checked::Invalid => {
                return Err(ImportError::Invalid(format!("material {i}: invalid alphaMode")));
            }
        };
        // The texture's sampler's wrap modes (glTF: repeat where there is no sampler).
        let mut wrap = [crate::character::TextureWrap::Repeat; 2];
        if let Some(info) = &pbr.base_color_texture
            && let Some(tex) = self.root.textures.get(info.index.value())
            && let Some(sampler) = tex.sampler.and_then(|k| self.root.samplers.get(k.value()))
        {
            for (slot, mode) in [&sampler.wrap_s, &sampler.wrap_t].into_iter().enumerate() {
                if let Checked::Valid(mode) = mode {
                    wrap[slot] = crate::character::TextureWrap::from_gltf(mode.as_gl_enum())
                        .unwrap_or(crate::character::TextureWrap::Repeat);
                }
            }
        }
        Ok(Material {
            name: m.name.clone().unwrap_or_else(|| format!("material {i}")),
            base_color_factor: factor,
            base_color_texture,
            double_sided: m.double_sided,
            alpha_cutoff,
            wrap,
        })
    }

    fn texture(&self, index: usize) -> Result<Texture, String> {
        let root = self.root;
        let tex = root
            .textures
            .get(index)
            .ok_or_else(|| format!("texture {index} does not exist"))?;
        let img_index = tex.source.value();
        let img = root
            .images
            .get(img_index)
            .ok_or_else(|| format!("image {img_index} does not exist"))?;
        let bytes: Vec<u8> = match (&img.buffer_view, &img.uri) {
            (Some(v), _) => accessor::view_bytes(root, self.buffers, v.value())
                .map_err(|e| e.to_string())?
                .to_vec(),
            (None, Some(uri)) => load_uri(uri, self.base_dir)?,
            (None, None) => {
                return Err(format!("image {img_index} has neither a bufferView nor a URI"));
            }
        };
        let reader = || {
            image::ImageReader::new(std::io::Cursor::new(&bytes[..]))
                .with_guessed_format()
                .map_err(|e| format!("image {img_index}: {e}"))
        };
        // The size from the header first: nothing is decoded past the documented limits.
        let (w, h) = reader()?
            .into_dimensions()
            .map_err(|e| format!("image {img_index}: {e}"))?;
        if w > MAX_TEXTURE_SIDE || h > MAX_TEXTURE_SIDE {
            return Err(format!(
                "image {img_index} is {w}×{h} pixels, more than the limit of {MAX_TEXTURE_SIDE} per side"
            ));
        }
        let rgba = u64::from(w) * u64::from(h) * 4;
        let total = self.decoded_texture_bytes.get() + rgba;
        if total > crate::limits::MAX_IMPORT_TEXTURE_BYTES {
            return Err(format!(
                "image {img_index} ({w}×{h}) brings the decoded textures to {}, more than the limit of {}",
                crate::limits::human_bytes(total),
                crate::limits::human_bytes(crate::limits::MAX_IMPORT_TEXTURE_BYTES)
            ));
        }
        self.decoded_texture_bytes.set(total);
        let mut reader = reader()?;
        let mut limits = image::Limits::default();
        limits.max_image_width = Some(MAX_TEXTURE_SIDE);
        limits.max_image_height = Some(MAX_TEXTURE_SIDE);
        // 16-bit RGBA at most, plus the 8-bit copy.
        limits.max_alloc = Some(rgba * 2 + (1 << 20));
        reader.limits(limits);
        let decoded = reader
            .decode()
            .map_err(|e| format!("image {img_index}: {e}"))?
            .to_rgba8();
        let name = img
            .name
            .clone()
            .or_else(|| img.uri.as_ref().filter(|u| !u.starts_with("data:")).cloned())
            .unwrap_or_else(|| format!("image {img_index}"));
        Ok(Texture {
            name,
            width: decoded.width(),
            height: decoded.height(),
            rgba8: decoded.into_raw(),
        })
    }

    /// A morph weights channel for `targets` (the animated node's morph targets in the
    /// character), or `None` (said by the caller) when its output does not hold one finite
    /// weight per target and key.
    fn morph_channel(
        &mut self,
        what: &str,
        sampler: &json::animation::Sampler,
        times: Vec<f32>,
        targets: &[usize],
    ) -> Option<crate::character::MorphChannel> {
        let interpolation = match sampler.interpolation {
            Checked::Valid(json::animation::Interpolation::Linear) => Interpolation::Linear,
            Checked::Valid(json::animation::Interpolation::Step) => Interpolation::Step,
            Checked::Valid(json::animation::Interpolation::CubicSpline) => Interpolation::CubicSpline,
            Checked::Invalid => return None,
        };
        let per_key = if interpolation == Interpolation::CubicSpline {
            3
        } else {
            1
        };
        let out = accessor::read_f32(self.root, self.buffers, sampler.output.value()).ok()?;
        let expected = times.len() * per_key * targets.len();
        if out.components != 1 || out.data.len() != expected {
            self.warn(format!(
                "{what}: morph weights output has {} values, expected {expected} ({} keys × {} targets); skipped",
                out.data.len(),
                times.len(),
                targets.len()
            ));
            return None;
        }
        if let Some(k) = out.data.iter().position(|x| !x.is_finite()) {
            self.warn(format!(
                "{what}: morph weight {k} of {expected} is {} (not a number); skipped",
                out.data[k]
            ));
            return None;
        }
        let largest = out.data.iter().fold(0.0f32, |m, x| m.max(x.abs()));
        if largest > MORPH_WEIGHT_PLAUSIBLE {
            self.warn(format!(
                "{what}: morph weights reach {largest} (they usually lie within 0..1): the targets are added that many times over; kept as given"
            ));
        }
        Some(crate::character::MorphChannel {
            targets: targets.to_vec(),
            interpolation,
            times,
            values: out.data,
        })
    }

    /// Whether a morph weights channel's values ever leave the node's default weights (the
    /// node's, else its mesh's, else 0): an unreadable channel counts as moving.
    fn weights_move(&self, sampler: &json::animation::Sampler, node: usize, keys: usize) -> bool {
        let root = self.root;
        let Ok(out) = accessor::read_f32(root, self.buffers, sampler.output.value()) else {
            return true;
        };
        let cubic = matches!(
            sampler.interpolation,
            Checked::Valid(json::animation::Interpolation::CubicSpline)
        );
        let per_key = if cubic { 3 } else { 1 };
        if keys == 0 || out.data.len() % (keys * per_key) != 0 {
            return true;
        }
        let targets = out.data.len() / (keys * per_key);
        let defaults: &[f32] = root
            .nodes
            .get(node)
            .and_then(|n| {
                n.weights
                    .as_deref()
                    .or_else(|| root.meshes.get(n.mesh?.value())?.weights.as_deref())
            })
            .unwrap_or(&[]);
        out.data.chunks_exact(targets).enumerate().any(|(k, w)| {
            // A cubic spline's in and out tangents: only the values count (zero tangents
            // between equal values keep the curve flat).
            let tangent = cubic && k % 3 != 1;
            w.iter().enumerate().any(|(i, &x)| {
                let rest = if tangent {
                    0.0
                } else {
                    defaults.get(i).copied().unwrap_or(0.0)
                };
                !((x - rest).abs() <= 1e-6)
            })
        })
    }

    /// The file nodes whose morph weights some clip moves away from their defaults.
    fn animated_weight_nodes(&self) -> std::collections::HashSet<usize> {
        let mut out = std::collections::HashSet::new();
        for anim in &self.root.animations {
            for ch in &anim.channels {
                if ch.target.path != Checked::Valid(json::animation::Property::MorphTargetWeights) {
                    continue;
                }
                let node = ch.target.node.value();
                let Some(sampler) = anim.samplers.get(ch.sampler.value()) else {
                    continue;
                };
                let keys =
                    accessor::read_f32(self.root, self.buffers, sampler.input.value()).map_or(0, |t| t.data.len());
                if !out.contains(&node) && keys > 0 && self.weights_move(sampler, node, keys) {
                    out.insert(node);
                }
            }
        }
        out
    }

    fn clips(
        &mut self,
        node_map: &HashMap<usize, usize>,
        rigged: bool,
        morph_nodes: &HashMap<usize, Vec<usize>>,
    ) -> Result<Vec<Clip>, ImportError> {
        let root = self.root;
        let mut clips = Vec::new();
        let mut skipped_skinless = 0usize;
        let mut morph_clips: Vec<String> = Vec::new();
        for (ai, anim) in root.animations.iter().enumerate() {
            // An unnamed clip is named after its index once every clip is read
            // (`unique_clip_names`), so that it never takes a name a clip was given.
            let name = anim.name.clone().unwrap_or_default();
            let shown = if name.trim().is_empty() {
                format!("{ai}")
            } else {
                format!("'{name}'")
            };
            let mut channels = Vec::new();
            let mut morph_channels: Vec<crate::character::MorphChannel> = Vec::new();
            let mut duration = 0.0f32;
            for (ci, ch) in anim.channels.iter().enumerate() {
                let what = format!("animation {shown} channel {ci}");
                let Some(sampler) = anim.samplers.get(ch.sampler.value()) else {
                    self.warn(format!("{what}: missing sampler; skipped"));
                    continue;
                };
                if ch.target.node.value() >= root.nodes.len() {
                    self.warn(format!(
                        "{what}: animates node {}, which does not exist; skipped",
                        ch.target.node.value()
                    ));
                    continue;
                }
                let times = match accessor::read_f32(root, self.buffers, sampler.input.value()) {
                    Ok(t) if t.components == 1 => t.data,
                    Ok(_) => {
                        self.warn(format!("{what}: input must be SCALAR; skipped"));
                        continue;
                    }
                    Err(e) => {
                        self.warn(format!("{what}: {e}; skipped"));
                        continue;
                    }
                };
                if times.iter().any(|t| !t.is_finite() || *t < 0.0) || times.windows(2).any(|w| w[1] <= w[0]) {
                    self.warn(format!(
                        "{what}: key times are not non-negative and strictly increasing; skipped"
                    ));
                    continue;
                }
                if let Some(&last) = times.last() {
                    duration = duration.max(last);
                }
                let path = match ch.target.path {
                    Checked::Valid(p) => p,
                    Checked::Invalid => {
                        self.warn(format!("{what}: invalid target path; skipped"));
                        continue;
                    }
                };
                use json::animation::Property;
                if path == Property::MorphTargetWeights {
                    // Kept where the weights move the shape of a mesh the character has:
                    // exporters write channels that hold the default weights throughout
                    // (RobotExpressive's face in all 14 clips), which play exactly as the
                    // still shape.
                    let Some(targets) = morph_nodes.get(&ch.target.node.value()) else {
                        continue;
                    };
                    match self.morph_channel(&what, sampler, times, targets) {
                        Some(c) => morph_channels.push(c),
                        None => {
                            if !morph_clips.contains(&shown) {
                                morph_clips.push(shown.clone());
                            }
                        }
                    }
                    continue;
                }
                let file_node = ch.target.node.value();
                let node = if rigged {
                    match node_map.get(&file_node) {
                        Some(&n) => n,
                        None => continue, // animates a node that does not move the character
                    }
                } else {
                    skipped_skinless += 1;
                    continue;
                };
                let interpolation = match sampler.interpolation {
                    Checked::Valid(json::animation::Interpolation::Linear) => Interpolation::Linear,
                    Checked::Valid(json::animation::Interpolation::Step) => Interpolation::Step,
                    Checked::Valid(json::animation::Interpolation::CubicSpline) => Interpolation::CubicSpline,
                    Checked::Invalid => {
                        self.warn(format!("{what}: invalid interpolation; skipped"));
                        continue;
                    }
                };
                let out = match accessor::read_f32(root, self.buffers, sampler.output.value()) {
                    Ok(o) => o,
                    Err(e) => {
                        self.warn(format!("{what}: {e}; skipped"));
                        continue;
                    }
                };
                let want_comps = if path == Property::Rotation { 4 } else { 3 };
                let per_key = if interpolation == Interpolation::CubicSpline {
                    3
                } else {
                    1
                };
                if out.components != want_comps || out.count() != times.len() * per_key {
                    self.warn(format!(
                        "{what}: output has {} values of {} components, expected {} of {want_comps}; skipped",
                        out.count(),
                        out.components,
                        times.len() * per_key
                    ));
                    continue;
                }
                if out.data.iter().any(|x| !x.is_finite()) {
                    self.warn(format!("{what}: output holds non-finite values; skipped"));
                    continue;
                }
                let values = match path {
                    Property::Translation => {
                        ChannelValues::Translation(out.data.chunks_exact(3).map(Vec3::from_slice).collect())
                    }
                    Property::Scale => ChannelValues::Scale(out.data.chunks_exact(3).map(Vec3::from_slice).collect()),
                    Property::Rotation => ChannelValues::Rotation(
                        out.data
                            .chunks_exact(4)
                            .enumerate()
                            .map(|(k, q)| {
                                let q = Quat::from_slice(q);
                                // Tangents of cubic splines are not unit quaternions.
                                if per_key == 3 && k % 3 != 1 { q } else { q.normalize() }
                            })
                            .map(|q| if q.is_finite() { q } else { Quat::IDENTITY })
                            .collect(),
                    ),
                    Property::MorphTargetWeights => unreachable!("handled above"),
                };
                channels.push(Channel {
                    node,
                    interpolation,
                    times,
                    values,
                });
            }
            // Keys that all start late (an exporter's absolute times: frames 100–150 of a
            // timeline) would hold the first pose that long before anything moves, and a
            // crowd would loop that hold: the clip starts at its first key instead.
            let start = channels
                .iter()
                .filter_map(|c| c.times.first().copied())
                .fold(f32::INFINITY, f32::min);
            let start = morph_channels
                .iter()
                .filter_map(|c| c.times.first().copied())
                .fold(start, f32::min);
            // (A clip of one key per channel at 5 s is a still pose: it becomes a clip of
            // no length, not a 5-second hold of 50 identical frames.)
            if start.is_finite() && start > LATE_START_SECS && start <= duration {
                for c in &mut channels {
                    c.times.iter_mut().for_each(|t| *t -= start);
                }
                for c in &mut morph_channels {
                    c.times.iter_mut().for_each(|t| *t -= start);
                }
                self.warn(format!(
                    "animation {shown}: every key is at {start:.3} s or later; played from its first key \
                     ({:.3} s long, not {duration:.3} s)",
                    duration - start
                ));
                duration -= start;
            }
            clips.push(Clip {
                name,
                duration_secs: duration,
                channels,
                in_place_velocity: glam::Vec3::ZERO,
                morph_channels,
            });
        }
        if !morph_clips.is_empty() {
            self.warn(format!(
                "morph target weight channels that could not be read are not played; those shapes stay at their default weights ({}: {})",
                plural(morph_clips.len(), "clip"),
                morph_clips.join(", ")
            ));
        }
        if skipped_skinless > 0 {
            self.warn(format!(
                "the file has no skin: imported as a rigid one-joint character; {skipped_skinless} node animation channels do not move it"
            ));
        }
        for (from, to) in unique_clip_names(&mut clips) {
            self.warn(format!(
                "clip '{from}' is called '{to}' here (clip names are chosen by name: --clips, the pack's clip table)"
            ));
        }
        Ok(clips)
    }
}

fn scene_name(root: &json::Root) -> Option<String> {
    let s = root.scene.map(|s| s.value()).unwrap_or(0);
    root.scenes
        .get(s)
        .and_then(|s| s.name.clone())
        // Exporters' generic scene names say nothing; the file name is better then.
        .filter(|n| !n.is_empty() && !n.to_lowercase().contains("scene") && n != "Root")
}

/// Converts strips and fans to a triangle list. Every index triple is kept, the joins that
/// stitch strips together (an index repeated) included: they draw nothing, and a project's
/// painted parts are stored per triangle of this list, so dropping them would lose its
/// painting for files saved before.
fn triangulate(mode: json::mesh::Mode, idx: &[u32]) -> Vec<u32> {
    use json::mesh::Mode;
    let mut out = Vec::new();
    match mode {
        Mode::Triangles => {
            for t in idx.chunks_exact(3) {
                out.extend_from_slice(t);
            }
        }
        Mode::TriangleStrip => {
            for i in 2..idx.len() {
                if i % 2 == 0 {
                    out.extend_from_slice(&[idx[i - 2], idx[i - 1], idx[i]]);
                } else {
                    out.extend_from_slice(&[idx[i - 1], idx[i - 2], idx[i]]);
                }
            }
        }
        Mode::TriangleFan => {
            for i in 2..idx.len() {
                out.extend_from_slice(&[idx[0], idx[i - 1], idx[i]]);
            }
        }
        _ => {}
    }
    out
}

/// Area-weighted smooth normals for vertices `base..` from a triangle list.
fn compute_normals(vertices: &mut [Vertex], indices: &[u32], base: u32) {
    let mut acc = vec![Vec3::ZERO; vertices.len()];
    for t in indices.chunks_exact(3) {
        let [a, b, c] = [t[0] - base, t[1] - base, t[2] - base].map(|x| x as usize);
        let n = (vertices[b].position - vertices[a].position).cross(vertices[c].position - vertices[a].position);
        for i in [a, b, c] {
            acc[i] += n;
        }
    }
    for (v, n) in vertices.iter_mut().zip(acc) {
        v.normal = n.normalize_or(Vec3::Y);
    }
}

/// Largest extent (metres) above which a character is reported as probably made in other units.
pub const HUGE_METRES: f32 = 50.0;
/// Largest extent (metres) below which a character is reported as probably made in other units.
pub const TINY_METRES: f32 = 0.01;

/// A warning for a character whose bind-pose bounds are implausibly large or small for
/// something that walks in a crowd: glTF lengths are metres, and the crowd shows a character
/// at that size, so a model exported in centimetres without its 0.01 scale comes out 100×
/// too big.
fn size_warning((min, max): (glam::Vec3, glam::Vec3)) -> Option<String> {
    let extent = (max - min).max_element();
    if !extent.is_finite() {
        return None;
    }
    // The power of ten that brings it nearest a person's size (about 2 m), named as a unit
    // where it is one (a model in millimetres asks for 0.001, not centimetres' 0.01).
    let n = (extent / 2.0).log10().round().clamp(-30.0, 30.0) as i32;
    let scale = if n >= 0 { 1.0 / 10f32.powi(n) } else { 10f32.powi(-n) };
    let unit = match scale {
        k if (k - 0.01).abs() < 1e-4 => "centimetres",
        k if (k - 0.001).abs() < 1e-5 => "millimetres",
        _ => "other units",
    };
    if extent > HUGE_METRES {
        Some(format!(
            "the character is {extent:.0} m across: glTF lengths are metres and the crowd shows it at that size; if it was made in {unit}, export it with a {scale} scale on its root node ({:.2} m across)",
            extent * scale
        ))
    } else if extent > 0.0 && extent < TINY_METRES {
        // Millimetres while they read (0.02 mm), a power of ten below that (1.5e-7 m).
        let size = if extent >= 1e-5 {
            format!("{:.2} mm", extent * 1000.0)
        } else {
            format!("{extent:.2e} m")
        };
        Some(format!(
            "the character is {size} across: glTF lengths are metres and the crowd shows it at that size; check the exporter's unit scale (×{scale:e} makes it {:.2} m)",
            extent * scale
        ))
    } else {
        None
    }
}

/// The matrix that carries normals under `w`: the inverse transpose of its linear part (the
/// linear part itself where that cannot be inverted).
fn normal_matrix(w: glam::Mat4) -> glam::Mat3 {
    let m = glam::Mat3::from_mat4(w);
    if m.determinant().abs() > 1e-30 {
        m.inverse().transpose()
    } else {
        m
    }
}

#[cfg(test)]
mod normal_tests {
    use glam::{Mat4, Quat, Vec3};

    #[test]
    fn normals_stay_perpendicular_to_surfaces_under_uneven_scale() {
        let transforms = [
            Mat4::from_scale(Vec3::new(2.0, 1.0, 1.0)),
            Mat4::from_scale_rotation_translation(Vec3::new(0.01, 3.0, 0.5), Quat::from_rotation_y(0.7), Vec3::ONE),
            Mat4::from_scale(Vec3::splat(100.0)),
        ];
        let normals = [Vec3::new(1.0, 1.0, 0.0), Vec3::new(0.3, -0.2, 0.9), Vec3::Z];
        for w in transforms {
            for n in normals {
                let n = n.normalize();
                // Two tangents of the surface, carried as positions are.
                let t1 = n.any_orthonormal_vector();
                let t2 = n.cross(t1);
                let m = (super::normal_matrix(w) * n).normalize();
                for t in [t1, t2] {
                    let tw = w.transform_vector3(t).normalize();
                    assert!(m.dot(tw).abs() < 1e-4, "{w:?} {n:?}: {}", m.dot(tw));
                }
                // Still on the outward side.
                assert!(m.dot(w.transform_vector3(n)) > 0.0);
            }
        }
        // A degenerate transform does not give NaN.
        let flat = Mat4::from_scale(Vec3::new(1.0, 0.0, 1.0));
        assert!((super::normal_matrix(flat) * Vec3::Y).is_finite());
    }
}

/// Gives every clip a name the command line and the pack's clip table can choose it by: no
/// comma (`--clips` separates names with them; it becomes ';'), not `all` (`--clips all`), and
/// no name twice (a second `Walk` becomes `Walk (2)`). Returns what was renamed, from → to.
pub(crate) fn unique_clip_names(clips: &mut [Clip]) -> Vec<(String, String)> {
    let mut renamed = Vec::new();
    let mut taken: std::collections::HashSet<String> = std::collections::HashSet::new();
    for i in 0..clips.len() {
        let original = clips[i].name.clone();
        // Control characters (a newline, a tab) would break every table the name is
        // printed in; a name longer than MAX_CLIP_NAME_CHARS widens them all.
        let printable: String = original
            .chars()
            .map(|c| if c.is_control() { ' ' } else { c })
            .take(MAX_CLIP_NAME_CHARS)
            .collect();
        let mut base = printable.trim().replace(',', ";");
        if base.eq_ignore_ascii_case("all") {
            base = format!("{base} (clip)");
        }
        // An unnamed clip is called after its index, silently, as before; a clip given that
        // name keeps it (the unnamed one moves aside).
        let unnamed = base.is_empty();
        if unnamed {
            base = format!("Animation {i}");
        }
        let mut name = base.clone();
        let mut k = 2;
        // Later clips' own names are kept for them: a renamed clip does not take one.
        while taken.contains(&name) || clips[i + 1..].iter().any(|c| c.name == name && name != original) {
            name = format!("{base} ({k})");
            k += 1;
        }
        taken.insert(name.clone());
        if name != original {
            clips[i].name = name.clone();
            if !(unnamed && original.is_empty()) {
                renamed.push((original, name));
            }
        }
    }
    renamed
}

/// Longest clip name kept (in characters): a longer one is cut, with a warning.
pub const MAX_CLIP_NAME_CHARS: usize = 64;

#[cfg(test)]
mod clip_name_tests {
    use super::*;

    fn named(names: &[&str]) -> Vec<Clip> {
        names
            .iter()
            .map(|n| Clip {
                name: n.to_string(),
                duration_secs: 1.0,
                channels: Vec::new(),
                in_place_velocity: glam::Vec3::ZERO,
                morph_channels: Vec::new(),
            })
            .collect()
    }

    #[test]
    fn every_clip_gets_a_name_it_can_be_chosen_by() {
        let mut clips = named(&["Walk", "Walk", "Run, fast", "Run; fast", "all", "Walk (2)", "Idle"]);
        let renamed = unique_clip_names(&mut clips);
        let names: Vec<&str> = clips.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "Walk",
                "Walk (3)",
                "Run; fast (2)",
                "Run; fast",
                "all (clip)",
                "Walk (2)",
                "Idle"
            ]
        );
        assert_eq!(renamed.len(), 3, "{renamed:?}");
        // Unique, free of commas, never `all`; names that were fine stay as they were.
        let mut seen = std::collections::HashSet::new();
        assert!(names.iter().all(|n| seen.insert(*n) && !n.contains(',') && *n != "all"));
        let mut fine = named(&["Walk", "Run", "Idle"]);
        assert!(unique_clip_names(&mut fine).is_empty());
        // An unnamed clip never takes a name a clip was given (index 1 is "Animation 1"
        // by default, which clip 2 is called), and is named silently.
        let mut unnamed = named(&["Walk", "", "Animation 1", "Animation 3", "  "]);
        let renamed = unique_clip_names(&mut unnamed);
        let names: Vec<&str> = unnamed.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(
            names,
            ["Walk", "Animation 1 (2)", "Animation 1", "Animation 3", "Animation 4"]
        );
        assert_eq!(renamed, [("  ".to_string(), "Animation 4".to_string())]);
        // Control characters become spaces; long names are cut.
        let long = "x".repeat(300);
        let mut odd = named(&["Line\nbreak\tand tab", &long]);
        unique_clip_names(&mut odd);
        assert_eq!(odd[0].name, "Line break and tab");
        assert_eq!(odd[1].name.chars().count(), MAX_CLIP_NAME_CHARS);
    }
}

/// Largest morph weight an import takes without a word: weights usually lie within 0..1
/// (a little over 1 for exaggeration); beyond this the file is said to be odd.
const MORPH_WEIGHT_PLAUSIBLE: f32 = 100.0;

/// `n` and `word`, made plural with an `s` unless `n` is 1: "1 clip", "3 clips".
pub fn plural(n: usize, word: &str) -> String {
    format!("{n} {word}{}", if n == 1 { "" } else { "s" })
}
