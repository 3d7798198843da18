//! File-system safety shared by every reader and writer of the tool:
//!
//! - **Bounded reads of regular files only** ([`read_regular`]): a symbolic link to
//!   `/dev/zero`, a FIFO or a device is refused before it is opened for reading (and the
//!   opened file is checked again), and no read goes past a stated limit, whatever the file
//!   claims or grows to.
//! - **Outputs that never clobber** ([`check_bake_output`], [`check_output_file`]): a bake may
//!   replace only a folder this tool wrote (its manifest says so and it holds nothing else),
//!   a file output may overwrite only a file this tool wrote (a PNG carrying the tool's
//!   `Software` text, a JSON with its `generator` key, a GLB whose glTF names it as
//!   generator).
//! - **Staging folders** of writers killed before they finished (`.NAME.writing-PID`,
//!   `.NAME.old-PID` beside the target) are removed by the next writer once their process is
//!   gone ([`clean_stale_staging`]).
//! - **Temporary folders removed on exit, Ctrl-C included** ([`TempDir`]).

use std::io::Read;
use std::path::{Component, Path, PathBuf};

/// What the tool writes into PNGs (`Software` text chunk) and JSON (`generator`) to know
/// them again.
pub const GENERATOR: &str = concat!("Polypostor Studio ", env!("CARGO_PKG_VERSION"));
/// The prefix every version's [`GENERATOR`] starts with.
pub const GENERATOR_PREFIX: &str = "Polypostor Studio";

/// Why a bounded read ([`read_regular`], [`read_regular_string`]) refused or failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FsError {
    /// The file could not be opened or read (missing, no permission, an I/O failure), or
    /// [`read_regular_string`] found it is not UTF-8 text.
    #[error("cannot read '{path}': {message}")]
    Io {
        /// The file asked for.
        path: PathBuf,
        /// The operating system's error text (or the UTF-8 decoding error).
        message: String,
    },
    /// The path (or the target of a symbolic link there) is not a regular file: a folder, a
    /// FIFO, a device or a socket. It is refused before any byte is read.
    #[error("'{path}' is {kind}, not a regular file")]
    NotRegular {
        /// The path asked for.
        path: PathBuf,
        /// What it is instead, in words ("a FIFO", "a folder"; see [`kind_of`]).
        kind: &'static str,
    },
    /// The file holds more bytes than the read allows.
    #[error("'{path}' is {len} bytes, more than the limit of {limit} bytes for {what}")]
    TooLarge {
        /// The file asked for.
        path: PathBuf,
        /// Its size in bytes; for a file that grew while being read, the bytes read before
        /// the read stopped (one past `limit`).
        len: u64,
        /// Most bytes the read accepts.
        limit: u64,
        /// What the limit is for, in words (e.g. "a manifest"), as the error message names it.
        what: &'static str,
    },
}

/// What kind of thing a file-system entry is, in words.
pub fn kind_of(ft: &std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if ft.is_fifo() {
            return "a FIFO";
        }
        if ft.is_char_device() {
            return "a character device";
        }
        if ft.is_block_device() {
            return "a block device";
        }
        if ft.is_socket() {
            return "a socket";
        }
    }
    if ft.is_dir() {
        "a folder"
    } else if ft.is_symlink() {
        "a symbolic link"
    } else if ft.is_file() {
        "a regular file"
    } else {
        "not a regular file"
    }
}

/// Reads a whole regular file (symbolic links are followed to their target, which must be a
/// regular file too) of at most `limit` bytes. `what` names the limit in the error.
pub fn read_regular(path: &Path, limit: u64, what: &'static str) -> Result<Vec<u8>, FsError> {
    let io = |e: std::io::Error| FsError::Io {
        path: path.to_owned(),
        message: e.to_string(),
    };
    let meta = std::fs::metadata(path).map_err(io)?;
    if !meta.is_file() {
        return Err(FsError::NotRegular {
            path: path.to_owned(),
            kind: kind_of(&meta.file_type()),
        });
    }
    let too_large = |len: u64| FsError::TooLarge {
        path: path.to_owned(),
        len,
        limit,
        what,
    };
    if meta.len() > limit {
        return Err(too_large(meta.len()));
    }
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        // Never block on a FIFO swapped in after the check above.
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK);
    }
    let file = options.open(path).map_err(io)?;
    let meta = file.metadata().map_err(io)?;
    if !meta.is_file() {
        return Err(FsError::NotRegular {
            path: path.to_owned(),
            kind: kind_of(&meta.file_type()),
        });
    }
    let mut out = Vec::with_capacity(meta.len().min(limit) as usize);
    file.take(limit.saturating_add(1)).read_to_end(&mut out).map_err(io)?;
    if out.len() as u64 > limit {
        return Err(too_large(out.len() as u64));
    }
    Ok(out)
}

/// [`read_regular`] as UTF-8 text.
pub fn read_regular_string(path: &Path, limit: u64, what: &'static str) -> Result<String, FsError> {
    let bytes = read_regular(path, limit, what)?;
    String::from_utf8(bytes).map_err(|e| FsError::Io {
        path: path.to_owned(),
        message: format!("not UTF-8 text: {e}"),
    })
}

/// `path` made absolute against the current folder, with `.` and `..` resolved lexically
/// (no file-system access; symbolic links are not followed).
pub fn absolute_lexical(path: &Path) -> PathBuf {
    let joined = if path.is_absolute() {
        path.to_owned()
    } else {
        std::env::current_dir()
            .unwrap_or_else(|_| PathBuf::from("/"))
            .join(path)
    };
    let mut out = PathBuf::new();
    for c in joined.components() {
        match c {
            Component::ParentDir => {
                out.pop();
            }
            Component::CurDir => {}
            other => out.push(other),
        }
    }
    out
}

