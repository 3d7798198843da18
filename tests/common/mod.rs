//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::path::PathBuf;

/// `../shared` beside the repository, when present. In CI (`CI` set) it must exist.
pub fn shared_dir() -> Option<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared");
    if dir.is_dir() {
        Some(dir)
    } else if std::env::var_os("CI").is_some() {
        panic!("../shared is missing, but CI must run every test");
    } else {
        eprintln!("skipped: ../shared not found beside the repository");
        None
    }
}

pub fn repo_path(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(rel)
}

/// The real characters of `../shared/assets/characters`.
pub fn real_characters() -> Vec<PathBuf> {
    let Some(shared) = shared_dir() else {
        return Vec::new();
    };
    let mut v: Vec<PathBuf> = std::fs::read_dir(shared.join("assets/characters"))
        .expect("characters folder")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "glb" || e == "gltf"))
        .collect();
    v.sort();
    v
}

/// A fresh temporary folder for one test.
pub fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("polypostor-test-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Copies a folder's plain files into `to` (made anew).
pub fn copy_folder(from: &std::path::Path, to: &std::path::Path) {
    let _ = std::fs::remove_dir_all(to);
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap().filter_map(|e| e.ok()) {
        if e.file_type().unwrap().is_file() {
            std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
        }
    }
}

/// Rewrites a manifest's `checksums` to match the files beside it as they are now (a forged
/// folder, to reach the checks behind the checksums). Files that are not plain files are
/// left alone (reading a link to a device would never end).
pub fn reseal(manifest: &std::path::Path) {
    if !std::fs::symlink_metadata(manifest).is_ok_and(|m| m.is_file()) {
        return;
    }
    let Ok(text) = std::fs::read_to_string(manifest) else {
        return;
    };
    let Ok(mut v) = serde_json::from_str::<serde_json::Value>(&text) else {
        return;
    };
    let dir = manifest.parent().unwrap();
    let names: Vec<String> = v["checksums"]
        .as_object()
        .map(|m| m.keys().cloned().collect())
        .unwrap_or_default();
    for n in names {
        if std::fs::symlink_metadata(dir.join(&n)).is_ok_and(|m| m.is_file())
            && let Ok(bytes) = std::fs::read(dir.join(&n))
        {
            v["checksums"][&n] = serde_json::json!({"bytes": bytes.len(), "crc32": crc32(&bytes)});
        }
    }
    std::fs::write(manifest, serde_json::to_string(&v).unwrap()).unwrap();
}

/// CRC-32 (IEEE), bit by bit: an independent check of the writer's checksums.
pub fn crc32(bytes: &[u8]) -> u32 {
    let mut c = 0xffff_ffffu32;
    for &b in bytes {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 { (c >> 1) ^ 0xedb8_8320 } else { c >> 1 };
        }
    }
    !c
}

/// Bakes the generated default character (its first clip, automatic segmentation, no cap
/// overrides) with `options`.
pub fn bake_default(
    ctx: &polypostor::gpu::GpuContext,
    options: &polypostor::bake::pipeline::BakeOptions,
) -> (polypostor::Character, polypostor::bake::pipeline::Bake) {
    let c = polypostor::default_character::generate();
    let seg = polypostor::bake::segment::auto_segment(&c);
    let b = polypostor::bake::pipeline::bake(
        ctx,
        &c,
        &seg,
        &polypostor::bake::caps::CapOverrides::default(),
        options,
        &|_| {},
        &std::sync::atomic::AtomicBool::new(false),
    )
    .unwrap();
    (c, b)
}

/// Bake options that make several key images cheap (any gain, a large budget), so parts get
/// several.
pub fn cheap_keys(views: usize, resolution: u32) -> polypostor::bake::pipeline::BakeOptions {
    polypostor::bake::pipeline::BakeOptions {
        views,
        resolution,
        key_frame: polypostor::bake::pipeline::KeyFrame::Frame(0),
        keys: polypostor::bake::keys::KeyOptions {
            max_keys: 4,
            min_gain_db: 0.0,
            budget: 4.0,
        },
        ..Default::default()
    }
}
