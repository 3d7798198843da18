//! The runtime crate's example (`crates/polypostor-runtime/examples/headless_crowd.rs`), its
//! own source compiled here, run on a folder the studio bakes: it must draw a crowd into a
//! PNG. And the runtime crate must not pull in any UI or command-line crate.

mod common;

#[allow(dead_code)]
#[path = "../crates/polypostor-runtime/examples/headless_crowd.rs"]
mod headless_crowd;

use std::process::Command;

/// Pixels of `img` farther than a small tolerance from `sky` (any channel).
fn not_sky(img: &image::RgbaImage, sky: [u8; 3]) -> usize {
    img.pixels()
        .filter(|p| (0..3).any(|c| (p.0[c] as i32 - sky[c] as i32).abs() > 6))
        .count()
}

#[test]
fn the_example_draws_a_crowd_of_a_studio_bake() {
    let out = common::temp_dir("runtime_example");
    let baked = out.join("baked");
    let glb = common::repo_path("assets/characters/default_humanoid.glb");
    let status = Command::new(env!("CARGO_BIN_EXE_polypostor"))
        .args([
            "bake",
            glb.to_str().unwrap(),
            "--clip",
            "Walk",
            "--views",
            "6",
            "--resolution",
            "64",
        ])
        .args(["--fps", "5", "--max-keys", "1", "--representation", "all", "--out"])
        .arg(&baked)
        .status()
        .unwrap();
    assert!(status.success(), "the studio's bake failed");

    let arg = |s: &str| s.to_string();
    let png = |name: &str| out.join(name).to_str().unwrap().to_string();
    let many = png("many.png");
    let summary = headless_crowd::run(&[
        arg(baked.to_str().unwrap()),
        arg("--count"),
        arg("400"),
        arg("--no-ground"),
        arg("--out"),
        many.clone(),
    ])
    .unwrap_or_else(|e| panic!("the example failed: {e}"));
    println!("{summary}");
    assert!(summary.starts_with("400 agents"), "{summary}");
    let img = image::open(&many).unwrap().to_rgba8();
    assert_eq!(img.dimensions(), (960, 540));
    // The sky the example clears to, as stored in the sRGB target.
    let sky = *img.get_pixel(0, 0);
    let sky = [sky.0[0], sky.0[1], sky.0[2]];
    let covered = not_sky(&img, sky);
    let total = (960 * 540) as usize;
    assert!(
        covered > total / 200 && covered < total * 8 / 10,
        "{covered} of {total} pixels are not sky: no crowd, or nothing else"
    );

    // One agent covers far fewer pixels than 400.
    let one = png("one.png");
    headless_crowd::run(&[
        arg(baked.to_str().unwrap()),
        arg("--count"),
        arg("1"),
        arg("--no-ground"),
        arg("--out"),
        one.clone(),
    ])
    .unwrap();
    let single = not_sky(&image::open(&one).unwrap().to_rgba8(), sky);
    assert!(
        single < covered / 4,
        "one agent covers {single} pixels, 400 cover {covered}"
    );

    // Bad arguments and folders are errors, not panics.
    let e = headless_crowd::run(&[arg(baked.to_str().unwrap()), arg("--count"), arg("0")]).unwrap_err();
    assert!(e.contains("--count"), "{e}");
    let e = headless_crowd::run(&[png("nowhere")]).unwrap_err();
    assert!(e.contains("nowhere"), "{e}");
}

/// The crates `package` depends on (normal dependencies, the whole tree), and the tree.
fn dependency_tree(package: &str) -> (Vec<String>, String) {
    let out = Command::new(env!("CARGO"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["tree", "--offline", "-p", package, "-e", "normal", "--prefix", "none"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let tree = String::from_utf8_lossy(&out.stdout).into_owned();
    let crates = tree
        .lines()
        .filter_map(|l| l.split_whitespace().next())
        .map(str::to_owned)
        .collect();
    (crates, tree)
}

/// The baking library (a build pipeline bakes with it) pulls no user interface either.
#[test]
fn the_baking_library_depends_on_no_ui_or_command_line_crate() {
    let (crates, tree) = dependency_tree("polypostor-bake");
    assert!(crates.iter().any(|c| c == "polypostor-runtime"), "{tree}");
    for ui in [
        "eframe",
        "egui",
        "egui-wgpu",
        "egui-winit",
        "winit",
        "rfd",
        "clap",
        "indicatif",
    ] {
        assert!(
            !crates.iter().any(|c| c == ui),
            "the baking library depends on {ui}:\n{tree}"
        );
    }
}

#[test]
fn the_runtime_crate_depends_on_no_ui_or_command_line_crate() {
    let (crates, tree) = dependency_tree("polypostor-runtime");
    let crates: Vec<&str> = crates.iter().map(String::as_str).collect();
    assert!(
        crates.contains(&"wgpu") && crates.contains(&"polypostor-runtime"),
        "{tree}"
    );
    for ui in [
        "eframe",
        "egui",
        "egui-wgpu",
        "egui-winit",
        "rfd",
        "clap",
        "indicatif",
        "anyhow",
        "polypostor",
        "polypostor-bake",
    ] {
        assert!(!crates.contains(&ui), "the runtime crate depends on {ui}:\n{tree}");
    }
}