/// The real location of `path`: its longest existing ancestor resolved through symbolic
/// links, with the rest appended.
pub fn resolved(path: &Path) -> PathBuf {
    let abs = absolute_lexical(path);
    let mut existing = abs.clone();
    let mut rest = Vec::new();
    loop {
        if let Ok(real) = std::fs::canonicalize(&existing) {
            let mut out = real;
            for r in rest.iter().rev() {
                out.push(r);
            }
            return out;
        }
        match (existing.file_name().map(|n| n.to_owned()), existing.parent()) {
            (Some(name), Some(parent)) => {
                rest.push(name);
                existing = parent.to_owned();
            }
            _ => return abs,
        }
    }
}

/// Files every bake folder of the tool's formats may hold, whatever its manifests say.
const BAKE_FIXED_NAMES: &[&str] = &[
    "manifest.json",
    "report.json",
    "vertices.bin",
    "indices.bin",
    "representations.json",
    "np3d.bin",
    "np3d_color.png",
    "np3d_color.ktx2",
    "rigid.bin",
];

/// Sub-folders a bake folder may hold: the bake's debug images (`--debug-images`) and
/// `compare`'s plots and sheet. They hold only files carrying the tool's mark
/// ([`carries_tool_mark`]).
const BAKE_SUBFOLDERS: &[&str] = &["debug", "compare"];

/// The names of files a bake folder may hold: what the pack, the representations and the
/// report write, by name and number (`atlas_012.ktx2`), and the [`BAKE_SUBFOLDERS`]. A name
/// alone does not make a file the tool's: [`check_bake_output`] also asks that numbered
/// files be named by the folder's manifests.
pub fn is_bake_file_name(name: &str) -> bool {
    const PATTERNS: &[(&str, &str)] = &[
        ("atlas_", ".png"),
        ("normal_", ".png"),
        ("impostor_color_", ".png"),
        ("impostor_normal_", ".png"),
        ("far_impostor_color_", ".png"),
        ("far_impostor_normal_", ".png"),
        ("atlas_", ".ktx2"),
        ("normal_", ".ktx2"),
        ("impostor_color_", ".ktx2"),
        ("far_impostor_color_", ".ktx2"),
        ("impostor_normal_", ".ktx2"),
        ("far_impostor_normal_", ".ktx2"),
        ("impostor_part_", ".png"),
        ("far_impostor_part_", ".png"),
    ];
    BAKE_FIXED_NAMES.contains(&name)
        || BAKE_SUBFOLDERS.contains(&name)
        || PATTERNS.iter().any(|(pre, suf)| {
            name.strip_prefix(pre)
                .and_then(|r| r.strip_suffix(suf))
                .is_some_and(|num| !num.is_empty() && num.bytes().all(|b| b.is_ascii_digit()))
        })
}

/// Whether `path` is a regular file carrying the tool's mark: a PNG whose `Software` text
/// (in the chunks before its image data, read from the first 64 KiB only) or a JSON object
/// (at most 256 MiB) whose `generator` starts with [`GENERATOR_PREFIX`] (what [`write_png`]
/// and [`write_json`] write). Cheap enough to run over a folder of large images.
pub fn carries_tool_mark(path: &Path) -> bool {
    let Ok(meta) = std::fs::symlink_metadata(path) else {
        return false;
    };
    if !meta.is_file() {
        return false;
    }
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_lowercase())
        .unwrap_or_default();
    if name.ends_with(".png") {
        marked(path, OutputFile::Png)
    } else if name.ends_with(".json") {
        marked(path, OutputFile::Json)
    } else {
        false
    }
}

/// Whether regular file `path` carries the tool's mark as a file of `kind`: a PNG's
/// `Software` text (read from its first 64 KiB, where the chunks before the image data are),
/// a JSON object's `generator` (at most 256 MiB), a GLB's glTF `asset.generator`.
fn marked(path: &Path, kind: OutputFile) -> bool {
    match kind {
        OutputFile::Png => {
            let Ok(file) = std::fs::File::open(path) else {
                return false;
            };
            let mut head = Vec::new();
            file.take(64 << 10).read_to_end(&mut head).is_ok()
                && png_text_before_data(&head, "Software").is_some_and(|t| t.starts_with(GENERATOR_PREFIX))
        }
        OutputFile::Json => read_regular(path, 256 << 20, "a JSON file")
            .ok()
            .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
            .is_some_and(|v| v["generator"].as_str().is_some_and(|g| g.starts_with(GENERATOR_PREFIX))),
        OutputFile::Glb => read_regular(path, crate::limits::MAX_IMPORT_FILE_BYTES, "a glTF file")
            .ok()
            .is_some_and(|b| glb_generator(&b).is_some_and(|g| g.starts_with(GENERATOR_PREFIX))),
    }
}

/// The text of a PNG's `tEXt` chunk `keyword` among the chunks of `head` (the file's first
/// bytes) before its first image data; `None` if the signature is wrong or it is not there.
fn png_text_before_data(head: &[u8], keyword: &str) -> Option<String> {
    const SIGNATURE: &[u8] = b"\x89PNG\r\n\x1a\n";
    let mut at = SIGNATURE.len();
    if head.get(..at)? != SIGNATURE {
        return None;
    }
    while at + 8 <= head.len() {
        let len = u32::from_be_bytes(head[at..at + 4].try_into().ok()?) as usize;
        let kind = &head[at + 4..at + 8];
        let data = head.get(at + 8..(at + 8).checked_add(len)?)?;
        match kind {
            b"IDAT" | b"IEND" => return None,
            b"tEXt" => {
                if let Some(zero) = data.iter().position(|&b| b == 0)
                    && &data[..zero] == keyword.as_bytes()
                {
                    return Some(data[zero + 1..].iter().map(|&b| b as char).collect());
                }
            }
            _ => {}
        }
        at += 12 + len;
    }
    None
}

