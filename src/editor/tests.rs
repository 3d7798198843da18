//! The editor driven like a user with egui_kittest, rendering through wgpu (software adapter).

use std::path::PathBuf;

use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;

use super::{AppOptions, Command, EditorApp};

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn harness(open: Option<PathBuf>) -> Harness<'static, EditorApp> {
    Harness::builder()
        .with_size(egui::vec2(1280.0, 800.0))
        .wgpu()
        .build_eframe(move |cc| {
            EditorApp::new(
                cc,
                AppOptions {
                    settings_path: None,
                    sync_loading: true,
                },
                open,
            )
        })
}

#[test]
fn open_default_project_switch_clip_and_toggle_play() {
    let mut h = harness(Some(repo().join("projects/default")));
    h.run_steps(3);
    {
        let app = h.state();
        let doc = app.doc.as_ref().expect("the default project is open");
        assert!(app.error.is_none(), "{:?}", app.error);
        assert!(
            doc.project_file
                .as_ref()
                .unwrap()
                .ends_with("projects/default/project.json")
        );
        assert!(doc.character.clips.len() >= 2);
        assert_eq!(app.playback.clip, doc.character.find_clip("Walk"));
        assert!(app.playback.playing);
    }
    // Switch clip with the timeline's clip selector.
    h.get_by_label("Clip").click();
    h.run_steps(2);
    h.get_by_label("Run").click();
    h.run_steps(2);
    {
        let app = h.state();
        let doc = app.doc.as_ref().unwrap();
        assert_eq!(app.playback.clip, doc.character.find_clip("Run"));
        assert!(doc.dirty, "changing the clip is an unsaved change");
    }
    // Pause, then play again.
    h.get_by_label("⏸ Pause").click();
    h.run_steps(2);
    assert!(!h.state().playback.playing);
    let t = h.state().playback.time_secs;
    h.run_steps(3);
    assert_eq!(h.state().playback.time_secs, t, "time must not advance while paused");
    h.get_by_label("▶ Play").click();
    h.run_steps(2);
    assert!(h.state().playback.playing);
}

#[test]
fn viewport_draws_the_character() {
    let mut h = harness(Some(repo().join("projects/default")));
    h.run_steps(3);
    h.state_mut().send(Command::SetPlaying(false));
    h.run_steps(2);
    let image = h.render().expect("wgpu render");
    if std::env::var_os("POLYPOSTOR_TEST_IMAGES").is_some() {
        image.save(std::env::temp_dir().join("editor-viewport.png")).unwrap();
    }
    // The viewport's middle column holds the character: bright, textured pixels over the
    // dark background, which the egui panels alone never paint there.
    let (w, hgt) = (image.width(), image.height());
    let mut lit = 0;
    for y in hgt / 5..hgt * 3 / 5 {
        for x in w / 2 - 60..w / 2 + 120 {
            let p = image.get_pixel(x, y);
            if p[0] as u32 + p[1] as u32 + p[2] as u32 > 150 {
                lit += 1;
            }
        }
    }
    assert!(lit > 1500, "the viewport shows no character ({lit} bright pixels)");
}

#[test]
fn a_bad_file_shows_an_error_and_keeps_the_open_project() {
    let mut h = harness(Some(repo().join("projects/default")));
    h.run_steps(3);
    let before = h.state().doc.as_ref().unwrap().generation;
    let bad = std::env::temp_dir().join(format!("polypostor-bad-{}.glb", std::process::id()));
    std::fs::write(&bad, b"glTF\x02\0\0\0garbage").unwrap();
    h.state_mut().send(Command::NewFromGltf(bad.clone()));
    h.run_steps(3);
    let app = h.state();
    let message = app.error.clone().expect("an error dialog");
    assert!(message.contains("GLB") || message.contains("glb"), "{message}");
    assert_eq!(
        app.doc.as_ref().unwrap().generation,
        before,
        "the open project must be untouched"
    );
    h.get_by_label("OK").click();
    h.run_steps(2);
    assert!(h.state().error.is_none());
    std::fs::remove_file(bad).unwrap();
}

#[test]
fn save_as_writes_a_project_that_reopens() {
    let dir = std::env::temp_dir().join(format!("polypostor-saveas-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let mut h = harness(Some(repo().join("assets/characters/default_humanoid.glb")));
    h.run_steps(3);
    assert!(h.state().doc.as_ref().unwrap().project_file.is_none());
    let idle = h.state().doc.as_ref().unwrap().character.find_clip("Idle");
    h.state_mut().send(Command::SelectClip(idle));
    h.state_mut().send(Command::SaveAs(dir.clone()));
    h.run_steps(3);
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
    assert!(!h.state().doc.as_ref().unwrap().dirty);
    let (project, file) = polypostor::project::Project::load(&dir).unwrap();
    assert_eq!(project.view.clip.as_deref(), Some("Idle"));
    assert!(project.character_path(&file).exists(), "{:?}", project.character);
    let mut again = harness(Some(dir.clone()));
    again.run_steps(3);
    assert_eq!(again.state().playback.clip, idle);
    std::fs::remove_dir_all(dir).unwrap();
}
