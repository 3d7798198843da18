//! The `polypostor` command line: `inspect` prints the summary (text or JSON) and exits 1 with
//! the error on bad input, never 101 (a panic).

mod common;

use std::process::Command;

fn polypostor(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_polypostor"))
        .args(args)
        .output()
        .expect("run polypostor")
}

#[test]
fn inspect_json_reports_the_default_character() {
    let path = common::repo_path(polypostor::default_character::DEFAULT_CHARACTER_PATH);
    let out = polypostor(&["inspect", path.to_str().unwrap(), "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
    assert!(v["vertices"].as_u64().unwrap() > 1000);
    assert!(v["triangles"].as_u64().unwrap() >= 2000);
    assert_eq!(v["joints"].as_u64(), Some(21));
    let clips = v["clips"].as_array().unwrap();
    assert!(
        clips
            .iter()
            .any(|c| c["name"] == "Walk" && (c["duration_secs"].as_f64().unwrap() - 1.0).abs() < 1e-6)
    );
    assert!(v["warnings"].as_array().unwrap().is_empty());
}

#[test]
fn inspect_text_and_json_agree_on_every_real_character() {
    for f in common::real_characters() {
        let text = polypostor(&["inspect", f.to_str().unwrap()]);
        assert!(text.status.success());
        let json = polypostor(&["inspect", f.to_str().unwrap(), "--json"]);
        let v: serde_json::Value = serde_json::from_slice(&json.stdout).unwrap();
        let text = String::from_utf8(text.stdout).unwrap();
        assert!(text.contains(&format!("joints      {}", v["joints"])), "{text}");
        assert!(text.contains(&format!("triangles   {}", v["triangles"])), "{text}");
    }
}

#[test]
fn inspect_exits_1_with_a_message_on_every_bad_file() {
    let dir = common::temp_dir("cli-bad");
    let cases: Vec<(std::path::PathBuf, &[u8])> = vec![
        (dir.join("empty.glb"), b""),
        (dir.join("garbage.glb"), b"glTF\x02\x00\x00\x00\xff\xff\xff\xffxx"),
        (dir.join("notjson.gltf"), b"{ this is not json"),
        (dir.join("noasset.gltf"), b"{}"),
    ];
    for (path, bytes) in &cases {
        std::fs::write(path, bytes).unwrap();
    }
    let missing = dir.join("does-not-exist.glb");
    for path in cases.iter().map(|c| c.0.clone()).chain([missing, dir.to_path_buf()]) {
        for json in [false, true] {
            let mut args = vec!["inspect", path.to_str().unwrap()];
            if json {
                args.push("--json");
            }
            let out = polypostor(&args);
            assert_eq!(out.status.code(), Some(1), "{}: {:?}", path.display(), out);
            let stderr = String::from_utf8_lossy(&out.stderr);
            assert!(stderr.contains("error:") && stderr.len() > 20, "{stderr}");
            if json {
                let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("an error object");
                assert!(v["error"].as_str().is_some_and(|e| !e.is_empty()));
            }
        }
    }
    // The whole invalid corpus through the binary: exit 0 or 1, never a panic.
    if let Some(shared) = common::shared_dir() {
        let mut n = 0;
        for group in std::fs::read_dir(shared.join("assets/invalid-gltf"))
            .unwrap()
            .filter_map(|e| e.ok())
        {
            if !group.path().is_dir() {
                continue;
            }
            for f in std::fs::read_dir(group.path())
                .unwrap()
                .filter_map(|e| e.ok())
                .map(|e| e.path())
            {
                if f.extension().is_some_and(|e| e == "gltf" || e == "glb") {
                    let out = polypostor(&["inspect", f.to_str().unwrap(), "--json"]);
                    let code = out.status.code();
                    assert!(code == Some(0) || code == Some(1), "{}: exit {code:?}", f.display());
                    n += 1;
                }
            }
        }
        assert!(n > 200);
    }
    std::fs::remove_dir_all(dir).unwrap();
}

/// The comparison workflow from the command line: bake the comparison representations, then
/// `compare` and `bench crowd` print their figures as JSON and write their plots; bad
/// arguments give clear errors, never a panic.
#[test]
fn representations_compare_and_bench_crowd_work_end_to_end() {
    let dir = common::temp_dir("cli-reps");
    let out = dir.join("reps.pack");
    let project = common::repo_path(polypostor::project::DEFAULT_PROJECT_DIR);
    let bad = polypostor(&["bake", project.to_str().unwrap(), "--representation", "sprites"]);
    assert_eq!(bad.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("unknown representation 'sprites'"));
    let bake = polypostor(&[
        "bake",
        project.to_str().unwrap(),
        "--representation",
        "impostor,np3d,rigid",
        "--views",
        "4",
        "--resolution",
        "64",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(bake.status.success(), "{}", String::from_utf8_lossy(&bake.stderr));
    assert!(out.join("representations.json").is_file());
    assert!(!out.join("manifest.json").exists(), "no Polypostor pack was asked for");

    let plots = dir.join("compare");
    let cmp = polypostor(&[
        "compare",
        out.to_str().unwrap(),
        "--views",
        "2",
        "--out",
        plots.to_str().unwrap(),
        "--json",
    ]);
    assert!(cmp.status.success(), "{}", String::from_utf8_lossy(&cmp.stderr));
    let v: serde_json::Value = serde_json::from_slice(&cmp.stdout).expect("one JSON object");
    let names = |key: &str| -> Vec<String> {
        v[key]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| r["representation"].as_str().unwrap().to_string())
            .collect()
    };
    for n in ["skinned", "rigid", "impostor", "np3d"] {
        assert!(names("memory").contains(&n.to_string()), "memory of {n}");
        assert!(names("error").contains(&n.to_string()), "error of {n}");
    }
    let impostor = v["memory"]
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["representation"] == "impostor")
        .unwrap();
    // 4 views × 10 frames × 64² × (colour + normal) RGBA8.
    assert_eq!(impostor["total"].as_u64(), Some(4 * 10 * 64 * 64 * 8));
    for p in ["memory.png", "error.png", "compare.json"] {
        assert!(plots.join(p).is_file(), "{p}");
    }

    let bench_out = dir.join("bench");
    let pack = out.to_str().unwrap();
    // `bench crowd --pack <the bake>` with `args`, small and quick.
    let bench_crowd = |args: &[&str]| {
        let mut all = vec!["bench", "crowd", "--pack", pack];
        all.extend_from_slice(args);
        polypostor(&all)
    };
    let small = [
        "--frames",
        "1",
        "--width",
        "320",
        "--height",
        "180",
        "--out",
        bench_out.to_str().unwrap(),
    ];
    let bench = bench_crowd(&[&["--counts", "40,80", "--json"][..], &small].concat());
    assert!(bench.status.success(), "{}", String::from_utf8_lossy(&bench.stderr));
    let rows: serde_json::Value = serde_json::from_slice(&bench.stdout).expect("a JSON list");
    let rows = rows.as_array().unwrap();
    for rep in ["skinned", "rigid", "impostor", "np3d", "mixed"] {
        for count in [40, 80] {
            let row = rows
                .iter()
                .find(|r| r["representation"] == rep && r["count"] == count)
                .unwrap_or_else(|| panic!("{rep} at {count}"));
            assert!(row["fps"].as_f64().unwrap() > 0.0);
        }
    }
    assert!(bench_out.join("crowd_fps.png").is_file());
    // Two characters in one crowd (the same folder twice), a quarter and three quarters.
    let mixed = bench_crowd(
        &[
            &[
                "--with",
                pack,
                "--shares",
                "1,3",
                "--counts",
                "40",
                "--representations",
                "impostor,mixed",
            ][..],
            &small,
        ]
        .concat(),
    );
    let err = String::from_utf8_lossy(&mixed.stderr);
    assert!(mixed.status.success(), "{err}");
    assert!(
        err.contains("share 1.00: 10 agents") && err.contains("share 3.00: 30 agents"),
        "{err}"
    );
    for (shares, why) in [
        ("1", "give 2 numbers"),
        ("1,-1", "give 2 numbers"),
        ("0,0", "not all 0"),
    ] {
        let bad = bench_crowd(&["--with", pack, "--shares", shares]);
        assert_eq!(bad.status.code(), Some(1), "--shares {shares}");
        assert!(String::from_utf8_lossy(&bad.stderr).contains(why), "--shares {shares}");
    }
    let bad = bench_crowd(&["--with", dir.join("nothing-here").to_str().unwrap()]);
    assert_eq!(bad.status.code(), Some(1));
    assert!(
        String::from_utf8_lossy(&bad.stderr).contains("--with"),
        "names the argument"
    );
    let bad = polypostor(&[
        "bench",
        "crowd",
        "--pack",
        out.to_str().unwrap(),
        "--representations",
        "polypostor",
    ]);
    assert_eq!(bad.status.code(), Some(1), "no pack was baked, so no polypostor");
    assert!(String::from_utf8_lossy(&bad.stderr).contains("'polypostor' is not one of"));
}

/// On the OpenGL backend (the software fallback where Vulkan is not installed) a bake runs
/// (depth is read back through a shader there) and gives the same pack as the default
/// backend.
#[test]
fn a_bake_on_opengl_matches_the_default_backend() {
    let project = common::repo_path(polypostor::project::DEFAULT_PROJECT_DIR);
    let dir = common::temp_dir("cli-gl");
    let bake = |backend: Option<&str>, name: &str| {
        let out = dir.join(name);
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_polypostor"));
        cmd.args([
            "bake",
            project.to_str().unwrap(),
            "--views",
            "3",
            "--resolution",
            "64",
            "--out",
        ])
        .arg(&out);
        if let Some(b) = backend {
            cmd.env("WGPU_BACKEND", b);
        }
        (cmd.output().expect("run polypostor"), out)
    };
    let (gl, gl_out) = bake(Some("gl"), "gl.pack");
    let stderr = String::from_utf8_lossy(&gl.stderr);
    if !gl.status.success() && stderr.contains("no GPU adapter") {
        eprintln!("skipped: no OpenGL adapter here ({stderr})");
        return;
    }
    assert!(gl.status.success(), "{stderr}");
    let said = format!("{}{stderr}", String::from_utf8_lossy(&gl.stdout));
    assert!(said.contains("(Gl,"), "the bake did not run on OpenGL: {said}");
    let (default, default_out) = bake(None, "default.pack");
    assert!(default.status.success(), "{}", String::from_utf8_lossy(&default.stderr));
    let report = |p: &std::path::Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(p.join("report.json")).unwrap()).unwrap()
    };
    let (a, b) = (report(&gl_out), report(&default_out));
    let psnr = |r: &serde_json::Value| r["mean_psnr"].as_f64().expect("mean_psnr");
    assert!(
        (psnr(&a) - psnr(&b)).abs() < 0.05,
        "OpenGL {} dB vs default {} dB",
        psnr(&a),
        psnr(&b)
    );
    assert_eq!(a["views"].as_array().map(Vec::len), Some(3));
    std::fs::remove_dir_all(dir).unwrap();
}