/// The plain file names (no folder parts) the folder's `manifest.json` and
/// `representations.json` give as files: the keys of their `checksums` tables (every file
/// written, from pack format 5 on) and the values of `atlas`, `normal_atlas` and `*_file`
/// keys (older packs). Not every string: a part or clip may be named like a file.
fn names_in_manifests(dir: &Path) -> std::collections::HashSet<String> {
    fn plain(s: &str) -> bool {
        !s.is_empty() && !s.contains(['/', '\\']) && s != "." && s != ".."
    }
    fn walk(v: &serde_json::Value, out: &mut std::collections::HashSet<String>) {
        match v {
            serde_json::Value::Array(a) => a.iter().for_each(|x| walk(x, out)),
            serde_json::Value::Object(o) => {
                for (k, x) in o {
                    if k == "checksums"
                        && let serde_json::Value::Object(files) = x
                    {
                        out.extend(files.keys().filter(|n| plain(n)).cloned());
                    } else if (k == "atlas" || k == "normal_atlas" || k.ends_with("_file"))
                        && let Some(n) = x.as_str().filter(|n| plain(n))
                    {
                        out.insert(n.to_string());
                    } else {
                        walk(x, out);
                    }
                }
            }
            _ => {}
        }
    }
    let mut names = std::collections::HashSet::new();
    for file in ["manifest.json", crate::limits::REPS_FILE] {
        if let Some(v) = read_regular(&dir.join(file), 64 << 20, "a manifest")
            .ok()
            .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
        {
            walk(&v, &mut names);
        }
    }
    names
}

/// Debug images an earlier version wrote without the tool's mark: `debug/view_NNN.png`
/// holding a PNG.
fn unmarked_debug_image(path: &Path, name: &str) -> bool {
    let numbered = name
        .strip_prefix("view_")
        .and_then(|r| r.strip_suffix(".png"))
        .is_some_and(|n| !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()));
    numbered
        && std::fs::symlink_metadata(path).is_ok_and(|m| m.is_file())
        && std::fs::File::open(path).is_ok_and(|f| {
            let mut head = Vec::new();
            f.take(8).read_to_end(&mut head).is_ok() && head == b"\x89PNG\r\n\x1a\n"
        })
}

/// The entries of bake folder `dir` this tool did not write (sub-folders' as
/// `debug/NAME`): anything but the fixed names ([`BAKE_FIXED_NAMES`]); numbered files by
/// [`is_bake_file_name`] that `named` lists (every such name, where `named` is `None`: a
/// staging folder whose manifest may not be written yet); sub-folders [`BAKE_SUBFOLDERS`]
/// holding only files that carry the tool's mark; and, at the top, other files carrying it
/// (`compare --out` into the pack folder).
fn foreign_entries(dir: &Path, named: Option<&std::collections::HashSet<String>>) -> Result<Vec<String>, String> {
    let list = |d: &Path| -> Result<Vec<String>, String> {
        Ok(std::fs::read_dir(d)
            .map_err(|e| format!("cannot list '{}': {e}", d.display()))?
            .filter_map(|e| e.ok().map(|e| e.file_name().to_string_lossy().into_owned()))
            .collect())
    };
    let mut foreign = Vec::new();
    for name in list(dir)? {
        let path = dir.join(&name);
        let is_file = std::fs::symlink_metadata(&path).is_ok_and(|m| m.is_file());
        if BAKE_FIXED_NAMES.contains(&name.as_str()) {
            if !is_file {
                foreign.push(name);
            }
            continue;
        }
        if BAKE_SUBFOLDERS.contains(&name.as_str()) {
            let is_dir = std::fs::symlink_metadata(&path).is_ok_and(|m| m.is_dir());
            if !is_dir {
                foreign.push(name);
                continue;
            }
            for inner in list(&path)? {
                let file = path.join(&inner);
                let old_debug_image = name == "debug" && unmarked_debug_image(&file, &inner);
                if !old_debug_image && !carries_tool_mark(&file) && !stale_atomic_tmp(&file, &inner) {
                    foreign.push(format!("{name}/{inner}"));
                }
            }
            continue;
        }
        let numbered = is_bake_file_name(&name) && named.is_none_or(|n| n.contains(&name));
        if !(is_file && numbered) && !carries_tool_mark(&path) && !stale_atomic_tmp(&path, &name) {
            foreign.push(name);
        }
    }
    foreign.sort();
    Ok(foreign)
}

/// Whether `path` (named `name`) is a file an atomic write of this tool left when its
/// process was killed (`.NAME.PID.tmp` of the kinds [`clean_stale_staging`] removes, the
/// process gone): a `compare` killed mid-write left one in the pack's `compare` folder, and
/// the next bake refused the pack as holding a file the tool did not write.
fn stale_atomic_tmp(path: &Path, name: &str) -> bool {
    let kind_ok = [".json.", ".autosave.", ".png.", ".glb."]
        .iter()
        .any(|k| name.trim_end_matches(".tmp").contains(k));
    name.ends_with(".tmp")
        && kind_ok
        && staging_pid(name).is_some_and(|pid| pid != std::process::id() && !process_alive(pid))
        && std::fs::symlink_metadata(path).is_ok_and(|m| m.is_file())
}

/// What a folder written by this tool says it is, from its manifest(s); `None` if neither
/// `manifest.json` nor `representations.json` names one of the tool's formats.
pub fn bake_folder_format(dir: &Path) -> Option<&'static str> {
    #[derive(serde::Deserialize)]
    struct Head {
        format: String,
    }
    let says = |file: &str, format: &'static str| -> Option<&'static str> {
        let bytes = read_regular(&dir.join(file), 64 << 20, "a manifest").ok()?;
        let head: Head = serde_json::from_slice(&bytes).ok()?;
        (head.format == format).then_some(format)
    };
    says("manifest.json", crate::limits::PACK_FORMAT_NAME)
        .or_else(|| says(crate::limits::REPS_FILE, crate::limits::REPS_FORMAT_NAME))
}

