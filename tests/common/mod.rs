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

/// A fresh temporary folder for one test, removed when the test ends well (kept, and its path
/// printed, when the test fails, to look at what it left).
pub fn temp_dir(name: &str) -> TempDir {
    let dir = std::env::temp_dir().join(format!("polypostor-test-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    TempDir(dir)
}

/// Siblings of `mine` named as it is but for another process id (`…-PID`), whose process no
/// longer runs (Linux: no `/proc/PID`); elsewhere nothing is removed.
fn remove_dead_runs_folders(mine: &std::path::Path) {
    let (Some(parent), Some(name)) = (mine.parent(), mine.file_name().and_then(|n| n.to_str())) else {
        return;
    };
    let Some((stem, _)) = name.rsplit_once('-') else {
        return;
    };
    if !std::path::Path::new("/proc/self").exists() {
        return;
    }
    let Ok(entries) = std::fs::read_dir(parent) else {
        return;
    };
    for e in entries.flatten() {
        let file = e.file_name();
        let Some(other) = file.to_str() else { continue };
        let Some(pid) = other.strip_prefix(stem).and_then(|r| r.strip_prefix('-')) else {
            continue;
        };
        if other == name || pid.is_empty() || !pid.bytes().all(|b| b.is_ascii_digit()) {
            continue;
        }
        if !std::path::Path::new("/proc").join(pid).exists() {
            let _ = std::fs::remove_dir_all(e.path());
        }
    }
}

/// See [`temp_dir`]: a folder path that removes its folder when dropped, unless the thread is
/// panicking (a failing test keeps its files).
pub struct TempDir(PathBuf);

impl TempDir {
    /// The path, and the folder kept after the test (for a bake shared by a whole test run
    /// through a `static`, which is never dropped anyway). Folders of the same name kept by
    /// earlier runs whose process is gone are removed first, so test runs do not pile them up
    /// in the temporary folder.
    #[allow(dead_code)]
    pub fn keep(self) -> PathBuf {
        let path = self.0.clone();
        remove_dead_runs_folders(&path);
        std::mem::forget(self);
        path
    }
}

impl std::ops::Deref for TempDir {
    type Target = std::path::Path;
    fn deref(&self) -> &std::path::Path {
        &self.0
    }
}

impl AsRef<std::path::Path> for TempDir {
    fn as_ref(&self) -> &std::path::Path {
        &self.0
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        if std::thread::panicking() {
            eprintln!("kept {} (the test failed)", self.0.display());
        } else {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
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
            ..Default::default()
        },
        ..Default::default()
    }
}

/// The GPU every test draws with: software adapters first (reproducible, and present on
/// every CI machine: lavapipe, else llvmpipe), named on stderr.
pub fn gpu() -> polypostor::gpu::GpuContext {
    let ctx = polypostor::gpu::GpuContext::new(&polypostor::gpu::AdapterPreference::SoftwareFirst)
        .expect("a wgpu adapter (install mesa-vulkan-drivers)");
    eprintln!("adapter: {}", ctx.adapter_description());
    ctx
}

/// Image comparisons shared by the tests; [`images::save_on_failure`] keeps the pictures of
/// a failed comparison for a person to look at.
pub mod images {
    use image::RgbaImage;

    /// Coverage of a render: alpha above half.
    pub fn mask(img: &RgbaImage) -> Vec<bool> {
        img.pixels().map(|p| p[3] > 127).collect()
    }

    /// Intersection over union of two masks (1 when both are empty).
    pub fn iou(a: &[bool], b: &[bool]) -> f64 {
        let inter = a.iter().zip(b).filter(|(x, y)| **x && **y).count() as f64;
        let union = a.iter().zip(b).filter(|(x, y)| **x || **y).count() as f64;
        if union == 0.0 { 1.0 } else { inter / union }
    }

    /// Mean absolute colour difference (RGB, 0..255) over the pixels both masks cover.
    pub fn mean_diff_where_both(a: &RgbaImage, ma: &[bool], b: &RgbaImage, mb: &[bool]) -> f64 {
        let (mut diff, mut n) = (0.0, 0usize);
        for (i, (p, q)) in a.pixels().zip(b.pixels()).enumerate() {
            if ma[i] && mb[i] {
                diff += (0..3).map(|k| (p[k] as f64 - q[k] as f64).abs()).sum::<f64>() / 3.0;
                n += 1;
            }
        }
        diff / n.max(1) as f64
    }

    /// Mean absolute difference per channel (RGBA, 0..255) over every pixel.
    pub fn mean_diff(a: &RgbaImage, b: &RgbaImage) -> f64 {
        let sum: u64 = a
            .as_raw()
            .iter()
            .zip(b.as_raw())
            .map(|(&x, &y)| (x as i32 - y as i32).unsigned_abs() as u64)
            .sum();
        sum as f64 / a.as_raw().len() as f64
    }

    /// PSNR (dB, 8-bit) over the first `channels` channels of the pixels where `keep` holds
    /// for `b`'s pixel (infinite for identical images).
    pub fn psnr_where(a: &RgbaImage, b: &RgbaImage, keep: impl Fn(&image::Rgba<u8>) -> bool, channels: usize) -> f64 {
        let (mut se, mut n) = (0.0, 0usize);
        for (p, q) in a.pixels().zip(b.pixels()) {
            if !keep(q) {
                continue;
            }
            for k in 0..channels {
                se += (p[k] as f64 - q[k] as f64).powi(2);
            }
            n += channels;
        }
        let mse = se / n.max(1) as f64;
        if mse == 0.0 {
            f64::INFINITY
        } else {
            10.0 * (255.0f64 * 255.0 / mse).log10()
        }
    }

    /// PSNR over every pixel and channel.
    pub fn psnr(a: &RgbaImage, b: &RgbaImage) -> f64 {
        psnr_where(a, b, |_| true, 4)
    }

    /// The bake's SSIM of two pictures ([`polypostor::metrics::ssim_rgba8`]: 11 × 11 Gaussian,
    /// σ 1.5, over the union of what either covers); 1 when neither covers anything.
    pub fn ssim(a: &RgbaImage, b: &RgbaImage) -> f64 {
        polypostor::metrics::ssim_rgba8(a, b).expect("two pictures of the same size")
    }

    /// Share of pixels whose `channels` differ by more than `tol` (0..255).
    pub fn differing(a: &RgbaImage, b: &RgbaImage, channels: std::ops::Range<usize>, tol: i32) -> f64 {
        assert_eq!(a.dimensions(), b.dimensions());
        let n = a
            .pixels()
            .zip(b.pixels())
            .filter(|(p, q)| channels.clone().any(|k| (p[k] as i32 - q[k] as i32).abs() > tol))
            .count();
        n as f64 / (a.width() * a.height()).max(1) as f64
    }

    /// When `ok` is false, writes `expected`, `actual` and their difference (×4, opaque) as
    /// `target/test-images/<name>_{expected,actual,diff}.png` and returns where; `ok` passes
    /// through otherwise (use: `assert!(save_on_failure(ok, …).is_none(), …)`).
    pub fn save_on_failure(ok: bool, name: &str, expected: &RgbaImage, actual: &RgbaImage) -> Option<String> {
        if ok {
            return None;
        }
        let dir = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/test-images");
        let _ = std::fs::create_dir_all(&dir);
        let diff = RgbaImage::from_fn(expected.width(), expected.height(), |x, y| {
            let (p, q) = (expected.get_pixel(x, y), actual.get_pixel(x, y));
            let d = |k: usize| ((p[k] as i32 - q[k] as i32).unsigned_abs() * 4).min(255) as u8;
            image::Rgba([d(0), d(1), d(2), 255])
        });
        for (kind, img) in [("expected", expected), ("actual", actual), ("diff", &diff)] {
            let _ = img.save(dir.join(format!("{name}_{kind}.png")));
        }
        Some(format!(
            "pictures in {}/{name}_{{expected,actual,diff}}.png",
            dir.display()
        ))
    }
}

/// A prop without a skin (a windmill made of three triangles): the "Tower" node, the "rotor_01"
/// node 1 up from it turning a quarter about +Z over one second (a node animation, "Turn"),
/// and the "Hub" node below the rotor, 0.5 in front, which does not move by itself. Triangles
/// in node order: the tower's, the rotor's, the hub's, each (0,0,0) (1,0,0) (0,1,0) in its
/// node.
pub const TURNING_PROP: &str = r#"{
    "asset": {"version": "2.0"},
    "scene": 0, "scenes": [{"nodes": [0]}],
    "nodes": [
        {"name": "Tower", "mesh": 0, "children": [1]},
        {"name": "rotor_01", "mesh": 0, "translation": [0, 1, 0], "children": [2]},
        {"name": "Hub", "mesh": 0, "translation": [0, 0, 0.5]}
    ],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
    "accessors": [
        {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]},
        {"bufferView": 1, "componentType": 5126, "count": 2, "type": "SCALAR", "min": [0], "max": [1]},
        {"bufferView": 2, "componentType": 5126, "count": 2, "type": "VEC4"}
    ],
    "bufferViews": [
        {"buffer": 0, "byteLength": 36},
        {"buffer": 0, "byteOffset": 36, "byteLength": 8},
        {"buffer": 0, "byteOffset": 44, "byteLength": 32}
    ],
    "animations": [{"name": "Turn", "channels": [{"sampler": 0, "target": {"node": 1, "path": "rotation"}}],
                    "samplers": [{"input": 1, "output": 2}]}],
    "buffers": [{"byteLength": 76, "uri": "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAAAAAAAgD8AAAAAAAAAAAAAAAAAAIA/AAAAAAAAAADzBDU/8wQ1Pw=="}]
}"#;