/// `bench sim --mixed`: two characters with clip tables (people walking, running and
/// standing; a long four-legged character with its own clips and views) run and are selected.
#[test]
fn bench_sim_runs_a_crowd_of_two_characters() {
    let out = polypostor(&["bench", "sim", "--agents", "500", "--frames", "5", "--mixed", "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
    assert_eq!(v["agents"], 500);
    let visible = v["visible"].as_u64().unwrap();
    let drawn: u64 = v["per_level"]
        .as_object()
        .unwrap()
        .values()
        .map(|x| x.as_u64().unwrap())
        .sum();
    assert!(visible > 0 && drawn >= visible, "{v}");
    assert!(v["cpu_ms"]["mean"].as_f64().unwrap() > 0.0);
}

/// A 2-view, 32² bake of `glb` into `out` with one key image per part (and `more` flags);
/// it must succeed.
fn small_bake(glb: &std::path::Path, out: &std::path::Path, more: &[&str]) {
    let (glb, out) = (glb.to_str().unwrap(), out.to_str().unwrap());
    let mut args = vec![
        "bake",
        glb,
        "--views",
        "2",
        "--resolution",
        "32",
        "--max-keys",
        "1",
        "--out",
        out,
    ];
    args.extend_from_slice(more);
    let bake = polypostor(&args);
    assert!(bake.status.success(), "{}", String::from_utf8_lossy(&bake.stderr));
}

/// A Polypostor pack baked from a glTF file names that file, so `bench crowd` (and `--with`,
/// which has no flag for a character) and `compare` find the character without being told.
#[test]
fn a_pack_names_the_file_it_was_baked_from() {
    let dir = common::temp_dir("cli-character-path");
    let glb = common::repo_path(polypostor::default_character::DEFAULT_CHARACTER_PATH);
    let out = dir.join("p.pack");
    small_bake(&glb, &out, &[]);
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("manifest.json")).unwrap()).unwrap();
    let named = std::path::PathBuf::from(manifest["character_path"].as_str().expect("character_path"));
    assert_eq!(
        std::fs::canonicalize(&named).unwrap(),
        std::fs::canonicalize(&glb).unwrap()
    );
    let pack = out.to_str().unwrap();
    let crowd = polypostor(&[
        "bench",
        "crowd",
        "--pack",
        pack,
        "--with",
        pack,
        "--counts",
        "20",
        "--frames",
        "1",
        "--width",
        "160",
        "--height",
        "90",
        "--representations",
        "polypostor",
        "--out",
        dir.join("bench").to_str().unwrap(),
    ]);
    assert!(crowd.status.success(), "{}", String::from_utf8_lossy(&crowd.stderr));
    std::fs::remove_dir_all(dir).unwrap();
}