/// Why `out` may not receive a bake, checked before any work starts:
///
/// - `out` must end in a plain folder name (not `.`, `..` or a root);
/// - it may not be, or hold, the current folder or any of `protected` (the character file,
///   the project file and its folder);
/// - if it exists it must be a folder (not a file or a symbolic link) that is empty or was
///   written by this tool: its `manifest.json` or `representations.json` names one of the
///   tool's formats and it holds only files the tool writes there.
///
/// On success the folder may be replaced as a whole.
pub fn check_bake_output(out: &Path, protected: &[&Path]) -> Result<(), String> {
    let shown = out.display();
    // `components()` hides a trailing `.` (`b.pack/.` reads as `b.pack`), which no rename can
    // replace: the whole bake ran, then failed.
    let raw = out.to_string_lossy();
    let trimmed = raw.trim_end_matches(std::path::is_separator);
    let dotted = trimmed == "." || trimmed.ends_with("/.") || trimmed.ends_with("\\.");
    match out.components().next_back() {
        Some(Component::Normal(_)) if !dotted => {}
        _ => {
            return Err(format!(
                "'{shown}' is not a folder name a bake can create (give a new folder, e.g. character.pack)"
            ));
        }
    }
    let real = resolved(out);
    let cwd = std::env::current_dir().map(|d| resolved(&d)).unwrap_or_default();
    if cwd.starts_with(&real) {
        return Err(format!(
            "'{shown}' is the current folder or holds it; a bake replaces its output folder as a whole, so give a new folder"
        ));
    }
    for p in protected {
        let p = resolved(p);
        if p.starts_with(&real) {
            return Err(format!(
                "'{shown}' holds '{}', an input of this bake; a bake replaces its output folder as a whole, so give a new folder",
                p.display()
            ));
        }
    }
    // Inside another bake's folder (its `debug` or `compare`, or a pack in a pack), the
    // other could not be baked again (this one would be a file it did not write).
    if let Some(outer) = real.ancestors().skip(1).find(|a| bake_folder_format(a).is_some()) {
        return Err(format!(
            "'{shown}' lies inside '{}', a folder this tool wrote; give a folder outside it",
            outer.display()
        ));
    }
    let meta = match std::fs::symlink_metadata(out) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(format!("cannot check '{shown}': {e}")),
    };
    if !meta.is_dir() {
        return Err(format!(
            "'{shown}' exists and is {}; a bake writes a folder and replaces only a folder it wrote",
            kind_of(&meta.file_type())
        ));
    }
    // A mount point (a volume, a drive's root) cannot be renamed away: found after the bake.
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        let parent = real.parent().unwrap_or(Path::new("/"));
        if let Ok(p) = std::fs::metadata(parent)
            && p.dev() != meta.dev()
        {
            return Err(format!(
                "'{shown}' is a mount point; a bake replaces its output folder as a whole, so give a folder inside it"
            ));
        }
    }
    let entries: Vec<String> = std::fs::read_dir(out)
        .map_err(|e| format!("cannot list '{shown}': {e}"))?
        .filter_map(|e| e.ok().map(|e| e.file_name().to_string_lossy().into_owned()))
        .collect();
    if entries.is_empty() {
        return Ok(());
    }
    if bake_folder_format(out).is_none() {
        return Err(format!(
            "'{shown}' is a folder this tool did not write (no manifest.json or representations.json of this tool's formats in it); it is left untouched: give a new or empty folder"
        ));
    }
    let mut foreign = foreign_entries(out, Some(&names_in_manifests(out)))?;
    if !foreign.is_empty() {
        let n = foreign.len();
        foreign.truncate(5);
        return Err(format!(
            "'{shown}' holds {n} file(s) this tool did not write ({}{}); a bake replaces its output folder as a whole, so move them or give another folder",
            foreign.join(", "),
            if n > 5 { ", …" } else { "" }
        ));
    }
    Ok(())
}

/// Why the folder for bake output `out` cannot be written, found before any work: a folder
/// is created (and removed at once) where the bake's staging folder will go — beside `out`,
/// or in the nearest folder above it that exists (the writer creates the rest). A read-only
/// file system, a folder without write permission or a pseudo file system such as `/sys`
/// was only found when the finished bake was written.
pub fn check_can_write_beside(out: &Path) -> Result<(), String> {
    let parent = out
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let mut existing = parent.to_path_buf();
    while std::fs::symlink_metadata(&existing).is_err() {
        match existing.parent() {
            Some(p) if !p.as_os_str().is_empty() => existing = p.to_path_buf(),
            _ => {
                existing = PathBuf::from(".");
                break;
            }
        }
    }
    // A number per call: two checks at once in one process (the editor's threads) do not
    // meet on one name.
    static PROBES: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let n = PROBES.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let name = out
        .file_name()
        .map_or("out".into(), |n| n.to_string_lossy().into_owned());
    let probe = existing.join(staging_name(&format!("{name}.{n}"), "probe", std::process::id()));
    match std::fs::create_dir(&probe) {
        Ok(()) => {
            let _ = std::fs::remove_dir(&probe);
            Ok(())
        }
        Err(e) => Err(format!(
            "cannot write the output '{}': a bake assembles its folder beside it, in '{}', and creating a folder there failed ({e}); give an output folder whose parent folder can be written",
            out.display(),
            existing.display()
        )),
    }
}

/// What a file output writes, to recognise an earlier one.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutputFile {
    /// A PNG carrying this tool's `Software` text chunk ([`write_png`]).
    Png,
    /// A JSON object whose `generator` starts with [`GENERATOR_PREFIX`].
    Json,
    /// A GLB whose glTF `asset.generator` starts with [`GENERATOR_PREFIX`].
    Glb,
}

/// Why `path` may not be written: it exists and is not a regular file this tool wrote as
/// `kind` (a new path, or an earlier output of the tool, is fine).
pub fn check_output_file(path: &Path, kind: OutputFile) -> Result<(), String> {
    let shown = path.display();
    if path.file_name().is_none() {
        return Err(format!("'{shown}' is not a file name"));
    }
    let meta = match std::fs::symlink_metadata(path) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(format!("cannot check '{shown}': {e}")),
    };
    if !meta.is_file() {
        return Err(format!(
            "'{shown}' exists and is {}; only a file this tool wrote is replaced",
            kind_of(&meta.file_type())
        ));
    }
    let ours = marked(path, kind);
    if ours {
        Ok(())
    } else {
        Err(format!(
            "'{shown}' exists and was not written by this tool; it is left untouched: choose another path"
        ))
    }
}