/// [`TURNING_PROP`] without its animation (a static prop).
pub fn still_prop() -> String {
    TURNING_PROP.replace(
        r#""animations": [{"name": "Turn", "channels": [{"sampler": 0, "target": {"node": 1, "path": "rotation"}}],
                    "samplers": [{"input": 1, "output": 2}]}],"#,
        "",
    )
}

/// The real mesh `c` drawn unlit (GPU skinning) at `pose` into `target`: its colour image
/// and its coverage (the normal target's alpha), the ground truth the crowd tests compare
/// every representation with.
#[allow(clippy::too_many_arguments)]
pub fn unlit_truth(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    renderer: &polypostor::gpu::CharacterRenderer,
    target: &polypostor::gpu::RenderTarget,
    mesh: &mut polypostor::gpu::GpuCharacter,
    c: &polypostor::Character,
    pose: &polypostor::animation::Pose,
    camera: &polypostor::gpu::Camera,
) -> (image::RgbaImage, Vec<bool>) {
    use polypostor::gpu::{DrawOptions, Shading, SkinningMode};
    renderer.render(
        device,
        queue,
        target,
        mesh,
        c,
        pose,
        SkinningMode::Gpu,
        camera,
        &DrawOptions {
            shading: Shading::Unlit,
            ..Default::default()
        },
    );
    (
        target.read_color(device, queue).unwrap(),
        images::mask(&target.read_normal(device, queue).unwrap()),
    )
}

/// Adds to `c` a morph target that moves every vertex right of `x > above_x` by `offset` per
/// unit of weight, and a channel on clip `clip` taking its weight 0 → 1 → 0, the peak at
/// `peak` of the clip's duration (tests of animated morph weights).
#[allow(dead_code)]
pub fn add_lifting_morph(c: &mut polypostor::Character, clip: usize, above_x: f32, offset: glam::Vec3, peak: f32) {
    use polypostor::character::{Interpolation, MorphChannel, MorphTarget};
    let moved: Vec<u32> = (0..c.vertices.len() as u32)
        .filter(|&i| c.vertices[i as usize].position.x > above_x)
        .collect();
    c.morphs = vec![MorphTarget {
        name: "lift".into(),
        rest_weight: 0.0,
        positions: vec![offset; moved.len()],
        normals: vec![glam::Vec3::ZERO; moved.len()],
        vertices: moved,
    }];
    let d = c.clips[clip].duration_secs;
    c.clips[clip].morph_channels = vec![MorphChannel {
        targets: vec![0],
        interpolation: Interpolation::Linear,
        times: vec![0.0, d * peak, d],
        values: vec![0.0, 1.0, 0.0],
    }];
}