/// `bench sim` refuses crowds and runs it would not finish (a hundred million agents took
/// 12.8 GB and ran on; a billion frames never ends) and zero frames, naming the flag.
#[test]
fn bench_sim_refuses_absurd_sizes_before_any_work() {
    for (args, flag) in [
        (["--agents", "100000000", "--frames", "5"], "--agents"),
        (["--agents", "0", "--frames", "5"], "--agents"),
        (["--agents", "100", "--frames", "1000000000"], "--frames"),
        (["--agents", "100", "--frames", "0"], "--frames"),
    ] {
        let t = std::time::Instant::now();
        let out = polypostor(&["bench", "sim", args[0], args[1], args[2], args[3]]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(flag), "{args:?}: {err}");
        assert!(t.elapsed().as_secs() < 30, "{args:?} took {:?}", t.elapsed());
    }
}

#[test]
fn bake_settings_come_from_the_project_and_flags_override_single_fields() {
    let dir = common::temp_dir("cli-settings");
    let glb = common::repo_path(polypostor::default_character::DEFAULT_CHARACTER_PATH);
    let project = serde_json::json!({
        "format_version": 1,
        "name": "settings",
        "character": { "path": glb.to_str().unwrap() },
        "view": { "clip": "Walk", "playback_speed": 1.0 },
        "bake": { "views": 3, "resolution": 32, "fps": 5.0, "max_keys": 1, "textures": "Png" }
    });
    let proj = dir.join("proj");
    std::fs::create_dir_all(&proj).unwrap();
    std::fs::write(
        proj.join("project.json"),
        serde_json::to_string_pretty(&project).unwrap(),
    )
    .unwrap();
    let settings = |out: &std::path::Path| -> serde_json::Value {
        let r: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
        r["settings"].clone()
    };
    // The project's settings, every one.
    let a = dir.join("a.pack");
    let o = polypostor(&["bake", proj.to_str().unwrap(), "--out", a.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let s = settings(&a);
    assert_eq!((s["views"].as_u64(), s["resolution"].as_u64()), (Some(3), Some(32)));
    assert_eq!(s["keys"]["max_keys"].as_u64(), Some(1));
    assert_eq!(s["textures"], "Png");
    assert!(a.join("atlas_000.png").is_file());
    // A flag overrides its field only.
    let b = dir.join("b.pack");
    let o = polypostor(&[
        "bake",
        proj.to_str().unwrap(),
        "--views",
        "2",
        "--textures",
        "bc7",
        "--out",
        b.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let s = settings(&b);
    assert_eq!((s["views"].as_u64(), s["resolution"].as_u64()), (Some(2), Some(32)));
    assert_eq!(s["textures"], "Bc7");
    assert!(b.join("atlas_000.ktx2").is_file());
    // A project setting out of range is named as the project's field, with the file and
    // the flag that would override it, before any work.
    let mut bad = project.clone();
    bad["bake"]["views"] = 0.into();
    std::fs::write(proj.join("project.json"), serde_json::to_string_pretty(&bad).unwrap()).unwrap();
    let c = dir.join("c.pack");
    let o = polypostor(&["bake", proj.to_str().unwrap(), "--out", c.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("project.json") && e.contains("bake setting views 0") && e.contains("--views"),
        "{e}"
    );
    assert!(!c.exists());
}

/// A character exported lying down (here the default laid with its up along -z, as a Z-up
/// tool's export comes) is baked standing with `--up -z`: the pack and the representations
/// record the axis, and the crowd, which reads the character file again, reads it the same
/// way (independent answer: the original's height, from its own first pose).
#[test]
fn a_file_read_with_another_up_axis_is_baked_and_crowded_standing() {
    use polypostor::animation::{Pose, skin_vertices};
    let dir = common::temp_dir("cli-up-axis");
    let original = polypostor::default_character::generate();
    let height = |c: &polypostor::Character| {
        let pose = Pose::sample_index(c, Some(0), 0.0);
        let (lo, hi) = polypostor::character::bounds(skin_vertices(c, &pose).0);
        hi - lo
    };
    let mut lying = original.clone();
    lying.move_rigidly(
        glam::Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2),
        glam::Vec3::ZERO,
    );
    assert!(height(&lying).y < 0.5 * height(&original).y, "the copy lies");
    let glb = dir.join("lying.glb");
    std::fs::write(&glb, polypostor::gltf_write::write_glb(&lying).unwrap()).unwrap();
    let inspect = polypostor(&["inspect", glb.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&inspect.stdout);
    assert!(text.contains("--up z"), "the import hints at the axis: {text}");
    let stood = polypostor(&["inspect", glb.to_str().unwrap(), "--up", "-z", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&stood.stdout).unwrap();
    assert_eq!(v["up_axis"], "-z");
    let tall = v["bounds_max"][1].as_f64().unwrap() - v["bounds_min"][1].as_f64().unwrap();
    assert!((1.5..2.2).contains(&tall), "stands {tall} tall");
    let bad = polypostor(&["inspect", glb.to_str().unwrap(), "--up", "sideways"]);
    assert_eq!(bad.status.code(), Some(2), "clap refuses it");
    assert!(String::from_utf8_lossy(&bad.stderr).contains("'sideways' is not an axis"));
    let out = dir.join("p.pack");
    small_bake(&glb, &out, &["--up", "-z", "--representation", "all"]);
    for file in ["manifest.json", polypostor::reps::REPS_FILE] {
        let m: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(out.join(file)).unwrap()).unwrap();
        assert_eq!(m["character_up"], "-z", "{file}");
    }
    let assets = polypostor::scene::CrowdAssets::load(&out, None, None).unwrap();
    assert_eq!(assets.character.up_axis, polypostor::UpAxis::NegZ);
    let (stood, was) = (height(&assets.character), height(&original));
    assert!(
        (stood - was).abs().max_element() < 1e-3 * was.y,
        "{stood} against {was}"
    );
    std::fs::remove_dir_all(dir).unwrap();
}

/// A character that never moves (here the default with its clips taken away: its rest pose,
/// one frame) is drawn by its Polypostor nearly as well as by impostors: each part's polygon
/// holds every covered texel and the alpha test draws the outline (a polygon simplified from
/// the traced outline left a pixel of staircase in or out along every edge: this test read
/// 27.6 dB against the impostors' 36.9, now 35.5; a one-part prop Bevy ships went from 25.7
/// to 59.7 dB, the impostors' 53.5).
#[test]
fn a_still_prop_is_drawn_nearly_as_well_as_by_impostors() {
    let dir = common::temp_dir("cli-still-prop");
    let mut c = polypostor::default_character::generate();
    c.clips.clear();
    let glb = dir.join("still.glb");
    std::fs::write(&glb, polypostor::gltf_write::write_glb(&c).unwrap()).unwrap();
    let out = dir.join("still.pack");
    let bake = polypostor(&[
        "bake",
        glb.to_str().unwrap(),
        "--representation",
        "polypostor,impostor",
        "--views",
        "4",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(bake.status.success(), "{}", String::from_utf8_lossy(&bake.stderr));
    let cmp = polypostor(&["compare", out.to_str().unwrap(), "--views", "4", "--json"]);
    assert!(cmp.status.success(), "{}", String::from_utf8_lossy(&cmp.stderr));
    let v: serde_json::Value = serde_json::from_slice(&cmp.stdout).expect("one JSON object");
    let psnr = |name: &str| {
        v["error"]
            .as_array()
            .unwrap()
            .iter()
            .find(|r| r["representation"] == name)
            .and_then(|r| r["mean_psnr"].as_f64())
            .unwrap_or_else(|| panic!("no error row for {name}"))
    };
    let (poly, imp) = (psnr("polypostor"), psnr("impostor"));
    eprintln!("Polypostor {poly:.2} dB, impostors {imp:.2} dB");
    assert!(poly >= imp - 4.0, "Polypostor {poly:.1} dB, impostors {imp:.1} dB");
    // The silhouette agreement of each row, and the real mesh's brightness: the skinned mesh
    // is the real one (agreement 1), the others cover nearly what it covers, the default
    // character is not dark.
    for r in v["error"].as_array().unwrap() {
        let iou = r["mean_silhouette_iou"].as_f64().expect("silhouette agreement");
        let name = r["representation"].as_str().unwrap();
        if name == "skinned" {
            assert!(iou > 0.999, "skinned: {iou}");
        }
        assert!((0.8..=1.0).contains(&iou), "{name}: silhouette agreement {iou}");
        let bright = r["truth_brightness"].as_f64().expect("brightness");
        assert!(bright > 0.1 && bright <= 1.0, "{name}: brightness {bright}");
    }
}