/// `asset.generator` of a GLB file's JSON chunk.
fn glb_generator(bytes: &[u8]) -> Option<String> {
    if bytes.len() < 20 || &bytes[0..4] != b"glTF" {
        return None;
    }
    let len = u32::from_le_bytes(bytes[12..16].try_into().ok()?) as usize;
    let json = bytes.get(20..20usize.checked_add(len)?)?;
    let v: serde_json::Value = serde_json::from_slice(json).ok()?;
    v["asset"]["generator"].as_str().map(String::from)
}

/// Encodes an RGBA8 image as PNG with this tool's `Software` text (so a later run knows it
/// may overwrite it) at the given compression.
pub fn encode_png(img: &image::RgbaImage, compression: png::Compression) -> Result<Vec<u8>, String> {
    encode_png_as(img.as_raw(), img.dimensions(), png::ColorType::Rgba, compression)
}

/// [`encode_png`] of a greyscale image (one byte a pixel).
pub fn encode_gray_png(img: &image::GrayImage, compression: png::Compression) -> Result<Vec<u8>, String> {
    encode_png_as(img.as_raw(), img.dimensions(), png::ColorType::Grayscale, compression)
}

fn encode_png_as(
    data: &[u8],
    (width, height): (u32, u32),
    color: png::ColorType,
    compression: png::Compression,
) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, width, height);
        enc.set_color(color);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_compression(compression);
        enc.set_filter(png::Filter::Adaptive);
        enc.add_text_chunk("Software".into(), GENERATOR.into())
            .map_err(|e| e.to_string())?;
        let mut w = enc.write_header().map_err(|e| e.to_string())?;
        w.write_image_data(data).map_err(|e| e.to_string())?;
        w.finish().map_err(|e| e.to_string())?;
    }
    Ok(out)
}

/// Writes `img` to `path` as a PNG marked as this tool's, after [`check_output_file`].
pub fn write_png(path: &Path, img: &image::RgbaImage) -> Result<(), String> {
    check_output_file(path, OutputFile::Png)?;
    let bytes = encode_png(img, png::Compression::Balanced)?;
    write_file_atomic(path, &bytes)
}

/// Writes `value` (a JSON object; a `generator` key is added) to `path`, after
/// [`check_output_file`].
pub fn write_json(path: &Path, mut value: serde_json::Value) -> Result<(), String> {
    check_output_file(path, OutputFile::Json)?;
    if let Some(map) = value.as_object_mut() {
        map.insert("generator".into(), GENERATOR.into());
    }
    let text = serde_json::to_string_pretty(&value).map_err(|e| e.to_string())?;
    write_file_atomic(path, text.as_bytes())
}

/// Writes `bytes` to `path` through a temporary file in the same (existing) folder, renamed
/// into place when complete.
pub fn write_file_atomic(path: &Path, bytes: &[u8]) -> Result<(), String> {
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    if !dir.is_dir() {
        return Err(format!(
            "{}: the folder {} does not exist",
            path.display(),
            dir.display()
        ));
    }
    write_atomic(path, bytes).map_err(|e| format!("{}: {e}", path.display()))
}

/// Whether process `pid` is alive on this machine.
pub fn process_alive(pid: u32) -> bool {
    #[cfg(unix)]
    {
        let Ok(pid) = i32::try_from(pid) else {
            return false;
        };
        if pid <= 0 {
            return false;
        }
        // SAFETY: kill with signal 0 only checks whether the process exists.
        let r = unsafe { libc::kill(pid, 0) };
        r == 0 || std::io::Error::last_os_error().raw_os_error() == Some(libc::EPERM)
    }
    #[cfg(not(unix))]
    {
        let _ = pid;
        true
    }
}

/// `path` with each `NAME/..` whose `NAME` does not exist taken out, as the system would read
/// it had the folder existed: creating the folders of `sub/../d.pack` made an empty `sub`
/// the user never asked for. A `..` after a folder that exists (perhaps a link) is left for
/// the system to follow.
pub fn without_missing_dotdot(path: &Path) -> PathBuf {
    use std::path::Component;
    let mut out = PathBuf::new();
    // How many of `out`'s trailing components are names that do not exist.
    let mut missing = 0usize;
    for c in path.components() {
        match c {
            Component::ParentDir if missing > 0 => {
                out.pop();
                missing -= 1;
            }
            Component::Normal(n) => {
                out.push(n);
                if missing > 0 || std::fs::symlink_metadata(&out).is_err() {
                    missing += 1;
                }
            }
            other => {
                out.push(other.as_os_str());
                missing = 0;
            }
        }
    }
    out
}

/// The staging name of a writer of `name` in process `pid`: `.NAME.KIND-PID`.
pub fn staging_name(name: &str, kind: &str, pid: u32) -> String {
    format!(".{name}.{kind}-{pid}")
}

