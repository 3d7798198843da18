//! Issue 16, reproduced first and kept closed: nothing a user has is lost or overwritten,
//! documented settings bake or are refused up front, tiny inputs never cause unbounded work,
//! damaged packs are refused with the file they concern, dropped corrections are reported,
//! limits are checked before the work, nothing is left behind, URIs stay in the model's
//! folder, and a closed pipe ends the command line quietly. (The editor's side — the
//! unsaved-work prompt on New/Open, a cancelled bake that is not an error, the palette's part
//! limit — is in `src/editor/tests.rs`; the generated-damage suite in `tests/mutations.rs`.)

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_polypostor"))
}

fn run_in(dir: &Path, args: &[&str]) -> Output {
    bin().current_dir(dir).args(args).output().expect("run polypostor")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A refusal: exit 1, one clear error line containing `want`, no panic, and no work done (the
/// bake's "baking …" line never printed).
fn refused(o: &Output, want: &str) -> String {
    let e = stderr(o);
    assert_eq!(o.status.code(), Some(1), "expected a refusal mentioning '{want}':\n{e}");
    assert!(e.contains("error:") && e.contains(want), "expected '{want}' in:\n{e}");
    assert!(!e.contains("panicked"), "{e}");
    assert!(
        !e.contains("\nbaking ") && !e.starts_with("baking "),
        "work started before the refusal:\n{e}"
    );
    e
}

fn default_glb() -> PathBuf {
    common::repo_path(polypostor::default_character::DEFAULT_CHARACTER_PATH)
}

/// A small bake of every representation of the default character, made once per test run.
fn small_bake() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = common::temp_dir("hardening-bake").keep();
        let out = dir.join("small.pack");
        let o = run_in(
            &dir,
            &[
                "bake",
                default_glb().to_str().unwrap(),
                "--views",
                "2",
                "--resolution",
                "32",
                "--representation",
                "all",
                "--out",
                out.to_str().unwrap(),
            ],
        );
        assert!(o.status.success(), "{}", stderr(&o));
        out
    })
}

fn edit_json(file: &Path, f: impl FnOnce(&mut serde_json::Value)) {
    let mut v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(file).unwrap()).unwrap();
    f(&mut v);
    std::fs::write(file, serde_json::to_string_pretty(&v).unwrap()).unwrap();
}

fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

// --- 1. Data loss -------------------------------------------------------------------