/// Removes the staging folders and files that this tool's writers left in `dir` when they
/// were killed: `.NAME.writing-PID` and `.NAME.old-PID` folders holding only files a bake
/// writes, and `.NAME.PID.tmp` files of the kinds written atomically (`.json`, `.autosave`,
/// `.png`, `.glb`); only those whose process is gone. Returns what was removed.
pub fn clean_stale_staging(dir: &Path) -> Vec<PathBuf> {
    let mut removed = Vec::new();
    let Ok(entries) = std::fs::read_dir(dir) else {
        return removed;
    };
    for entry in entries.filter_map(Result::ok) {
        let name = entry.file_name().to_string_lossy().into_owned();
        let Some(pid) = staging_pid(&name) else { continue };
        if pid == std::process::id() || process_alive(pid) {
            continue;
        }
        let path = entry.path();
        let ok = match entry.file_type() {
            // A write probe ([`check_can_write_beside`]) left by a killed process: only
            // ever empty, removed only so.
            Ok(t) if t.is_dir() && name.contains(".probe-") => std::fs::remove_dir(&path).is_ok(),
            Ok(t) if t.is_dir() && !name.ends_with(".tmp") => {
                let ours = foreign_entries(&path, None).is_ok_and(|f| f.is_empty());
                ours && std::fs::remove_dir_all(&path).is_ok()
            }
            Ok(t) if t.is_file() && name.ends_with(".tmp") => {
                stale_atomic_tmp(&path, &name) && std::fs::remove_file(&path).is_ok()
            }
            _ => false,
        };
        if ok {
            log::info!("removed {} left by an interrupted run (process {pid})", path.display());
            removed.push(path);
        }
    }
    removed
}

/// The process number in a staging name this tool makes, if `name` is one.
fn staging_pid(name: &str) -> Option<u32> {
    let rest = name.strip_prefix('.')?;
    if let Some(stem) = rest.strip_suffix(".tmp") {
        // `.NAME.PID.tmp` (atomic file writes)
        let (_, pid) = stem.rsplit_once('.')?;
        return pid.parse().ok();
    }
    let (_, tail) = rest.rsplit_once('.')?;
    let pid = tail
        .strip_prefix("writing-")
        .or_else(|| tail.strip_prefix("old-"))
        .or_else(|| tail.strip_prefix("probe-"))?;
    pid.parse().ok()
}

/// A temporary folder that is removed when dropped and when the process is interrupted
/// (Ctrl-C / SIGTERM, by a handler that calls [`remove_temp_dirs`]).
pub struct TempDir {
    path: PathBuf,
}

static TEMP_DIRS: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

impl TempDir {
    /// A new folder `prefix-PID[-n]` in the system's temporary folder; stale ones of dead
    /// processes with the same prefix are removed first.
    pub fn new(prefix: &str) -> std::io::Result<Self> {
        let base = std::env::temp_dir();
        if let Ok(entries) = std::fs::read_dir(&base) {
            for e in entries.filter_map(Result::ok) {
                let name = e.file_name().to_string_lossy().into_owned();
                let Some(rest) = name.strip_prefix(prefix).and_then(|r| r.strip_prefix('-')) else {
                    continue;
                };
                let pid = rest.split('-').next().and_then(|p| p.parse::<u32>().ok());
                if let Some(pid) = pid
                    && pid != std::process::id()
                    && !process_alive(pid)
                    && e.file_type().is_ok_and(|t| t.is_dir())
                {
                    let _ = std::fs::remove_dir_all(e.path());
                }
            }
        }
        let mut n = 0u32;
        loop {
            let name = if n == 0 {
                format!("{prefix}-{}", std::process::id())
            } else {
                format!("{prefix}-{}-{n}", std::process::id())
            };
            let path = base.join(name);
            match std::fs::create_dir(&path) {
                Ok(()) => {
                    if let Ok(mut list) = TEMP_DIRS.lock() {
                        list.push(path.clone());
                    }
                    return Ok(Self { path });
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && n < 1000 => n += 1,
                Err(e) => return Err(e),
            }
        }
    }

    /// Where the folder is (absolute, in the system's temporary folder); it exists until the
    /// `TempDir` is dropped.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.path);
        if let Ok(mut list) = TEMP_DIRS.lock() {
            list.retain(|p| p != &self.path);
        }
    }
}

/// Removes every live [`TempDir`] (for an interrupt handler that is about to exit).
pub fn remove_temp_dirs() {
    if let Ok(list) = TEMP_DIRS.lock() {
        for p in list.iter() {
            let _ = std::fs::remove_dir_all(p);
        }
    }
}

/// Writes `bytes` to `path` atomically: a temporary file in the same folder, flushed, then
/// renamed over the target.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    use std::io::Write;
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir)?;
    // What killed writers left here (never anything this tool did not write).
    clean_stale_staging(dir);
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "file".into());
    let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        drop(f);
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("pp-safefs-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn a_dotdot_after_a_missing_folder_makes_no_folder() {
        let d = temp("dotdot");
        assert_eq!(without_missing_dotdot(&d.join("sub/../x.pack")), d.join("x.pack"));
        assert_eq!(without_missing_dotdot(&d.join("a/b/../../x.pack")), d.join("x.pack"));
        assert_eq!(without_missing_dotdot(&d.join("a/b/../x.pack")), d.join("a/x.pack"));
        // An existing folder's `..` is the system's to follow (it may be a link).
        std::fs::create_dir(d.join("sub")).unwrap();
        assert_eq!(
            without_missing_dotdot(&d.join("sub/../x.pack")),
            d.join("sub/../x.pack")
        );
        assert_eq!(
            without_missing_dotdot(Path::new("../x.pack")),
            PathBuf::from("../x.pack")
        );
        assert_eq!(without_missing_dotdot(Path::new("x.pack")), PathBuf::from("x.pack"));
        std::fs::remove_dir_all(d).unwrap();
    }

    #[test]
    fn reads_are_bounded_and_take_regular_files_only() {
        let d = temp("read");
        let f = d.join("a.bin");
        std::fs::write(&f, [7u8; 100]).unwrap();
        assert_eq!(read_regular(&f, 100, "test").unwrap().len(), 100);
        assert!(matches!(
            read_regular(&f, 99, "test"),
            Err(FsError::TooLarge { len: 100, .. })
        ));
        assert!(matches!(read_regular(&d, 99, "test"), Err(FsError::NotRegular { .. })));
        #[cfg(unix)]
        {
            let link = d.join("zero.bin");
            std::os::unix::fs::symlink("/dev/zero", &link).unwrap();
            let e = read_regular(&link, 1 << 20, "test").unwrap_err();
            assert!(e.to_string().contains("character device"), "{e}");
            let fifo = d.join("fifo.png");
            let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
            // SAFETY: a plain mkfifo on a path we own.
            assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
            let e = read_regular(&fifo, 1 << 20, "test").unwrap_err();
            assert!(e.to_string().contains("FIFO"), "{e}");
        }
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn bake_outputs_replace_only_what_the_tool_wrote() {
        let d = temp("out");
        // New and empty folders are fine.
        assert!(check_bake_output(&d.join("new.pack"), &[]).is_ok());
        std::fs::create_dir(d.join("empty")).unwrap();
        assert!(check_bake_output(&d.join("empty"), &[]).is_ok());
        // A folder of the user's is refused.
        let docs = d.join("mydocs");
        std::fs::create_dir(&docs).unwrap();
        std::fs::write(docs.join("notes.txt"), "x").unwrap();
        let e = check_bake_output(&docs, &[]).unwrap_err();
        assert!(e.contains("did not write"), "{e}");
        // A file is refused.
        std::fs::write(d.join("file.pack"), "x").unwrap();
        assert!(
            check_bake_output(&d.join("file.pack"), &[])
                .unwrap_err()
                .contains("regular file")
        );
        // A pack folder is fine, until the user puts a file of theirs in it.
        let pack = d.join("a.pack");
        std::fs::create_dir(&pack).unwrap();
        std::fs::write(
            pack.join("manifest.json"),
            format!(
                r#"{{"format": "{}", "views": [{{"atlas": "atlas_000.png", "normal_atlas": "normal_000.png"}}]}}"#,
                crate::limits::PACK_FORMAT_NAME
            ),
        )
        .unwrap();
        std::fs::write(pack.join("atlas_000.png"), "x").unwrap();
        std::fs::write(pack.join("normal_000.png"), "x").unwrap();
        assert!(check_bake_output(&pack, &[]).is_ok());
        // The tool's debug images and `compare`'s outputs, in their folders or at the top.
        let marked = image::RgbaImage::new(2, 2);
        for sub in ["debug", "compare"] {
            std::fs::create_dir(pack.join(sub)).unwrap();
            write_png(&pack.join(sub).join("view_000.png"), &marked).unwrap();
        }
        write_json(&pack.join("compare").join("compare.json"), serde_json::json!({})).unwrap();
        write_png(&pack.join("quality.png"), &marked).unwrap();
        write_json(&pack.join("compare.json"), serde_json::json!({})).unwrap();
        assert_eq!(check_bake_output(&pack, &[]), Ok(()));
        // A file of the user's named like one of the bake's numbered files but not in its
        // manifest, or anything of the user's inside the sub-folders, is theirs.
        let theirs = |path: &Path, refused_as: &str| {
            std::fs::write(path, "mine").unwrap();
            let e = check_bake_output(&pack, &[]).unwrap_err();
            assert!(e.contains(refused_as) && e.contains("did not write"), "{e}");
            std::fs::remove_file(path).unwrap();
            assert_eq!(check_bake_output(&pack, &[]), Ok(()));
        };
        theirs(&pack.join("atlas_999.ktx2"), "atlas_999.ktx2");
        theirs(&pack.join("debug").join("notes.md"), "debug/notes.md");
        theirs(&pack.join("compare").join("notes.md"), "compare/notes.md");
        theirs(&pack.join("notes.txt"), "notes.txt");
        // An unmarked PNG under a name the tool writes is not taken for the tool's.
        theirs(&pack.join("compare").join("error.png"), "compare/error.png");
        std::fs::create_dir(pack.join("debug").join("mystuff")).unwrap();
        assert!(check_bake_output(&pack, &[]).unwrap_err().contains("debug/mystuff"));
        std::fs::remove_dir(pack.join("debug").join("mystuff")).unwrap();
        // An earlier version's debug image (a PNG without the mark) is the tool's; a file
        // under that name that is not a PNG is not.
        let mut png = Vec::new();
        image::RgbaImage::new(2, 2)
            .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .unwrap();
        std::fs::write(pack.join("debug").join("view_001.png"), &png).unwrap();
        assert_eq!(check_bake_output(&pack, &[]), Ok(()));
        theirs(&pack.join("debug").join("view_002.png"), "debug/view_002.png");
        // A fixed name that is a folder of the user's.
        std::fs::create_dir(pack.join("report.json")).unwrap();
        assert!(check_bake_output(&pack, &[]).unwrap_err().contains("report.json"));
        std::fs::remove_dir(pack.join("report.json")).unwrap();
        // A name in the manifest that is not a file's (a part named like one) lists nothing.
        let manifest = std::fs::read_to_string(pack.join("manifest.json")).unwrap();
        std::fs::write(
            pack.join("manifest.json"),
            manifest.replacen('{', r#"{"parts": [{"name": "atlas_007.png"}], "#, 1),
        )
        .unwrap();
        theirs(&pack.join("atlas_007.png"), "atlas_007.png");
        // A stale staging folder holding a user's file in its debug folder is kept.
        let stale = d.join(".a.pack.writing-4000000");
        std::fs::create_dir_all(stale.join("debug")).unwrap();
        std::fs::write(stale.join("atlas_000.png"), "x").unwrap();
        std::fs::write(stale.join("debug").join("notes.md"), "mine").unwrap();
        assert!(clean_stale_staging(&d).is_empty());
        assert!(stale.join("debug").join("notes.md").exists());
        // A write probe a killed run left (empty) goes; one holding anything stays.
        let probe = d.join(".b.pack.0.probe-4000000");
        std::fs::create_dir(&probe).unwrap();
        assert_eq!(clean_stale_staging(&d), vec![probe.clone()]);
        std::fs::create_dir(&probe).unwrap();
        std::fs::write(probe.join("x"), "mine").unwrap();
        assert!(clean_stale_staging(&d).is_empty());
        std::fs::remove_dir_all(&probe).unwrap();
        std::fs::remove_file(stale.join("debug").join("notes.md")).unwrap();
        assert_eq!(clean_stale_staging(&d), vec![stale.clone()]);
        std::fs::write(pack.join("notes.txt"), "x").unwrap();
        assert!(check_bake_output(&pack, &[]).unwrap_err().contains("notes.txt"));
        // Inputs and the current folder are protected.
        let project = d.join("proj");
        std::fs::create_dir(&project).unwrap();
        let e = check_bake_output(&project, &[&project.join("project.json")]).unwrap_err();
        assert!(e.contains("input"), "{e}");
        assert!(check_bake_output(&d, &[&project.join("project.json")]).is_err());
        assert!(check_bake_output(Path::new("."), &[]).is_err());
        assert!(check_bake_output(Path::new(".."), &[]).is_err());
        assert!(check_bake_output(Path::new("/"), &[]).is_err());
        // A trailing `.` (which `components()` hides; no rename can replace it), new or not.
        for dotted in [pack.join("."), d.join("new.pack/."), d.join("new.pack/./")] {
            let e = check_bake_output(&dotted, &[]).unwrap_err();
            assert!(e.contains("not a folder name"), "{e}");
        }
        // A `compare` killed mid-write left a temporary image: the tool's.
        std::fs::remove_file(pack.join("notes.txt")).unwrap();
        let dead = 4_194_399;
        std::fs::write(pack.join("compare").join(format!(".memory.png.{dead}.tmp")), "x").unwrap();
        assert_eq!(check_bake_output(&pack, &[]), Ok(()));
        std::fs::write(pack.join("compare").join(format!(".notes.{dead}.tmp")), "x").unwrap();
        assert!(check_bake_output(&pack, &[]).is_err(), "not of a kind the tool writes");
        std::fs::remove_file(pack.join("compare").join(format!(".notes.{dead}.tmp"))).unwrap();
        // Inside a folder this tool wrote (its debug folder, a pack in a pack).
        for inner in [pack.join("debug"), pack.join("inner.pack"), pack.join("a/b.pack")] {
            let e = check_bake_output(&inner, &[]).unwrap_err();
            assert!(e.contains("a folder this tool wrote"), "{e}");
        }
        std::fs::remove_dir_all(&d).unwrap();
    }

    /// A folder that can be written passes and keeps nothing of the probe; one under a pseudo
    /// file system no one can create folders in (root included) is refused, naming it.
    #[test]
    fn an_unwritable_output_is_found_before_the_work() {
        let d = temp("probe");
        assert_eq!(check_can_write_beside(&d.join("a.pack")), Ok(()));
        assert_eq!(check_can_write_beside(&d.join("not/yet/made/a.pack")), Ok(()));
        assert!(std::fs::read_dir(&d).unwrap().next().is_none(), "the probe is removed");
        #[cfg(target_os = "linux")]
        {
            let e = check_can_write_beside(Path::new("/proc/polypostor-test.pack")).unwrap_err();
            assert!(e.contains("cannot write") && e.contains("/proc"), "{e}");
        }
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn file_outputs_overwrite_only_their_own_files() {
        let d = temp("files");
        let png_path = d.join("a.png");
        let img = image::RgbaImage::new(3, 2);
        write_png(&png_path, &img).unwrap();
        write_png(&png_path, &img).unwrap(); // ours: overwritten
        let back = image::open(&png_path).unwrap();
        assert_eq!((back.width(), back.height()), (3, 2));
        let theirs = d.join("photo.png");
        img.save(&theirs).unwrap();
        assert!(
            write_png(&theirs, &img)
                .unwrap_err()
                .contains("not written by this tool")
        );
        let json = d.join("a.json");
        write_json(&json, serde_json::json!({"x": 1})).unwrap();
        write_json(&json, serde_json::json!({"x": 2})).unwrap();
        std::fs::write(d.join("b.json"), "{\"x\": 1}").unwrap();
        assert!(write_json(&d.join("b.json"), serde_json::json!({})).is_err());
        assert!(check_output_file(&d, OutputFile::Png).is_err());
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn stale_staging_of_dead_processes_is_removed_and_live_ones_kept() {
        let d = temp("stale");
        // A process number that cannot be alive (above the kernel's maximum).
        let dead = 999_999_999u32;
        let mine = std::process::id();
        for n in [
            staging_name("x.pack", "writing", dead),
            staging_name("x.pack", "old", dead),
            staging_name("x.pack", "writing", mine),
            staging_name("y", "old", dead),
        ] {
            std::fs::create_dir(d.join(&n)).unwrap();
        }
        std::fs::write(d.join(staging_name("x.pack", "old", dead)).join("atlas_000.png"), "x").unwrap();
        // A folder of the same name pattern holding something else is not ours.
        std::fs::write(d.join(staging_name("y", "old", dead)).join("thesis.tex"), "x").unwrap();
        std::fs::write(d.join(format!(".project.json.{dead}.tmp")), "x").unwrap();
        std::fs::write(d.join(format!(".notes.{dead}.tmp")), "x").unwrap();
        std::fs::create_dir(d.join(".user.writing-notanumber")).unwrap();
        std::fs::create_dir(d.join("keep")).unwrap();
        let removed = clean_stale_staging(&d);
        assert_eq!(removed.len(), 3, "{removed:?}");
        let left: Vec<String> = std::fs::read_dir(&d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert!(left.contains(&staging_name("x.pack", "writing", mine)));
        assert!(left.contains(&".user.writing-notanumber".to_string()));
        assert!(left.contains(&"keep".to_string()));
        assert!(left.contains(&staging_name("y", "old", dead)));
        assert!(left.contains(&format!(".notes.{dead}.tmp")));
        assert_eq!(left.len(), 5);
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn temp_dirs_go_away_when_dropped() {
        let t = TempDir::new("pp-safefs-tempdir").unwrap();
        let p = t.path().to_owned();
        std::fs::write(p.join("f"), "x").unwrap();
        assert!(p.is_dir());
        drop(t);
        assert!(!p.exists());
    }
}