#[test]
fn bake_out_replaces_only_what_this_tool_wrote() {
    let dir = common::temp_dir("hardening-out");
    let glb = default_glb();
    let glb = glb.to_str().unwrap();
    let small = ["--views", "1", "--resolution", "32", "--fps", "5"];
    let bake = |out: &str| {
        let mut args = vec!["bake", glb, "--out", out];
        args.extend(small);
        run_in(&dir, &args)
    };
    // A folder of the user's.
    std::fs::create_dir(dir.join("mydocs")).unwrap();
    std::fs::write(dir.join("mydocs/notes.txt"), "mine").unwrap();
    refused(&bake("mydocs"), "did not write");
    assert_eq!(std::fs::read_to_string(dir.join("mydocs/notes.txt")).unwrap(), "mine");
    // A file.
    std::fs::write(dir.join("afile"), "mine").unwrap();
    refused(&bake("afile"), "regular file");
    assert_eq!(std::fs::read_to_string(dir.join("afile")).unwrap(), "mine");
    // The current folder, and what holds it.
    refused(&bake("."), "folder name");
    refused(&bake(".."), "folder name");
    refused(&bake(dir.parent().unwrap().to_str().unwrap()), "current folder");
    // A project: its folder and anything inside it.
    let project = dir.join("proj");
    std::fs::create_dir(&project).unwrap();
    let p = polypostor::project::Project::new_for_character("proj", &default_glb(), &project);
    p.save(&project.join("project.json")).unwrap();
    let before = std::fs::read(project.join("project.json")).unwrap();
    for out in ["proj", "proj/sub.pack", "proj/."] {
        let o = run_in(&dir, &["bake", "proj", "--out", out, "--views", "1"]);
        refused(&o, "project folder");
    }
    // ... and the folder that holds the character.
    let chars = dir.join("chars");
    std::fs::create_dir(&chars).unwrap();
    std::fs::copy(default_glb(), chars.join("c.glb")).unwrap();
    let o = run_in(&dir, &["bake", "chars/c.glb", "--out", "chars", "--views", "1"]);
    refused(&o, "input");
    assert_eq!(std::fs::read(project.join("project.json")).unwrap(), before);
    assert!(chars.join("c.glb").is_file());

    // A folder this tool wrote is replaced; interrupted writers' staging is cleaned first.
    let dead = 999_999_999u32;
    for kind in ["writing", "old"] {
        let s = dir.join(format!(".ok.pack.{kind}-{dead}"));
        std::fs::create_dir(&s).unwrap();
        std::fs::write(s.join("vertices.bin"), [0u8; 1000]).unwrap();
    }
    let first = bake("ok.pack");
    assert!(first.status.success(), "{}", stderr(&first));
    assert!(dir.join("ok.pack/manifest.json").is_file());
    let second = bake("ok.pack");
    assert!(
        second.status.success(),
        "re-baking over its own pack: {}",
        stderr(&second)
    );
    let left: Vec<String> = listing(&dir)
        .into_iter()
        .filter(|n| n.starts_with(".ok.pack"))
        .collect();
    assert!(left.is_empty(), "staging left behind: {left:?}");
    // Once the user keeps a file of theirs in it, it is no longer only ours.
    std::fs::write(dir.join("ok.pack/notes.txt"), "mine").unwrap();
    refused(&bake("ok.pack"), "notes.txt");
    assert_eq!(std::fs::read_to_string(dir.join("ok.pack/notes.txt")).unwrap(), "mine");
    std::fs::remove_file(dir.join("ok.pack/notes.txt")).unwrap();
    // Nor in the folders the tool writes into it, nor under a name like the bake's own that
    // its manifest does not list (both were deleted by a re-bake before 2026-12-02).
    for (path, shown) in [
        ("ok.pack/debug/notes.md", "debug/notes.md"),
        ("ok.pack/compare/notes.md", "compare/notes.md"),
        ("ok.pack/atlas_999.ktx2", "atlas_999.ktx2"),
    ] {
        let file = dir.join(path);
        std::fs::create_dir_all(file.parent().unwrap()).unwrap();
        std::fs::write(&file, "mine").unwrap();
        refused(&bake("ok.pack"), shown);
        assert_eq!(std::fs::read_to_string(&file).unwrap(), "mine");
        std::fs::remove_file(&file).unwrap();
    }

    // generate-default never renames over what it did not write.
    std::fs::write(dir.join("mine.glb"), "mine").unwrap();
    let o = run_in(&dir, &["generate-default", "-o", "mine.glb"]);
    refused(&o, "not written by this tool");
    assert_eq!(std::fs::read_to_string(dir.join("mine.glb")).unwrap(), "mine");
    refused(
        &run_in(&dir, &["generate-default", "-o", "/dev/null"]),
        "character device",
    );
    refused(&run_in(&dir, &["generate-default", "-o", "gen.txt"]), "name it .glb");
    let o = run_in(&dir, &["generate-default", "-o", "gen.glb"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run_in(&dir, &["generate-default", "-o", "gen.glb"]);
    assert!(o.status.success(), "its own file is regenerated: {}", stderr(&o));
    assert_eq!(
        std::fs::read(dir.join("gen.glb")).unwrap(),
        std::fs::read(default_glb()).unwrap()
    );
    // render -o: the same rule for images.
    std::fs::write(dir.join("photo.png"), "mine").unwrap();
    let o = run_in(&dir, &["render", glb, "-o", "photo.png", "--size", "32"]);
    refused(&o, "not written by this tool");
    let o = run_in(&dir, &["render", glb, "-o", "r.png", "--size", "32"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run_in(&dir, &["render", glb, "-o", "r.png", "--size", "32"]);
    assert!(o.status.success(), "{}", stderr(&o));
    // A PNG under another name (it wrote PNG bytes into x.jpg) and a missing folder (said
    // after the render) are refused before any work.
    let o = run_in(&dir, &["render", glb, "-o", "x.jpg", "--size", "32"]);
    refused(&o, ".png");
    assert!(!dir.join("x.jpg").exists());
    let o = run_in(&dir, &["render", glb, "-o", "nodir/x.png", "--size", "32"]);
    refused(&o, "does not exist");
    assert!(
        !stderr(&o).contains("adapter"),
        "refused before the GPU: {}",
        stderr(&o)
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

// --- 2. Documented settings ---------------------------------------------------------

#[test]
fn documented_settings_bake_or_are_refused_up_front() {
    let dir = common::temp_dir("hardening-settings");
    let glb = default_glb();
    let glb = glb.to_str().unwrap();
    let t = Instant::now();
    refused(&run_in(&dir, &["bake", glb, "--views", "100000"]), "4096");
    refused(
        &run_in(&dir, &["bake", glb, "--views", "4097", "--representation", "impostor"]),
        "4096",
    );
    refused(&run_in(&dir, &["bake", glb, "--resolution", "4096"]), "2048");
    refused(&run_in(&dir, &["bake", glb, "--fps", "1e-45"]), "--fps");
    refused(&run_in(&dir, &["bake", glb, "--fps", "241"]), "--fps");
    refused(&run_in(&dir, &["bake", glb, "--key-ratio", "0.5"]), "--key-ratio");
    refused(&run_in(&dir, &["bake", glb, "--key-ratio", "NaN"]), "--key-ratio");
    // Within the documented ranges but beyond this machine: refused before any rendering,
    // with the limit named.
    refused(&run_in(&dir, &["bake", glb, "--resolution", "2048"]), "memory");
    refused(
        &run_in(&dir, &["bake", glb, "--resolution", "2048", "--representation", "all"]),
        "texture limit",
    );
    refused(
        &run_in(&dir, &["render", glb, "-o", "x.png", "--size", "16384"]),
        "megapixels",
    );
    refused(
        &run_in(&dir, &["render", glb, "-o", "x.png", "--size", "100000"]),
        "16384",
    );
    assert!(t.elapsed() < Duration::from_secs(60), "refusals took {:?}", t.elapsed());
    assert!(!dir.join("x.png").exists());

    let pack = small_bake();
    let o = run_in(
        &dir,
        &[
            "bench",
            "crowd",
            "--pack",
            pack.to_str().unwrap(),
            "--width",
            "100000",
            "--counts",
            "10",
        ],
    );
    refused(&o, "texture limit");
    // compare on a pack whose resolution is past the limit: the loader names it.
    let forged = dir.join("forged.pack");
    common::copy_folder(pack, &forged);
    edit_json(&forged.join("manifest.json"), |v| v["resolution"] = 4096.into());
    let o = run_in(&dir, &["compare", forged.to_str().unwrap(), "--views", "1"]);
    refused(&o, "resolution 4096");

    // A clip longer than 12.8 s bakes (its frames no longer fit one render target at 128²
    // on most GPUs): a 20 s clip at one view.
    let mut c = polypostor::default_character::generate();
    let walk = c.find_clip("Walk").unwrap();
    let clip = &mut c.clips[walk];
    for ch in &mut clip.channels {
        for t in &mut ch.times {
            *t *= 20.0;
        }
    }
    clip.duration_secs *= 20.0;
    let long = dir.join("long.glb");
    std::fs::write(&long, polypostor::gltf_write::write_glb(&c).unwrap()).unwrap();
    let o = run_in(
        &dir,
        &[
            "bake",
            long.to_str().unwrap(),
            "--views",
            "1",
            "--resolution",
            "16",
            "--out",
            "long.pack",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let p = polypostor::pack::load_pack(&dir.join("long.pack")).unwrap();
    assert_eq!(p.manifest.frames, 200);
    std::fs::remove_dir_all(&dir).unwrap();
}

// --- 3. Unbounded work from tiny inputs --------------------------------------------

/// The default character with one clip whose key times are `[0, end]`.
fn clip_until(end: f32) -> Vec<u8> {
    let mut c = polypostor::default_character::generate();
    let clip = &mut c.clips[0];
    clip.channels.truncate(1);
    let ch = &mut clip.channels[0];
    ch.times = vec![0.0, end];
    ch.interpolation = polypostor::character::Interpolation::Linear;
    ch.values = match &ch.values {
        polypostor::character::ChannelValues::Rotation(v) => {
            polypostor::character::ChannelValues::Rotation(vec![v[0]; 2])
        }
        polypostor::character::ChannelValues::Translation(v) => {
            polypostor::character::ChannelValues::Translation(vec![v[0]; 2])
        }
        polypostor::character::ChannelValues::Scale(v) => polypostor::character::ChannelValues::Scale(vec![v[0]; 2]),
    };
    clip.duration_secs = end;
    let name = clip.name.clone();
    c.clips.retain(|k| k.name == name);
    polypostor::gltf_write::write_glb(&c).unwrap()
}

#[test]
fn absurd_clip_lengths_are_refused_before_the_work() {
    let dir = common::temp_dir("hardening-clips");
    for (name, end) in [("e30.glb", 1e30f32), ("e6.glb", 1e6)] {
        std::fs::write(dir.join(name), clip_until(end)).unwrap();
        let o = run_in(&dir, &["inspect", name, "--json"]);
        assert!(o.status.success(), "{}", stderr(&o));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert!(v["clips"][0]["duration_secs"].as_f64().unwrap() >= end as f64 * 0.99);
        let t = Instant::now();
        refused(&run_in(&dir, &["bake", name, "--views", "1"]), "10000");
        assert!(t.elapsed() < Duration::from_secs(30));
        refused(
            &run_in(&dir, &["bake", name, "--views", "1", "--representation", "rigid"]),
            "10000",
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[cfg(unix)]
#[test]
fn special_files_are_never_read() {
    use std::os::unix::fs::symlink;
    let dir = common::temp_dir("hardening-special");
    let pack = small_bake();
    // inspect /dev/zero, and a .glb that is a link to it.
    refused(&run_in(&dir, &["inspect", "/dev/zero"]), "not a regular file");
    symlink("/dev/zero", dir.join("zero.glb")).unwrap();
    refused(&run_in(&dir, &["inspect", "zero.glb"]), "not a regular file");
    // Every data file of a baked folder, in turn.
    for name in [
        "vertices.bin",
        "indices.bin",
        "rigid.bin",
        "np3d.bin",
        "atlas_001.ktx2",
        "manifest.json",
        "representations.json",
    ] {
        let d = dir.join(format!("link-{name}"));
        common::copy_folder(pack, &d);
        std::fs::remove_file(d.join(name)).unwrap();
        symlink("/dev/zero", d.join(name)).unwrap();
        let t = Instant::now();
        let e = polypostor::scene::CrowdAssets::load(&d, Some(&default_glb()), None)
            .err()
            .unwrap_or_else(|| panic!("{name} linked to /dev/zero loaded"));
        assert!(e.contains(name) && e.contains("character device"), "{name}: {e}");
        assert!(t.elapsed() < Duration::from_secs(10));
    }
    // A FIFO where an atlas should be: refused at once, no hang.
    let d = dir.join("fifo");
    common::copy_folder(pack, &d);
    std::fs::remove_file(d.join("atlas_001.ktx2")).unwrap();
    let c = std::ffi::CString::new(d.join("atlas_001.ktx2").to_str().unwrap()).unwrap();
    // SAFETY: mkfifo on a path inside the test's own folder.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
    let (tx, rx) = std::sync::mpsc::channel();
    let dd = d.clone();
    std::thread::spawn(move || {
        let _ = tx.send(polypostor::pack::load_pack(&dd).err().map(|e| e.to_string()));
    });
    let e = rx
        .recv_timeout(Duration::from_secs(20))
        .expect("the loader hangs on a FIFO")
        .expect("a FIFO atlas loaded");
    assert!(e.contains("FIFO"), "{e}");
    // A project file, and the character path a representations folder names.
    let proj = dir.join("proj");
    std::fs::create_dir(&proj).unwrap();
    symlink("/dev/zero", proj.join("project.json")).unwrap();
    let e = polypostor::project::Project::load(&proj).unwrap_err().to_string();
    assert!(e.contains("character device"), "{e}");
    let d = dir.join("charpath");
    common::copy_folder(pack, &d);
    edit_json(&d.join("representations.json"), |v| {
        v["character_path"] = dir.join("zero.glb").to_str().unwrap().into()
    });
    let e = polypostor::scene::CrowdAssets::load(&d, None, None).err().unwrap();
    assert!(e.contains("not a regular file"), "{e}");
    // A glTF buffer URI naming a link to /dev/zero.
    let model = dir.join("model");
    std::fs::create_dir(&model).unwrap();
    let files = polypostor::gltf_write::write_gltf(
        &polypostor::default_character::generate(),
        &polypostor::gltf_write::BufferStorage::External("data.bin".into()),
    )
    .unwrap();
    std::fs::write(model.join("c.gltf"), &files.json).unwrap();
    symlink("/dev/zero", model.join("data.bin")).unwrap();
    let e = polypostor::import_path(&model.join("c.gltf")).unwrap_err().to_string();
    assert!(
        e.contains("/dev/zero") && e.contains("outside the model's folder"),
        "{e}"
    );
    // ... and a FIFO in the model's own folder is not read either.
    std::fs::remove_file(model.join("data.bin")).unwrap();
    let c = std::ffi::CString::new(model.join("data.bin").to_str().unwrap()).unwrap();
    // SAFETY: mkfifo on a path inside the test's own folder.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
    let e = polypostor::import_path(&model.join("c.gltf")).unwrap_err().to_string();
    assert!(e.contains("FIFO"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn many_views_naming_one_image_and_huge_textures_are_refused() {
    let dir = common::temp_dir("hardening-images");
    let pack = small_bake();
    // Every view names the first view's atlas (a few KB on disk, decoded once per view).
    let d = dir.join("one-image");
    common::copy_folder(pack, &d);
    edit_json(&d.join("manifest.json"), |v| {
        let first = v["views"][0]["atlas"].clone();
        for view in v["views"].as_array_mut().unwrap() {
            view["atlas"] = first.clone();
        }
    });
    let e = polypostor::pack::load_pack(&d).unwrap_err().to_string();
    assert!(e.contains("named twice"), "{e}");
    // An atlas size far beyond what the packer makes for these parts.
    let d = dir.join("big-atlas");
    common::copy_folder(pack, &d);
    edit_json(&d.join("manifest.json"), |v| {
        v["views"][0]["atlas_size"] = serde_json::json!([8192, 8192])
    });
    let e = polypostor::pack::load_pack(&d).unwrap_err().to_string();
    assert!(e.contains("atlas size 8192×8192"), "{e}");
    // A .glb holding a 16384² texture (a 1 MB file): refused by its header, before decoding.
    let mut c = polypostor::default_character::generate();
    c.textures[0] = polypostor::character::Texture {
        name: "huge".into(),
        width: 1,
        height: 1,
        rgba8: vec![255; 4],
    };
    let glb = polypostor::gltf_write::write_glb(&c).unwrap();
    let glb = replace_png(&glb, &huge_png(16384));
    let t = Instant::now();
    let imported = polypostor::import::import_slice(&glb, None, "huge").unwrap();
    assert!(t.elapsed() < Duration::from_secs(5));
    assert!(imported.textures.is_empty());
    assert!(
        imported
            .warnings
            .iter()
            .any(|w| w.contains("16384×16384") && w.contains("8192")),
        "{:?}",
        imported.warnings
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A valid, all-black RGBA PNG of `side`² pixels, written row by row (about 1 MB at 16384²).
pub fn huge_png(side: u32) -> Vec<u8> {
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, side, side);
        enc.set_color(png::ColorType::Rgba);
        enc.set_compression(png::Compression::Fast);
        let mut w = enc.write_header().unwrap();
        let mut stream = w.stream_writer().unwrap();
        let row = vec![0u8; side as usize * 4];
        for _ in 0..side {
            std::io::Write::write_all(&mut stream, &row).unwrap();
        }
        stream.finish().unwrap();
    }
    out
}

/// The GLB with its one embedded PNG replaced by `png` (buffer view and lengths updated).
pub fn replace_png(glb: &[u8], png: &[u8]) -> Vec<u8> {
    let (mut json, mut bin) = polypostor::gltf_write::glb_parts(glb).unwrap();
    let view = json["images"][0]["bufferView"].as_u64().unwrap() as usize;
    let offset = bin.len();
    bin.extend_from_slice(png);
    json["bufferViews"][view]["byteOffset"] = offset.into();
    json["bufferViews"][view]["byteLength"] = png.len().into();
    json["buffers"][0]["byteLength"] = bin.len().into();
    polypostor::gltf_write::glb_container(&json, &bin).unwrap()
}

#[test]
fn long_node_chains_import_in_linear_time() {
    // 300,000 nodes in one chain, a triangle on the deepest.
    let n = 300_000usize;
    let mut nodes: Vec<serde_json::Value> = (0..n - 1).map(|i| serde_json::json!({"children": [i + 1]})).collect();
    nodes.push(serde_json::json!({"mesh": 0}));
    let positions: Vec<u8> = [0f32, 0., 0., 1., 0., 0., 0., 1., 0.]
        .iter()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    use base64::Engine;
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&positions)
    );
    let gltf = serde_json::json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": nodes,
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                        "min": [0, 0, 0], "max": [1, 1, 0]}],
        "bufferViews": [{"buffer": 0, "byteLength": 36}],
        "buffers": [{"byteLength": 36, "uri": uri}],
    });
    let bytes = serde_json::to_vec(&gltf).unwrap();
    let t = Instant::now();
    let c = polypostor::import::import_slice(&bytes, None, "chain").unwrap();
    assert_eq!(c.triangle_count(), 1);
    assert!(t.elapsed() < Duration::from_secs(20), "took {:?}", t.elapsed());
    // A cycle is found without walking it once per node.
    let mut gltf = gltf;
    gltf["nodes"][n - 1]["children"] = serde_json::json!([0]);
    gltf["scenes"][0]["nodes"] = serde_json::json!([1]);
    let t = Instant::now();
    let e = polypostor::import::import_slice(&serde_json::to_vec(&gltf).unwrap(), None, "cycle").unwrap_err();
    assert!(
        e.to_string().contains("cycle") || e.to_string().contains("two parents"),
        "{e}"
    );
    assert!(t.elapsed() < Duration::from_secs(20), "took {:?}", t.elapsed());
}

// --- 4. Damaged packs -----------------------------------------------------------------

#[test]
fn damaged_numbers_and_disagreeing_manifests_are_named() {
    let dir = common::temp_dir("hardening-damage");
    let pack = small_bake();
    let case = |name: &str, file: &str, f: &dyn Fn(&mut serde_json::Value)| -> String {
        let d = dir.join(name);
        common::copy_folder(pack, &d);
        edit_json(&d.join(file), f);
        polypostor::scene::CrowdAssets::load(&d, Some(&default_glb()), None)
            .err()
            .unwrap_or_else(|| panic!("{name}: a damaged folder loaded"))
    };
    let pack_cases: Vec<(&str, Box<dyn Fn(&mut serde_json::Value)>, &str)> = vec![
        (
            "zero-direction",
            Box::new(|v| v["views"][0]["direction"] = serde_json::json!([0, 0, 0])),
            "unit vector",
        ),
        (
            "inf-direction",
            Box::new(|v| v["views"][1]["direction"] = serde_json::json!([1e39, 0, 0])),
            "unit vector",
        ),
        ("res-0", Box::new(|v| v["resolution"] = 0.into()), "resolution 0"),
        (
            "res-max",
            Box::new(|v| v["resolution"] = u32::MAX.into()),
            "resolution 4294967295",
        ),
        ("fps-tiny", Box::new(|v| v["fps"] = 1e-45.into()), "frame rate"),
        ("fps-huge", Box::new(|v| v["fps"] = 3.4e38.into()), "frame rate"),
        (
            "camera",
            Box::new(|v| v["views"][0]["camera"]["right"] = serde_json::json!([0, 0, 0])),
            "camera",
        ),
        (
            "camera-size",
            Box::new(|v| v["views"][0]["camera"]["half_size"] = 0.into()),
            "half size",
        ),
        ("old", Box::new(|v| v["version"] = 2.into()), "re-bake"),
    ];
    for (name, f, want) in &pack_cases {
        let e = case(name, "manifest.json", f.as_ref());
        assert!(e.contains(want) && e.contains("manifest.json"), "{name}: {e}");
    }
    let reps_cases: Vec<(&str, Box<dyn Fn(&mut serde_json::Value)>, &str)> = vec![
        ("reps-res", Box::new(|v| v["resolution"] = 0.into()), "resolution 0"),
        ("reps-fps", Box::new(|v| v["fps"] = 1e-45.into()), "frame rate"),
        (
            "reps-columns",
            Box::new(|v| {
                v["impostor"]["columns"] = (1u64 << 31).into();
                v["impostor"]["rows"] = 2.into();
            }),
            "impostor sheets",
        ),
        (
            "reps-camera",
            Box::new(|v| v["views"][0]["camera"]["up"] = serde_json::json!([1, 0, 0])),
            "camera",
        ),
        ("reps-old", Box::new(|v| v["version"] = 1.into()), "re-bake"),
        (
            "reps-garbage",
            Box::new(|v| v["frames"] = "ten".into()),
            "not a valid manifest",
        ),
    ];
    for (name, f, want) in &reps_cases {
        let e = case(name, "representations.json", f.as_ref());
        assert!(e.contains(want) && e.contains("representations.json"), "{name}: {e}");
        assert!(!e.contains("manifest.json"), "{name}: names the wrong file: {e}");
    }
    // The pack and the representations beside it disagree on the frame count (each
    // consistent in itself: the representations carry their own vertex data).
    let d = dir.join("frames");
    common::copy_folder(pack, &d);
    edit_json(&d.join("manifest.json"), |v| {
        v["frames"] = 9.into();
    });
    let e = polypostor::scene::CrowdAssets::load(&d, Some(&default_glb()), None)
        .err()
        .unwrap();
    assert!(
        // The pack's own per-frame tables (clip table, vertex blocks, key tables) may catch it
        // first.
        e.contains("frames")
            && (e.contains("disagree")
                || e.contains("past the end")
                || e.contains("frame keys for 9 frames")
                || e.contains("the clips hold 10 frames but the bake has 9")),
        "{e}"
    );
    // A byte flipped anywhere in the data: the checksum names the file.
    let flipped = |name: &str| {
        let d = dir.join(format!("flip-{name}"));
        common::copy_folder(pack, &d);
        let mut bytes = std::fs::read(d.join(name)).unwrap();
        let k = bytes.len() / 2;
        bytes[k] ^= 0x10;
        std::fs::write(d.join(name), &bytes).unwrap();
        d
    };
    for name in [
        "vertices.bin",
        "indices.bin",
        "rigid.bin",
        "np3d.bin",
        "normal_000.ktx2",
        "far_impostor_color_001.ktx2",
        "far_impostor_normal_001.ktx2",
        "far_impostor_part_001.png",
    ] {
        let e = polypostor::scene::CrowdAssets::load(&flipped(name), Some(&default_glb()), None)
            .err()
            .unwrap_or_else(|| panic!("{name}: a flipped byte loaded"));
        assert!(e.contains(name) && e.contains("checksum"), "{name}: {e}");
    }
    // The full-resolution impostor sheets are read when the impostor level is first drawn on
    // its own (the mix draws from the far ones): a flipped byte is named then.
    let name = "impostor_color_001.ktx2";
    let assets = polypostor::scene::CrowdAssets::load(&flipped(name), Some(&default_glb()), None).unwrap();
    let e = assets.full_impostors().err().expect("a flipped byte loaded");
    assert!(e.contains(name) && e.contains("checksum"), "{name}: {e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

// --- 5. Dropped corrections, 6. late failures -------------------------------------------

/// A project's bake setting out of range is refused naming the project file and its field,
/// and a flag given on the command line overrides it; an output no folder can be created in
/// is refused before the work.
#[test]
fn project_settings_and_unwritable_outputs_are_refused_before_the_work() {
    let dir = common::temp_dir("hardening-project-settings");
    let project = dir.join("proj");
    std::fs::create_dir(&project).unwrap();
    let mut p = polypostor::project::Project::new_for_character("proj", &default_glb(), &project);
    p.bake.views = 0;
    p.save(&project.join("project.json")).unwrap();
    let e = refused(&run_in(&dir, &["bake", "proj", "--out", "a.pack"]), "project.json");
    assert!(e.contains("bake setting views 0") && e.contains("--views"), "{e}");
    // A small bake of the project into `out`, its settings given on the command line.
    let small_with = |out: &str, more: &[&str]| {
        let mut args = vec![
            "bake",
            "proj",
            "--views",
            "1",
            "--resolution",
            "32",
            "--fps",
            "5",
            "--out",
            out,
        ];
        args.extend_from_slice(more);
        run_in(&dir, &args)
    };
    let small = |out: &str| small_with(out, &[]);
    let o = small("a.pack");
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("coarsest outline"), "{}", stderr(&o));
    // Polygons of a few vertices are allowed but said (3 gave 5.6 dB).
    let o = small_with("few.pack", &["--polygon-vertices", "6"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("polygons of 6 vertices follow only the coarsest outline"),
        "{}",
        stderr(&o)
    );
    // A part painted over entirely is said once, by name.
    let c = polypostor::import_path(&default_glb()).unwrap();
    let mut seg = polypostor::bake::segment::auto_segment(&c);
    seg.parts.push(polypostor::bake::segment::Part {
        name: "Ghost".into(),
        color: [1, 2, 3],
    });
    p.segmentation = Some(polypostor::project::StoredSegmentation::from_segmentation(&seg));
    p.save(&project.join("project.json")).unwrap();
    let o = small("b.pack");
    let e = stderr(&o);
    assert!(o.status.success(), "{e}");
    assert_eq!(e.matches("'Ghost' hold no triangles").count(), 1, "{e}");
    #[cfg(target_os = "linux")]
    refused(
        &run_in(
            &dir,
            &["bake", "proj", "--views", "1", "--out", "/proc/polypostor-test.pack"],
        ),
        "cannot write",
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn dropped_corrections_are_reported_by_kind() {
    use polypostor::bake::overrides::{OverrideBasis, Pin};
    let dir = common::temp_dir("hardening-corrections");
    let project = dir.join("proj");
    std::fs::create_dir(&project).unwrap();
    let mut p = polypostor::project::Project::new_for_character("proj", &default_glb(), &project);
    let basis = OverrideBasis {
        views: 1,
        full_sphere: false,
        frames: 5,
    };
    let v = p.overrides.view_mut(basis, 0);
    v.key_frame = Some(7); // past the 5 frames
    v.order = Some(vec![0, 1]); // not every part
    v.pins.insert(
        0,
        vec![
            Pin {
                frame: 1,
                source: 500, // no such vertex
                target: 0,
            },
            Pin {
                frame: 9, // no such frame
                source: 0,
                target: 0,
            },
        ],
    );
    p.overrides.views.entry(3).or_default().key_frame = Some(1); // no view 3
    p.view.clip = Some("Nope".into()); // no such clip: the Walk is baked, and that is said
    p.save(&project.join("project.json")).unwrap();
    let bake = |views: &str| {
        run_in(
            &dir,
            &[
                "bake",
                "proj",
                "--views",
                views,
                "--resolution",
                "32",
                "--fps",
                "5",
                "--out",
                "out.pack",
            ],
        )
    };
    let o = bake("1");
    let e = stderr(&o);
    assert!(o.status.success(), "{e}");
    for want in [
        "warning: 1 key frame(s) lie past the clip's frames; ignored",
        "warning: 1 drawing order(s) do not list each part of the bake once; ignored",
        "warning: 1 correction(s) refer to views this bake does not have; ignored",
        "warning: the project's clip 'Nope' is not among the character's clips; baking Walk",
    ] {
        assert!(e.contains(want), "missing '{want}' in:\n{e}");
    }
    // One pin past the frames (said before the bake), one past the polygon (after it, as
    // one more).
    assert_eq!(
        e.matches("pin(s) refer to frames, parts or polygon vertices").count(),
        1,
        "{e}"
    );
    assert!(
        e.contains("warning: 1 more pin(s) refer to polygon vertices the fitted polygons do not have"),
        "{e}"
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("out.pack/report.json")).unwrap()).unwrap();
    assert_eq!(report["dropped_corrections"]["pins"], 2);
    assert_eq!(report["dropped_corrections"]["key_frames"], 1);
    // Another number of views: every correction is dropped, in one line that says why.
    let o = bake("2");
    let e = stderr(&o);
    assert!(o.status.success(), "{e}");
    assert!(
        e.contains("warning: 5 correction(s) were made for a bake of 1 views and 5 frames"),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn limits_that_can_be_checked_are_checked_before_the_work() {
    let dir = common::temp_dir("hardening-late");
    // A segmentation of 21 parts.
    let project = dir.join("proj");
    std::fs::create_dir(&project).unwrap();
    let c = polypostor::import_path(&default_glb()).unwrap();
    let mut seg = polypostor::bake::segment::auto_segment(&c);
    while seg.parts.len() < 21 {
        seg.parts.push(polypostor::bake::segment::Part {
            name: format!("extra {}", seg.parts.len()),
            color: [1, 2, 3],
        });
    }
    let n = seg.labels.len();
    for (t, l) in seg.labels.iter_mut().enumerate() {
        *l = (t * 21 / n) as u16;
    }
    let mut p = polypostor::project::Project::new_for_character("proj", &default_glb(), &project);
    p.segmentation = Some(polypostor::project::StoredSegmentation::from_segmentation(&seg));
    p.save(&project.join("project.json")).unwrap();
    let t = Instant::now();
    refused(&run_in(&dir, &["bake", "proj", "--out", "a.pack"]), "21 parts");
    // Positions up to 3e38 (finite, far past any sensible size).
    let mut c = polypostor::default_character::generate();
    for v in &mut c.vertices {
        v.position *= 1e30;
    }
    c.vertices[0].position.x = 3e38;
    std::fs::write(dir.join("huge.glb"), polypostor::gltf_write::write_glb(&c).unwrap()).unwrap();
    refused(
        &run_in(&dir, &["bake", "huge.glb", "--out", "b.pack"]),
        "beyond the limit",
    );
    assert!(t.elapsed() < Duration::from_secs(60), "took {:?}", t.elapsed());
    assert!(!dir.join("a.pack").exists() && !dir.join("b.pack").exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

// --- 7. Leftovers ----------------------------------------------------------------------

#[cfg(unix)]
#[test]
fn an_interrupted_benchmark_leaves_nothing_behind() {
    let tmp = common::temp_dir("hardening-tmp");
    // What a killed run left: removed by the next.
    std::fs::create_dir(tmp.join("polypostor-bench-999999999")).unwrap();
    std::fs::write(tmp.join("polypostor-bench-999999999/big.bin"), [0u8; 4096]).unwrap();
    let child = bin()
        .current_dir(&tmp)
        .env("TMPDIR", &*tmp)
        .args(["bench", "crowd", "--counts", "10", "--out", "bench"])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Wait until its temporary bake exists, then interrupt it.
    let started = Instant::now();
    let mine = format!("polypostor-bench-{}", child.id());
    while !tmp.join(&mine).exists() && started.elapsed() < Duration::from_secs(60) {
        std::thread::sleep(Duration::from_millis(50));
    }
    assert!(tmp.join(&mine).exists(), "the benchmark made no temporary folder");
    std::thread::sleep(Duration::from_millis(1500));
    // SAFETY: signalling our own child.
    unsafe {
        libc::kill(child.id() as i32, libc::SIGINT);
    }
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(130), "{}", stderr(&out));
    let left: Vec<String> = listing(&tmp)
        .into_iter()
        .filter(|n| n.starts_with("polypostor-bench"))
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
    std::fs::remove_dir_all(&tmp).unwrap();
}

/// `--out sub/../d.pack` where `sub` does not exist writes `d.pack` and makes no `sub` (an
/// empty folder the user never asked for was left).
#[test]
fn a_dotdot_in_the_output_makes_no_stray_folder() {
    let dir = common::temp_dir("hardening-dotdot");
    let o = run_in(
        &dir,
        &[
            "bake",
            default_glb().to_str().unwrap(),
            "--views",
            "1",
            "--resolution",
            "32",
            "--out",
            "sub/../d.pack",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(dir.join("d.pack/manifest.json").is_file());
    assert!(!dir.join("sub").exists(), "{:?}", listing(&dir));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Ctrl+C while `bench crowd` draws (not only while it bakes) ends it at once, writing no
/// figures: the first interrupt said "cancelling…" and the run went on for minutes.
#[test]
fn an_interrupted_crowd_benchmark_stops_drawing() {
    let tmp = common::temp_dir("hardening-crowd-int");
    let child = bin()
        .current_dir(&tmp)
        .args([
            "bench",
            "crowd",
            "--pack",
            small_bake().to_str().unwrap(),
            "--counts",
            "50",
            "--frames",
            "100000",
            "--representations",
            "polypostor",
            "--out",
            "bench",
        ])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Loading a two-view pack takes a few seconds at most; the drawing then runs for a minute.
    std::thread::sleep(Duration::from_secs(8));
    let signalled = Instant::now();
    // SAFETY: signalling our own child.
    unsafe {
        libc::kill(child.id() as i32, libc::SIGINT);
    }
    let out = child.wait_with_output().unwrap();
    let took = signalled.elapsed();
    assert_eq!(out.status.code(), Some(130), "{}", stderr(&out));
    assert!(took < Duration::from_secs(20), "ended {took:?} after the interrupt");
    assert!(
        !tmp.join("bench/crowd_fps.json").exists(),
        "no figures from a cancelled run"
    );
    std::fs::remove_dir_all(&tmp).unwrap();
}

// --- 8. Path escape ----------------------------------------------------------------------

#[test]
fn uris_stay_inside_the_models_folder() {
    let dir = common::temp_dir("hardening-uris");
    let model = dir.join("model");
    std::fs::create_dir_all(model.join("sub")).unwrap();
    let files = polypostor::gltf_write::write_gltf(
        &polypostor::default_character::generate(),
        &polypostor::gltf_write::BufferStorage::External("sub/data.bin".into()),
    )
    .unwrap();
    let bin = files.bin.unwrap();
    std::fs::write(model.join("sub/data.bin"), &bin).unwrap();
    std::fs::write(dir.join("outside.bin"), &bin).unwrap();
    let with_uri = |uri: &str| {
        let mut v: serde_json::Value = serde_json::from_str(&files.json).unwrap();
        v["buffers"][0]["uri"] = uri.into();
        std::fs::write(model.join("c.gltf"), serde_json::to_string(&v).unwrap()).unwrap();
        polypostor::import_path(&model.join("c.gltf")).map_err(|e| e.to_string())
    };
    assert!(
        with_uri("sub/data.bin").is_ok(),
        "a file below the model's folder is read"
    );
    assert!(with_uri("sub/../sub/data.bin").is_ok());
    // Out of the folder by name and straight back in is still inside (it was refused).
    assert!(with_uri("../model/./sub/data.bin").is_ok());
    let e = with_uri("../model2/sub/data.bin").unwrap_err();
    assert!(e.contains("leaves the model's folder"), "{e}");
    let e = with_uri("../outside.bin").unwrap_err();
    assert!(e.contains("leaves the model's folder"), "{e}");
    let e = with_uri("sub/../../outside.bin").unwrap_err();
    assert!(e.contains("leaves the model's folder"), "{e}");
    let e = with_uri("/etc/passwd").unwrap_err();
    assert!(e.contains("absolute"), "{e}");
    let e = with_uri("%2Fetc%2Fpasswd").unwrap_err();
    assert!(e.contains("absolute"), "{e}");
    let e = with_uri("file:///etc/passwd").unwrap_err();
    assert!(e.contains("not a relative file reference"), "{e}");
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(dir.join("outside.bin"), model.join("link.bin")).unwrap();
        let e = with_uri("link.bin").unwrap_err();
        assert!(e.contains("leads outside the model's folder"), "{e}");
        // The same model opened by its bare name from its own folder (the folder then is
        // "", whose resolution failed and skipped the link check: the outside file was read).
        let out = run_in(&model, &["inspect", "c.gltf"]);
        let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), stderr(&out));
        assert!(text.contains("leads outside the model's folder"), "{text}");
        // And through `..` back into the folder, then the link.
        with_uri("../model/link.bin").unwrap_err();
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

// --- 10. Broken pipe ---------------------------------------------------------------------

#[cfg(unix)]
#[test]
fn a_closed_pipe_ends_the_command_quietly() {
    for args in [
        vec!["inspect", "--json", default_glb().to_str().unwrap().to_owned().leak()],
        vec!["bench", "sim", "--agents", "200", "--frames", "5", "--json"],
    ] {
        let mut child = bin()
            .args(&args)
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        // The reader goes away before the first line is written (`| head -c 0`).
        drop(child.stdout.take());
        let out = child.wait_with_output().unwrap();
        let e = stderr(&out);
        assert!(!e.contains("panicked") && !e.contains("Broken pipe"), "{args:?}: {e}");
        use std::os::unix::process::ExitStatusExt;
        assert!(
            out.status.signal() == Some(libc::SIGPIPE) || out.status.success(),
            "{args:?}: {:?} {e}",
            out.status
        );
    }
}

/// The default character under a root node scaled by `k` (a GLB written for the test).
fn scaled_default(k: f32) -> Vec<u8> {
    scaled_default_by([k; 3])
}

/// The default character under a root node scaled by `k` along each axis.
fn scaled_default_by(k: [f32; 3]) -> Vec<u8> {
    let c = polypostor::default_character::generate();
    let glb = polypostor::gltf_write::write_glb(&c).unwrap();
    let (mut json, bin) = polypostor::gltf_write::glb_parts(&glb).unwrap();
    let scene = json["scene"].as_u64().unwrap_or(0) as usize;
    let roots = json["scenes"][scene]["nodes"].clone();
    let nodes = json["nodes"].as_array_mut().unwrap();
    nodes.push(serde_json::json!({"name": "UnitRoot", "scale": k, "children": roots}));
    let root = nodes.len() - 1;
    json["scenes"][scene]["nodes"] = serde_json::json!([root]);
    polypostor::gltf_write::glb_container(&json, &bin).unwrap()
}

/// A character 100× too big (a model in centimetres exported without its unit scale) or
/// 1000× too small imports with a warning naming its size, and the crowd measures it at the
/// size the file gives: a person-sized character has no warning.
#[test]
fn characters_of_implausible_size_are_reported_and_measured_as_the_file_says() {
    let person = polypostor::import::import_slice(&scaled_default(1.0), None, "person").unwrap();
    assert!(person.warnings.is_empty(), "{:?}", person.warnings);
    let size = |c: &polypostor::character::Character| polypostor::crowd::CharacterSize::measure(c, c.find_clip("Walk"));
    let base = size(&person);
    for (k, unit) in [(100.0f32, " m across"), (0.001, " mm across"), (1e-8, "e-8 m across")] {
        let c = polypostor::import::import_slice(&scaled_default(k), None, "scaled").unwrap();
        assert!(
            c.warnings.iter().any(|w| w.contains(unit) && w.contains("metres")),
            "scale {k}: {:?}",
            c.warnings
        );
        let s = size(&c);
        assert!(
            (s.height / base.height - k).abs() < 1e-3 * k,
            "scale {k}: {s:?} against {base:?}"
        );
        assert!((s.scale() / base.scale() - k).abs() < 1e-3 * k);
    }
}

/// An inverse bind matrix that is not a transform (a NaN, an infinity, all zeros) was taken
/// silently: the joint's vertices flew off or vanished. Now each is named in a warning and the
/// joint's rest pose stands in for its bind pose, which for a mesh bound in its rest pose (as
/// the default character is) gives back the same skinned mesh.
#[test]
fn broken_inverse_bind_matrices_are_named_and_replaced_by_the_rest_pose() {
    use polypostor::animation::{Pose, skin_vertices};
    let c = polypostor::default_character::generate();
    let glb = polypostor::gltf_write::write_glb(&c).unwrap();
    let original = polypostor::import::import_slice(&glb, None, "original").unwrap();
    let want = skin_vertices(&original, &Pose::rest(&original)).0;
    let (json, bin) = polypostor::gltf_write::glb_parts(&glb).unwrap();
    let skin = &json["skins"][0];
    let accessor = &json["accessors"][skin["inverseBindMatrices"].as_u64().unwrap() as usize];
    let view = &json["bufferViews"][accessor["bufferView"].as_u64().unwrap() as usize];
    let start =
        view["byteOffset"].as_u64().unwrap_or(0) as usize + accessor["byteOffset"].as_u64().unwrap_or(0) as usize;
    let joints = skin["joints"].as_array().unwrap().len();
    for (k, bad) in [(1usize, f32::NAN), (joints / 2, f32::INFINITY), (joints - 1, 0.0)] {
        let mut broken = bin.clone();
        for e in 0..16 {
            // The NaN and the infinity in the translation only; zero: the whole matrix.
            if bad == 0.0 || e == 13 {
                let at = start + (k * 16 + e) * 4;
                broken[at..at + 4].copy_from_slice(&bad.to_le_bytes());
            }
        }
        let file = polypostor::gltf_write::glb_container(&json, &broken).unwrap();
        let got = polypostor::import::import_slice(&file, None, "broken").unwrap();
        assert!(
            got.warnings.iter().any(|w| w.contains("inverse bind matrix")),
            "{bad}: {:?}",
            got.warnings
        );
        let have = skin_vertices(&got, &Pose::rest(&got)).0;
        assert_eq!(have.len(), want.len());
        let worst = have
            .iter()
            .zip(&want)
            .map(|(a, b)| (*a - *b).length())
            .fold(0.0f32, f32::max);
        assert!(worst < 1e-3, "{bad} in joint {k}: a vertex moved {worst}");
    }
}

/// A file that names no default scene and whose first scene is empty (the character in the
/// second) was refused ("the default scene has no triangle meshes"): the first scene holding
/// a mesh is imported, and said. A file whose named default is empty is still refused.
#[test]
fn without_a_default_scene_the_first_scene_with_a_mesh_is_imported() {
    let c = polypostor::default_character::generate();
    let glb = polypostor::gltf_write::write_glb(&c).unwrap();
    let (mut json, bin) = polypostor::gltf_write::glb_parts(&glb).unwrap();
    let scene = json["scene"].as_u64().unwrap_or(0) as usize;
    let character = json["scenes"][scene].clone();
    json["scenes"] = serde_json::json!([{"name": "Empty", "nodes": []}, character]);
    json.as_object_mut().unwrap().remove("scene");
    let file = polypostor::gltf_write::glb_container(&json, &bin).unwrap();
    let got = polypostor::import::import_slice(&file, None, "second").unwrap();
    assert_eq!(got.triangle_count(), c.triangle_count());
    assert!(got.warnings.iter().any(|w| w.contains("scene 1")), "{:?}", got.warnings);
    json["scene"] = serde_json::json!(0);
    let file = polypostor::gltf_write::glb_container(&json, &bin).unwrap();
    let e = polypostor::import::import_slice(&file, None, "named").unwrap_err();
    assert!(e.to_string().contains("no triangle meshes"), "{e}");
}

/// An animation channel aimed at a node the file does not have was dropped without a word
/// (a missing sampler was said): now it is said too, and the rest of the clip kept.
#[test]
fn a_channel_aimed_at_a_missing_node_is_said() {
    let c = polypostor::default_character::generate();
    let glb = polypostor::gltf_write::write_glb(&c).unwrap();
    let (mut json, bin) = polypostor::gltf_write::glb_parts(&glb).unwrap();
    let channels = json["animations"][0]["channels"].as_array().unwrap().len();
    json["animations"][0]["channels"][0]["target"]["node"] = serde_json::json!(9999);
    let file = polypostor::gltf_write::glb_container(&json, &bin).unwrap();
    let got = polypostor::import::import_slice(&file, None, "aimless").unwrap();
    assert!(
        got.warnings
            .iter()
            .any(|w| w.contains("node 9999, which does not exist")),
        "{:?}",
        got.warnings
    );
    let intact = polypostor::import::import_slice(&glb, None, "intact").unwrap();
    assert_eq!(intact.clips[0].channels.len(), channels);
    assert_eq!(got.clips[0].channels.len(), channels - 1);
}

/// A text file given a glTF name was reported as "invalid JSON: expected value at line 1",
/// which sends the user looking for a typo: it is said to be no glTF file at all. A JSON file
/// with a syntax error keeps the parser's message.
#[test]
fn a_file_that_is_no_gltf_at_all_is_said_to_be_none() {
    let e = polypostor::import::import_slice(b"hello, this is text\n", None, "fake").unwrap_err();
    assert!(e.to_string().contains("not a glTF file"), "{e}");
    let e = polypostor::import::import_slice(b"{\"asset\": ", None, "cut").unwrap_err();
    assert!(!e.to_string().contains("not a glTF file"), "{e}");
}

/// A character thinner than a pixel from some sides (the default squashed to 1/500 of its
/// width: a sheet seen edge-on from the front and back) traces nothing in those views. They
/// drew nothing against empty part images and were scored 99 dB, lifting the bake's mean;
/// now they are named in a warning and in the report and left out of its means.
#[test]
fn views_that_trace_nothing_are_named_and_left_out_of_the_means() {
    let dir = common::temp_dir("hardening-sheet");
    let glb = dir.join("sheet.glb");
    std::fs::write(&glb, scaled_default_by([0.002, 1.0, 1.0])).unwrap();
    let out = dir.join("sheet.pack");
    let o = run_in(
        &dir,
        &[
            "bake",
            glb.to_str().unwrap(),
            "--views",
            "8",
            "--resolution",
            "32",
            "--out",
            out.to_str().unwrap(),
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let r = polypostor::bake::report::read_report(&out).unwrap();
    assert!(
        !r.empty_views.is_empty() && r.empty_views.len() < r.views.len(),
        "{:?}",
        r.empty_views
    );
    assert!(stderr(&o).contains("trace no part of the character"), "{}", stderr(&o));
    let counted: Vec<f64> = r
        .views
        .iter()
        .filter(|v| !r.empty_views.contains(&v.index))
        .flat_map(|v| v.psnr.iter().copied())
        .collect();
    // The PSNR of the counted frames' mean RMSE.
    let rmse = counted.iter().map(|p| 10f64.powf(-p / 20.0)).sum::<f64>() / counted.len() as f64;
    let mean = -20.0 * rmse.log10();
    assert!((r.mean_psnr - mean).abs() < 1e-9, "{} against {mean}", r.mean_psnr);
    assert!(r.mean_psnr < 60.0, "{}", r.mean_psnr);
    assert!(r.worst_views.iter().all(|w| !r.empty_views.contains(&w.view)));
}
