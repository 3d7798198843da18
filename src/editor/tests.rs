//! The editor driven like a user with egui_kittest, rendering through wgpu (software adapter).

use std::path::{Path, PathBuf};

use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;

use super::{AppOptions, Command, EditorApp};

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Opens the default character's file as a new document (the open one marked saved, so no
/// question is asked) and steps the editor until it is in.
fn open_default_file(h: &mut Harness<'static, EditorApp>) {
    h.state_mut().doc.as_mut().unwrap().dirty = false;
    let generation = h.state().doc.as_ref().unwrap().generation;
    h.state_mut()
        .send(Command::Open(repo().join("assets/characters/default_humanoid.glb")));
    let started = std::time::Instant::now();
    while h.state().doc.as_ref().unwrap().generation == generation {
        assert!(started.elapsed().as_secs() < 60, "the character did not open");
        std::thread::sleep(std::time::Duration::from_millis(50));
        h.run_steps(1);
    }
}

/// Adds the pack at `folder` to the crowd and steps the editor until it is in.
fn add_guest(h: &mut Harness<'static, EditorApp>, folder: &Path) {
    h.state_mut().send(Command::AddToCrowd(folder.to_owned()));
    let started = std::time::Instant::now();
    while h.state().crowd.guests.is_empty() {
        assert!(started.elapsed().as_secs() < 60, "the character was not added");
        std::thread::sleep(std::time::Duration::from_millis(50));
        h.run_steps(1);
    }
}

fn harness(open: Option<PathBuf>) -> Harness<'static, EditorApp> {
    harness_with(open, false)
}

/// `autosave`: autosave and recovery on (off elsewhere, so a stray autosave beside the
/// default project cannot change what a test sees).
fn harness_with(open: Option<PathBuf>, autosave: bool) -> Harness<'static, EditorApp> {
    Harness::builder()
        .with_size(egui::vec2(1280.0, 800.0))
        .wgpu()
        .build_eframe(move |cc| {
            EditorApp::new(
                cc,
                AppOptions {
                    settings_path: None,
                    sync_loading: true,
                    recovery_dir: None,
                    autosave,
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
    // Enter closes it too.
    h.state_mut().send(Command::NewFromGltf(bad.clone()));
    h.run_steps(3);
    assert!(h.state().error.is_some());
    h.key_press(egui::Key::Enter);
    h.run_steps(2);
    assert!(h.state().error.is_none(), "Enter closes the error dialog");
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
    // Save As elsewhere keeps the last pack where it is (it was read beside the new folder:
    // the Views tab opened on nothing).
    again.state_mut().doc.as_mut().unwrap().project.view.last_pack = Some("mine.pack".into());
    again.state_mut().send(Command::SaveAs(dir.join("deep/b")));
    again.run_steps(3);
    assert!(again.state().error.is_none(), "{:?}", again.state().error);
    let (moved, _) = polypostor::project::Project::load(&dir.join("deep/b")).unwrap();
    assert_eq!(moved.view.last_pack.as_deref(), Some("../../mine.pack"));
    // Save As onto a user's file (not a folder, not a project file) is refused as such and
    // leaves it as it was.
    let theirs = dir.join("user.glb");
    std::fs::write(&theirs, "mine").unwrap();
    again.state_mut().send(Command::SaveAs(theirs.clone()));
    again.run_steps(2);
    let e = again.state().error.clone().expect("refused");
    assert!(e.contains("not a project folder") && e.contains("user.glb"), "{e}");
    assert_eq!(std::fs::read_to_string(&theirs).unwrap(), "mine");
    // Nor onto another project: the first one is still there as it was (it was replaced
    // without a word, its painting and corrections lost).
    again.state_mut().error = None;
    let first = std::fs::read(dir.join("project.json")).unwrap();
    again.state_mut().send(Command::SaveAs(dir.clone()));
    again.run_steps(2);
    let e = again.state().error.clone().expect("refused");
    assert!(e.contains("already holds project"), "{e}");
    assert_eq!(std::fs::read(dir.join("project.json")).unwrap(), first);
    // Its own folder again is a plain save.
    again.state_mut().error = None;
    again.state_mut().send(Command::SaveAs(dir.join("deep/b")));
    again.run_steps(2);
    assert!(again.state().error.is_none(), "{:?}", again.state().error);
    std::fs::remove_dir_all(dir).unwrap();
}

/// The crowd preview opened on a baked folder: the panel shows the crowd, a render runs the
/// simulation and fills the statistics, and switching the representation changes what is
/// drawn.
#[test]
fn crowd_preview_opens_a_baked_folder_and_draws_the_chosen_representation() {
    use polypostor::crowd::lod::Level;
    let (dir, out) = bake_small(
        "crowd",
        "reps.pack",
        "impostor,np3d,rigid",
        polypostor::bake::pipeline::BakeOptions {
            views: 6,
            resolution: 64,
            ..Default::default()
        },
    );

    let mut h = harness(Some(repo().join("projects/default")));
    h.run_steps(3);
    h.state_mut().send(Command::OpenCrowd(out.clone()));
    let started = std::time::Instant::now();
    while h.state().crowd.assets.is_none() {
        assert!(started.elapsed().as_secs() < 60, "the folder did not open");
        std::thread::sleep(std::time::Duration::from_millis(50));
        h.run_steps(1);
    }
    assert!(h.state().crowd.open, "opening a folder shows the preview");
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
    // The side panel shows the crowd controls.
    h.get_by_label("Paused (P)");
    h.state_mut().crowd.count = 300;
    h.run_steps(2);
    h.render().expect("render");
    h.run_steps(1);
    h.render().expect("render");
    let stats = h.state().crowd.stats.lock().unwrap().clone();
    assert!(stats.error.is_none(), "{:?}", stats.error);
    assert_eq!(stats.agents, 300);
    assert!(stats.visible > 0, "some of the crowd is on screen");
    assert!(stats.available[Level::Impostor as usize] && stats.available[Level::Np3d as usize]);
    assert!(!stats.available[Level::Polypostor as usize], "no pack was baked");
    assert!(stats.gpu_bytes[Level::Impostor as usize] > 0);

    // Everyone as NP3D impostors.
    h.state_mut().crowd.mode = super::crowd::PreviewMode::Only(Level::Np3d);
    h.run_steps(1);
    h.render().expect("render");
    let stats = h.state().crowd.stats.lock().unwrap().clone();
    assert_eq!(stats.per_level[Level::Np3d as usize], stats.visible);
    assert!(stats.draw_calls >= 1);
    let one = stats.gpu_bytes[Level::Np3d as usize];

    // The same folder again is refused (one character counted twice).
    h.state_mut().send(Command::AddToCrowd(out.clone()));
    h.run_steps(2);
    assert!(h.state().crowd.guests.is_empty() && !h.state().crowd.busy());
    // A second character shares the crowd (a copy of the folder: a second character of the
    // same name), a quarter of it; then it is removed.
    let copy = out.with_extension("copy");
    let _ = std::fs::remove_dir_all(&copy);
    std::fs::create_dir_all(&copy).unwrap();
    for e in std::fs::read_dir(&out).unwrap() {
        let e = e.unwrap();
        if e.file_type().unwrap().is_file() {
            std::fs::copy(e.path(), copy.join(e.file_name())).unwrap();
        }
    }
    add_guest(&mut h, &copy);
    h.state_mut().crowd.own_share = 0.75;
    h.state_mut().crowd.guests[0].share = 0.25;
    h.run_steps(1);
    h.render().expect("render");
    let stats = h.state().crowd.stats.lock().unwrap().clone();
    assert!(stats.error.is_none(), "{:?}", stats.error);
    assert_eq!(stats.per_kind, vec![225, 75]);
    assert_eq!(
        stats.gpu_bytes[Level::Np3d as usize],
        2 * one,
        "each character on the GPU"
    );
    h.get_by_label("Add character…");
    // Two rows of one name are told apart by their folders.
    let name = h.state().crowd.guests[0].assets.character.name.clone();
    h.get_by_label(&format!("{name} (reps.copy)"));
    h.state_mut().send(Command::RemoveFromCrowd(0));
    h.run_steps(1);
    h.render().expect("render");
    let stats = h.state().crowd.stats.lock().unwrap().clone();
    assert!(h.state().crowd.guests.is_empty());
    assert_eq!(stats.per_kind, vec![300]);
    // Added characters belong to the crowd of the project they were added beside: another
    // project opened, they are gone.
    add_guest(&mut h, &copy);
    open_default_file(&mut h);
    assert!(h.state().crowd.guests.is_empty());
    // So is the crowd itself: the preview showed the project left's pack (and its header
    // named it) after another project was opened.
    assert!(h.state().crowd.assets.is_none() && h.state().crowd.folder.is_none());
    assert!(h.state().crowd.last_bake.is_none());
    let _ = std::fs::remove_dir_all(&dir);
}

/// Bakes the default character (Walk) with `set` into a fresh `dir/name`, small.
fn bake_small(
    tag: &str,
    name: &str,
    set: &str,
    options: polypostor::bake::pipeline::BakeOptions,
) -> (PathBuf, PathBuf) {
    let dir = std::env::temp_dir().join(format!("polypostor-editor-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let out = dir.join(name);
    // The character as the editor opens it (imported from its file), so the bake and the
    // editor's re-fits see the same vertices to the last bit.
    let character_path = repo().join(polypostor::default_character::DEFAULT_CHARACTER_PATH);
    let c = polypostor::import_path(&character_path).unwrap();
    let seg = polypostor::bake::segment::auto_segment(&c);
    let ctx = polypostor::gpu::GpuContext::new(&polypostor::gpu::AdapterPreference::SoftwareFirst).unwrap();
    let job = polypostor::job::BakeJob {
        character: &c,
        character_path: &character_path,
        segmentation: &seg,
        caps: &Default::default(),
        options: &options,
        set: polypostor::reps::RepSet::parse(set).unwrap(),
        out: &out,
        previous: None,
        reuse_representations: false,
    };
    polypostor::job::run(&ctx, &job, &|_| {}, &Default::default(), &|_, _| Ok(())).unwrap();
    (dir, out)
}

/// Undoing every edit back to the state last saved leaves no unsaved changes; redoing one
/// brings them back.
#[test]
fn undoing_back_to_the_saved_state_is_clean() {
    let dir = temp_project("undo-clean");
    let mut h = harness(Some(dir.clone()));
    h.run_steps(3);
    assert!(!h.state().doc.as_ref().unwrap().dirty);
    h.get_by_label("Segment").click();
    h.run_steps(2);
    for _ in 0..2 {
        h.get_by_label("➕ Add part").click();
        h.run_steps(2);
    }
    assert!(h.state().doc.as_ref().unwrap().dirty);
    h.state_mut().send(Command::Undo);
    h.run_steps(2);
    assert!(h.state().doc.as_ref().unwrap().dirty, "one edit is still there");
    h.state_mut().send(Command::Undo);
    h.run_steps(2);
    assert!(!h.state().doc.as_ref().unwrap().dirty, "back to the saved project");
    h.state_mut().send(Command::Redo);
    h.run_steps(2);
    assert!(h.state().doc.as_ref().unwrap().dirty);
    std::fs::remove_dir_all(dir).unwrap();
}

/// A copy of the default project in a fresh folder (absolute character path).
fn temp_project(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("polypostor-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let character = repo().join(polypostor::default_character::DEFAULT_CHARACTER_PATH);
    let project = polypostor::project::Project::new_for_character(tag, &character, &dir);
    project.save(&dir.join("project.json")).unwrap();
    dir
}

/// Paint a stroke over the left arm with the Torso part in the Segment tab: the arm's
/// triangles under the brush (and their mirrors) become Torso, as one undo step; Ctrl+Z puts
/// every label back, Ctrl+Shift+Z paints it again.
#[test]
fn a_paint_stroke_is_one_undo_step() {
    use polypostor::edit::paint;
    let mut h = harness(Some(repo().join("projects/default")));
    h.run_steps(3);
    h.get_by_label("Segment").click();
    h.state_mut().send(Command::SetPlaying(false));
    h.state_mut().send(Command::Seek(0.0));
    h.run_steps(3);
    assert_eq!(h.state().tab, super::app::SideTab::Segment);
    let (target, before) = {
        let app = h.state();
        let doc = app.doc.as_ref().unwrap();
        let rect = app.viewport_rect;
        let seg = &doc.segmentation;
        let arm = seg.parts.iter().position(|p| p.name == "Left Arm").unwrap() as u16;
        let pose = polypostor::animation::Pose::sample_index(&doc.character, app.playback.clip, 0.0);
        let (pos, _) = polypostor::animation::skin_vertices(&doc.character, &pose);
        let m = app.camera.camera().clip_from_world(rect.width() / rect.height());
        // An arm triangle the cursor would hit first from where it projects.
        let target = (0..seg.labels.len())
            .filter(|&t| seg.labels[t] == arm)
            .find_map(|t| {
                let tri = &doc.character.indices[3 * t..3 * t + 3];
                let c = (pos[tri[0] as usize] + pos[tri[1] as usize] + pos[tri[2] as usize]) / 3.0;
                let clip = m * c.extend(1.0);
                let ndc = glam::Vec2::new(clip.x / clip.w, clip.y / clip.w);
                let ray = paint::ray_through(m, ndc);
                let (hit, _) = paint::pick(&pos, &doc.character.indices, &ray)?;
                (seg.labels[hit] == arm).then(|| {
                    egui::pos2(
                        rect.left() + (ndc.x + 1.0) * 0.5 * rect.width(),
                        rect.top() + (1.0 - ndc.y) * 0.5 * rect.height(),
                    )
                })
            })
            .expect("a visible arm triangle");
        (target, seg.clone())
    };
    assert_eq!(h.state().segment.active, 0, "Torso is the active part");
    h.hover_at(target);
    h.run_steps(1);
    h.drag_at(target);
    h.run_steps(1);
    h.hover_at(target + egui::vec2(0.0, 4.0));
    h.run_steps(1);
    h.drop_at(target + egui::vec2(0.0, 4.0));
    h.run_steps(2);
    let painted = {
        let doc = h.state().doc.as_ref().unwrap();
        let changed: Vec<usize> = (0..before.labels.len())
            .filter(|&t| doc.segmentation.labels[t] != before.labels[t])
            .collect();
        assert!(!changed.is_empty(), "the stroke painted nothing");
        assert!(changed.iter().all(|&t| doc.segmentation.labels[t] == 0));
        let right = before.parts.iter().position(|p| p.name == "Right Arm").unwrap() as u16;
        assert!(
            changed.iter().any(|&t| before.labels[t] == right),
            "the X-mirror painted the other arm too"
        );
        assert_eq!(doc.history.undo_len(), 1, "one stroke, one undo step");
        assert!(doc.dirty);
        assert!(
            doc.project.segmentation.is_some(),
            "the project holds the painted segmentation"
        );
        doc.segmentation.clone()
    };
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run_steps(2);
    assert_eq!(
        h.state().doc.as_ref().unwrap().segmentation,
        before,
        "undo restores every label"
    );
    h.key_press_modifiers(egui::Modifiers::COMMAND | egui::Modifiers::SHIFT, egui::Key::Z);
    h.run_steps(2);
    assert_eq!(
        h.state().doc.as_ref().unwrap().segmentation,
        painted,
        "redo paints it again"
    );
}

/// Crash recovery: an edit autosaved, the editor dropped without saving (as if killed), the
/// project reopened: the project file is untouched, the editor offers the autosave, Recover
/// brings the edit back, and saving writes it and removes the autosave.
#[test]
fn an_autosave_is_recovered_after_a_crash() {
    let dir = temp_project("recovery");
    let file = dir.join("project.json");
    let original = std::fs::read_to_string(&file).unwrap();
    {
        let mut h = harness_with(Some(dir.clone()), true);
        h.run_steps(3);
        h.get_by_label("Segment").click();
        h.run_steps(2);
        h.get_by_label("➕ Add part").click();
        h.run_steps(2);
        let app = h.state_mut();
        assert_eq!(app.doc.as_ref().unwrap().segmentation.parts.len(), 6);
        assert!(app.autosave_now(), "the edit is autosaved");
        assert!(!app.autosave_now(), "nothing new to autosave");
        // Dropped here without saving: the crash.
    }
    assert_eq!(
        std::fs::read_to_string(&file).unwrap(),
        original,
        "the project file is untouched"
    );
    let autosave = polypostor::project::autosave_file(&file);
    assert!(autosave.exists());

    let mut h = harness_with(Some(dir.clone()), true);
    h.run_steps(3);
    assert!(h.state().safety.recovery.is_some(), "the autosave is offered");
    assert_eq!(h.state().doc.as_ref().unwrap().segmentation.parts.len(), 5);
    h.get_by_label("Recover").click();
    h.run_steps(2);
    {
        let doc = h.state().doc.as_ref().unwrap();
        assert_eq!(doc.segmentation.parts.len(), 6, "the added part is back");
        assert!(doc.dirty);
    }
    h.state_mut().send(Command::Save);
    h.run_steps(2);
    assert!(!autosave.exists(), "saving removes the autosave");
    let (saved, _) = polypostor::project::Project::load(&dir).unwrap();
    assert_eq!(saved.segmentation.unwrap().parts.len(), 6);
    // Reopening offers nothing.
    let mut again = harness_with(Some(dir.clone()), true);
    again.run_steps(3);
    assert!(again.state().safety.recovery.is_none());
    let _ = std::fs::remove_dir_all(dir);
}

/// An autosave goes with its document, not before: "Don't save" before opening a project
/// that then fails to load keeps the document and its autosave; a recovery undone back to
/// the saved project leaves an autosave with nothing the project lacks, removed when another
/// project opens (it was offered again on the next open).
#[test]
fn autosaves_go_when_their_document_does() {
    let dir = temp_project("autosave-replace");
    let other = temp_project("autosave-other");
    let autosave = polypostor::project::autosave_file(&dir.join("project.json"));
    let broken = dir.join("broken");
    std::fs::create_dir_all(&broken).unwrap();
    std::fs::write(broken.join("project.json"), "{ not json").unwrap();
    let mut h = harness_with(Some(dir.clone()), true);
    h.run_steps(3);
    h.get_by_label("Segment").click();
    h.run_steps(2);
    h.get_by_label("➕ Add part").click();
    h.run_steps(2);
    assert!(h.state_mut().autosave_now());
    assert!(autosave.exists());
    h.state_mut().send(Command::Open(broken.clone()));
    h.run_steps(2);
    h.get_by_label("Don't save").click();
    h.run_steps(4);
    assert!(h.state().error.is_some(), "the broken project is refused");
    assert!(h.state().doc.as_ref().unwrap().dirty, "the work stays open");
    assert!(autosave.exists(), "and so does its autosave");
    drop(h);
    // Reopened, the recovery asked about but not answered, another project opened: the
    // autosave is the lost work, and stays.
    let mut h = harness_with(Some(dir.clone()), true);
    h.run_steps(3);
    assert!(h.state().safety.recovery.is_some());
    h.state_mut().send(Command::Open(other.clone()));
    h.run_steps(4);
    assert!(autosave.exists(), "an unanswered recovery keeps its autosave");
    drop(h);
    // Reopened: recover, then undo the recovery (back to the saved project).
    let mut h = harness_with(Some(dir.clone()), true);
    h.run_steps(3);
    h.get_by_label("Recover").click();
    h.run_steps(2);
    assert!(h.state().doc.as_ref().unwrap().dirty);
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run_steps(2);
    assert!(!h.state().doc.as_ref().unwrap().dirty, "back to the saved project");
    h.state_mut().send(Command::Open(other.clone()));
    h.run_steps(4);
    assert!(
        h.state()
            .doc
            .as_ref()
            .unwrap()
            .project_file
            .as_ref()
            .unwrap()
            .starts_with(&other),
        "no prompt: nothing was unsaved"
    );
    assert!(!autosave.exists(), "the stale autosave went with its document");
    drop(h);
    let mut again = harness_with(Some(dir.clone()), true);
    again.run_steps(3);
    assert!(again.state().safety.recovery.is_none(), "nothing is offered again");
    drop(again);
    let _ = std::fs::remove_dir_all(dir);
    let _ = std::fs::remove_dir_all(other);
}

/// Closing with unsaved changes asks first; Cancel keeps the editor open.
#[test]
fn closing_with_unsaved_changes_asks_first() {
    let dir = temp_project("close");
    let mut h = harness(Some(dir.clone()));
    h.run_steps(3);
    h.get_by_label("Segment").click();
    h.run_steps(2);
    h.get_by_label("➕ Add part").click();
    h.run_steps(2);
    h.input_mut()
        .viewports
        .entry(egui::ViewportId::ROOT)
        .or_default()
        .events
        .push(egui::ViewportEvent::Close);
    h.run_steps(2);
    assert!(h.state().safety.close_prompt, "the close prompt shows");
    h.get_by_label("Save changes before closing?");
    h.get_by_label("Cancel").click();
    h.run_steps(2);
    assert!(!h.state().safety.close_prompt);
    assert!(h.state().doc.as_ref().unwrap().dirty, "nothing was saved or discarded");
    let _ = std::fs::remove_dir_all(dir);
}

/// The Views tab on a real (small) bake: every view is listed worst first, the dots and the
/// list agree with the report, and picking the worst view turns the camera to look from it.
#[test]
fn the_views_tab_lists_the_worst_view_first_and_turns_the_camera_to_it() {
    let (dir, out) = bake_small(
        "views",
        "walk.pack",
        "polypostor",
        polypostor::bake::pipeline::BakeOptions {
            views: 5,
            resolution: 48,
            fps: 5.0,
            ..Default::default()
        },
    );
    let report = polypostor::bake::report::read_report(&out).unwrap();
    assert_eq!(report.views.len(), 5);

    let mut h = harness(Some(repo().join("projects/default")));
    h.run_steps(3);
    // As after a bake from the editor: the Views tab reads the bake's report.
    h.state_mut().views.set_source(Some(&out));
    h.get_by_label("Views").click();
    h.run_steps(2);
    assert_eq!(h.state().tab, super::app::SideTab::Views);
    assert!(!h.state().crowd.open);
    assert!(
        h.state().views.report.is_some(),
        "{:?} {:?}",
        h.state().views.error,
        h.state().views.source
    );
    let worst = (0..report.views.len())
        .min_by(|&a, &b| report.views[a].mean_psnr.total_cmp(&report.views[b].mean_psnr))
        .unwrap();
    let label = format!(
        "view {worst:>3}   {:.2} dB   SSIM {:.3}",
        report.views[worst].mean_psnr, report.views[worst].mean_ssim
    );
    h.get_by_label(&label).click();
    h.run_steps(2);
    let app = h.state();
    assert_eq!(app.views.selected, Some(worst));
    let eye = (app.camera.camera().eye - app.camera.target).normalize();
    let want = glam::Vec3::from(report.views[worst].direction).normalize();
    assert!(
        eye.distance(want) < 1e-3,
        "the camera looks from {eye:?}, the view from {want:?}"
    );
    // The per-frame plot of that view is shown.
    h.get_by_label(&format!("View {worst}: PSNR per frame (dB)"));

    // The fit inspector re-fitted the view the way the bake did (same polygons).
    h.run_steps(2);
    let (basis, frames, part, fit0) = {
        let s = h
            .state()
            .views
            .inspector
            .session
            .as_ref()
            .expect("the inspector opened the view");
        assert_eq!(s.view, worst);
        // The same error the bake wrote, frame by frame (one refit path).
        let baked = &report.views[worst];
        assert_eq!(s.error.psnr.len(), baked.psnr.len());
        for (a, b) in s
            .error
            .psnr
            .iter()
            .zip(&baked.psnr)
            .chain(s.error.ssim.iter().zip(&baked.ssim))
        {
            assert!((a - b).abs() < 1e-9, "inspector {a} vs bake {b}");
        }
        for (p, r) in s.parts.iter().enumerate() {
            let baked = &report.views[worst].parts[p];
            assert_eq!(
                r.fit.as_ref().map_or(0, |f| f.vertex_count()),
                baked.vertices,
                "part {p}"
            );
        }
        let part = (0..s.parts.len()).find(|&p| s.parts[p].fit.is_some()).unwrap();
        (s.basis, s.frames(), part, s.parts[part].fit.clone().unwrap())
    };
    h.get_by_label(&format!("Fit inspector: view {worst}"));
    // Pin the first kept vertex at the last frame half-way round the contour: the part is
    // re-solved under the pin at once.
    let f = frames - 1;
    let m = fit0.targets[f].len();
    let source = fit0.kept[0];
    let target = (fit0.mappings[f][source] + m / 2) % m;
    h.state_mut()
        .doc
        .as_mut()
        .unwrap()
        .edit_overrides("Pin correspondence", |o| {
            o.view_mut(basis, worst)
                .pins
                .entry(part)
                .or_default()
                .push(polypostor::bake::overrides::Pin {
                    frame: f,
                    source,
                    target,
                });
            true
        });
    h.run_steps(3);
    {
        let app = h.state();
        let s = app.views.inspector.session.as_ref().unwrap();
        let fit = s.parts[part].fit.as_ref().unwrap();
        assert_eq!(fit.mappings[f][source], target, "the pin holds");
        assert_ne!(fit.mappings[f], fit0.mappings[f], "the fit changed");
        assert!(app.views.inspector.last_refit_ms.is_some());
        h.get_by_label(&format!("frame {f}: vertex {source} -> contour {target}"));
    }
    // Reorder: the back part moves one step forward.
    let before = h.state().views.inspector.session.as_ref().unwrap().order.clone();
    // A tall window, so the order list is on screen without scrolling.
    h.set_size(egui::vec2(1280.0, 1800.0));
    h.run_steps(2);
    h.get_all_by_label("Down").next().unwrap().click();
    h.run_steps(3);
    let after = h.state().views.inspector.session.as_ref().unwrap().order.clone();
    let mut want = before.clone();
    want.swap(0, 1);
    assert_eq!(after, want);
    {
        let doc = h.state().doc.as_ref().unwrap();
        assert_eq!(
            doc.project.overrides.view(basis, worst).unwrap().order.as_ref(),
            Some(&want)
        );
    }
    // Undo the reorder, then the pin: the session follows the project back.
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run_steps(3);
    assert_eq!(h.state().views.inspector.session.as_ref().unwrap().order, before);
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run_steps(3);
    {
        let s = h.state().views.inspector.session.as_ref().unwrap();
        assert_eq!(s.parts[part].fit.as_ref().unwrap().mappings, fit0.mappings);
        assert!(h.state().doc.as_ref().unwrap().project.overrides.is_empty());
    }
    // Key images: add one at the inspector's frame, remove it, go back to auto; each an
    // undo step, saved in the project's overrides, and the session re-fitted to match.
    let keys_now = |h: &Harness<'static, EditorApp>| {
        h.state()
            .doc
            .as_ref()
            .unwrap()
            .project
            .overrides
            .view(basis, worst)
            .and_then(|o| o.keys.clone())
    };
    let key_frames: Vec<usize> = {
        let s = h.state().views.inspector.session.as_ref().unwrap();
        s.parts.iter().flat_map(|r| r.key_frames()).collect()
    };
    let at = (0..frames)
        .find(|f| !key_frames.contains(f))
        .expect("a frame that is no key");
    h.state_mut().views.inspector.time = at as f32;
    h.run_steps(2);
    h.get_by_label(&format!("Add key at frame {at}")).click();
    h.run_steps(4);
    let auto_extras: Vec<usize> = {
        let mut l: Vec<usize> = key_frames.iter().copied().filter(|&k| k != key_frames[0]).collect();
        l.sort_unstable();
        l.dedup();
        l
    };
    let mut with = auto_extras.clone();
    with.push(at);
    with.sort_unstable();
    assert_eq!(keys_now(&h), Some(with.clone()));
    {
        // The re-fitted session has exactly the artist's frames as its keys (each part those
        // that draw a frame better).
        let s = h.state().views.inspector.session.as_ref().unwrap();
        for r in &s.parts {
            for e in &r.extra {
                assert!(with.contains(&e.frame), "key {} not asked for", e.frame);
            }
        }
    }
    // Remove it again with its row's button (rows: the first key, the others in frame order,
    // then the unused ones; every row but the first has a Remove).
    let index = {
        let s = h.state().views.inspector.session.as_ref().unwrap();
        let listed: Vec<usize> = polypostor::bake::report::view_keys_of_parts(&s.parts)
            .iter()
            .filter(|k| !k.first)
            .map(|k| k.frame)
            .collect();
        listed.iter().position(|&k| k == at).unwrap_or_else(|| {
            listed.len()
                + with
                    .iter()
                    .filter(|k| !listed.contains(k))
                    .position(|&k| k == at)
                    .unwrap()
        })
    };
    h.get_all_by_label("Remove").nth(index).unwrap().click();
    h.run_steps(3);
    assert_eq!(keys_now(&h), Some(auto_extras.clone()), "removed");
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run_steps(3);
    assert_eq!(keys_now(&h), Some(with.clone()), "undo puts it back");
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run_steps(3);
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run_steps(3);
    assert_eq!(keys_now(&h), None, "undo takes the added key back");
    h.key_press_modifiers(egui::Modifiers::COMMAND | egui::Modifiers::SHIFT, egui::Key::Z);
    h.run_steps(3);
    assert_eq!(keys_now(&h), Some(with.clone()), "redo adds it again");
    h.get_by_label("Reset to auto").click();
    h.run_steps(3);
    assert_eq!(keys_now(&h), None);
    assert!(h.state().doc.as_ref().unwrap().project.overrides.is_empty());
    // The quality sheet of the chosen view: the real mesh beside the Polypostor (the only
    // representation this folder holds), at the inspector's frame and half-way after it.
    let frame = h.state().views.inspector.time.round() as u32;
    h.get_by_label(&format!("Quality sheet of view {worst} at frame {frame}"))
        .click();
    h.run_steps(3);
    {
        let sheet = &h.state().views.sheet;
        assert!(sheet.error.is_none(), "{:?}", sheet.error);
        let (view, at, img, _) = sheet.shown.as_ref().expect("the sheet was made");
        assert_eq!((*view, *at), (worst, frame));
        // Two tiles a row (real mesh, polypostor), two rows: wider than two tiles, taller
        // than two rows, and not mostly paper.
        assert!(
            img.width() >= 2 * 160 && img.height() >= 2 * 160,
            "{:?}",
            img.dimensions()
        );
        let ink = img.pixels().filter(|p| p[0] < 200).count();
        assert!(
            ink > (img.width() * img.height() / 4) as usize,
            "{ink} non-paper pixels"
        );
    }
    h.get_by_label(&format!("Quality sheet: view {worst}, frame {frame}"));
    // Another view: the inspector's images are that view's, never the previous one's
    // cached under the same name.
    let key_before = h.state().views.inspector.texture_version("key");
    let composite_before = h.state().views.inspector.texture_version("composite");
    assert!(key_before.is_some() && composite_before.is_some());
    let other = (worst + 1) % report.views.len();
    let label = format!(
        "view {other:>3}   {:.2} dB   SSIM {:.3}",
        report.views[other].mean_psnr, report.views[other].mean_ssim
    );
    h.get_by_label(&label).click();
    h.run_steps(4);
    assert_eq!(h.state().views.inspector.session.as_ref().map(|s| s.view), Some(other));
    assert_ne!(h.state().views.inspector.texture_version("key"), key_before);
    assert_ne!(h.state().views.inspector.texture_version("composite"), composite_before);
    // Another document opened: the inspector holds nothing of this one (it showed this fit
    // for the next document's view of the same number).
    open_default_file(&mut h);
    h.run_steps(2);
    assert!(h.state().views.inspector.session.is_none());
    assert!(h.state().views.selected.is_none());
    let _ = std::fs::remove_dir_all(&dir);
}

/// The export dialog: Ctrl+E opens it with a memory estimate; Export bakes the chosen
/// representations in the background into the folder and opens the crowd preview on it; the
/// estimate was close to what was written.
#[test]
fn export_writes_the_chosen_representations_and_opens_the_preview() {
    let dir = temp_project("export");
    let out = dir.join("export.pack");
    let mut h = harness(Some(dir.clone()));
    h.run_steps(3);
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::E);
    h.run_steps(2);
    assert!(h.state().export.open, "Ctrl+E opens the export dialog");
    h.get_by_label("Estimated memory (10 frames, textures as BC7 blocks)");
    {
        let e = &mut h.state_mut().export;
        e.folder = out.display().to_string();
        e.views = 4;
        e.resolution = 64;
        e.fps = 5.0;
        e.polygon_vertices = 24;
        e.set = polypostor::reps::RepSet::parse("polypostor,impostor").unwrap();
        // Two clips ticked (the project's set was the Walk alone).
        e.clips = vec![false; e.clips.len()];
        e.clips[0] = true;
        e.clips[1] = true;
    }
    let names: Vec<String> = h.state().doc.as_ref().unwrap().character.clips[..2]
        .iter()
        .map(|c| c.name.clone())
        .collect();
    h.run_steps(2);
    h.get_by_label("Polygon vertices");
    h.get_by_label("Export").click();
    h.run_steps(2);
    assert!(!h.state().export.open);
    let started = std::time::Instant::now();
    while h.state().crowd.assets.is_none() {
        assert!(h.state().error.is_none(), "{:?}", h.state().error);
        assert!(started.elapsed().as_secs() < 300, "the export did not finish");
        std::thread::sleep(std::time::Duration::from_millis(100));
        h.run_steps(1);
    }
    assert!(h.state().crowd.open, "the crowd preview opens on the export");
    assert_eq!(h.state().crowd.folder.as_deref(), Some(out.as_path()));
    let report = polypostor::bake::report::read_report(&out).unwrap();
    assert_eq!(report.views.len(), 4);
    // The clips ticked are the ones baked (it baked the project's old set, then made the
    // ticked one the project's), and the project's from now on.
    let baked: Vec<String> = report.clips.iter().map(|c| c.name.clone()).collect();
    assert_eq!(baked, names);
    // The inspector's frame lists name the clip a frame of such a pack is in.
    let second = &report.clips[1];
    assert_eq!(
        super::inspect::frame_label(&report, second.first_frame + 1),
        format!("{} ({} 1)", second.first_frame + 1, second.name)
    );
    assert_eq!(h.state().doc.as_ref().unwrap().project.clips, names);
    assert_eq!(report.settings.resolution, 64);
    // The polygon size chosen in the dialog is the bake's and, from now on, the project's.
    assert_eq!(report.settings.final_vertices, 24);
    assert_eq!(h.state().doc.as_ref().unwrap().project.bake.polygon_vertices, 24);
    // So are the representations ticked, and the dialog opens with the project's.
    assert_eq!(
        h.state().doc.as_ref().unwrap().project.bake.representations,
        "polypostor,impostor"
    );
    h.state_mut().doc.as_mut().unwrap().project.bake.representations = "polypostor,np3d".into();
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::E);
    h.run_steps(2);
    assert!(h.state().export.open);
    assert_eq!(
        h.state().export.set,
        polypostor::reps::RepSet::parse("polypostor,np3d").unwrap()
    );
    let reps = polypostor::reps::load_representations(&out).unwrap();
    assert!(reps.impostor.is_some() && reps.np3d.is_none() && reps.rigid.is_none());
    // The estimate shown before writing, against what was written.
    let c = &h.state().doc.as_ref().unwrap().character;
    let e = polypostor::reps::compare::estimate(4, 64, report.settings.frames, 5, c.vertices.len(), 0)
        .with_polygon_vertices(
            24 + polypostor::reps::compare::kept_interior(report.settings.interior_vertices),
            4,
            report.settings.frames,
            5,
        );
    assert_eq!(e.impostor, report.impostor_bytes, "impostor memory is exact");
    let ratio = e.polypostor as f64 / report.pack_bytes as f64;
    assert!(
        (0.6..1.6).contains(&ratio),
        "polypostor estimate {} vs {}",
        e.polypostor,
        report.pack_bytes
    );
    // An export cancelled before it ends changes nothing: not the project's settings (a
    // cancelled 137-view export had set them), not the Views tab's folder.
    let bake_before = h.state().doc.as_ref().unwrap().project.bake.clone();
    let source_before = h.state().views.source.clone();
    {
        let e = &mut h.state_mut().export;
        e.folder = dir.join("cancelled.pack").display().to_string();
        e.views = 40;
    }
    h.run_steps(2);
    h.get_by_label("Export").click();
    h.run_steps(2);
    assert!(h.state().crowd.busy(), "the export runs");
    h.state().crowd.cancel_job();
    let started = std::time::Instant::now();
    while h.state().crowd.busy() {
        assert!(started.elapsed().as_secs() < 300, "the cancel did not end the export");
        std::thread::sleep(std::time::Duration::from_millis(100));
        h.run_steps(1);
    }
    h.run_steps(2);
    assert!(!dir.join("cancelled.pack").exists());
    assert_eq!(h.state().doc.as_ref().unwrap().project.bake, bake_before);
    assert_eq!(h.state().views.source, source_before);
    // The project remembers the pack exported (not the cancelled one): saved and opened
    // again, its Views tab shows that pack, not the Ctrl+B folder (crowd.pack).
    assert_eq!(
        h.state().doc.as_ref().unwrap().project.view.last_pack.as_deref(),
        Some("export.pack")
    );
    h.state_mut().send(Command::Save);
    h.run_steps(2);
    assert!(!h.state().doc.as_ref().unwrap().dirty);
    drop(h);
    let mut h = harness(Some(dir.clone()));
    h.run_steps(3);
    assert_eq!(h.state().views.source.as_deref(), Some(out.as_path()));
    drop(h);
    // A recorded pack that is gone: the Ctrl+B folder.
    std::fs::remove_dir_all(&out).unwrap();
    let mut h = harness(Some(dir.clone()));
    h.run_steps(3);
    assert_eq!(h.state().views.source, Some(dir.join("crowd.pack")));
    drop(h);
    let _ = std::fs::remove_dir_all(dir);
}

/// New from glTF and Open on top of unsaved work ask first, as closing does: Cancel keeps
/// the work, Don't save replaces it, Save writes it and then opens the other project.
#[test]
fn replacing_unsaved_work_asks_first() {
    let a = temp_project("replace-a");
    let b = temp_project("replace-b");
    let mut h = harness(Some(a.clone()));
    h.run_steps(3);
    let make_dirty = |h: &mut Harness<'static, EditorApp>| {
        h.get_by_label("Segment").click();
        h.run_steps(2);
        h.get_by_label("➕ Add part").click();
        h.run_steps(2);
        assert!(h.state().doc.as_ref().unwrap().dirty);
    };
    make_dirty(&mut h);
    let glb = repo().join(polypostor::default_character::DEFAULT_CHARACTER_PATH);
    h.state_mut().send(Command::NewFromGltf(glb));
    h.run_steps(2);
    assert!(h.state().safety.replace_prompt.is_some(), "the prompt shows");
    h.get_by_label("Save changes before starting a new project?");
    h.get_by_label("Cancel").click();
    h.run_steps(2);
    {
        let doc = h.state().doc.as_ref().unwrap();
        assert!(
            doc.dirty && doc.project_file.as_ref().unwrap().starts_with(&a),
            "the work is kept"
        );
    }
    // Don't save: the other project opens, the changes are gone.
    h.state_mut().send(Command::Open(b.clone()));
    h.run_steps(2);
    h.get_by_label("Save changes before opening another project?");
    h.get_by_label("Don't save").click();
    h.run_steps(4);
    {
        let doc = h.state().doc.as_ref().unwrap();
        assert!(
            doc.project_file.as_ref().unwrap().starts_with(&b),
            "{:?}",
            doc.project_file
        );
        assert!(!doc.dirty);
    }
    let (saved_a, _) = polypostor::project::Project::load(&a).unwrap();
    assert!(
        saved_a.segmentation.is_none(),
        "nothing was written to the first project"
    );
    // Save: written first, then the other project opens.
    make_dirty(&mut h);
    h.state_mut().send(Command::Open(a.clone()));
    h.run_steps(2);
    h.get_by_label("Save").click();
    h.run_steps(4);
    {
        let doc = h.state().doc.as_ref().unwrap();
        assert!(
            doc.project_file.as_ref().unwrap().starts_with(&a),
            "{:?}",
            doc.project_file
        );
    }
    let (saved_b, _) = polypostor::project::Project::load(&b).unwrap();
    assert!(saved_b.segmentation.is_some(), "the changes were saved before opening");
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
    let _ = std::fs::remove_dir_all(a);
    let _ = std::fs::remove_dir_all(b);
}

/// Cancelling a bake is not an error: no error dialog, a line in the log.
#[test]
fn a_cancelled_bake_is_not_an_error() {
    let dir = temp_project("cancel");
    let mut h = harness(Some(dir.clone()));
    h.run_steps(3);
    h.state_mut().send(Command::BakeCrowd);
    h.run_steps(2);
    assert!(h.state().crowd.busy());
    h.get_by_label("Cancel").click();
    let started = std::time::Instant::now();
    while h.state().crowd.busy() && started.elapsed() < std::time::Duration::from_secs(120) {
        std::thread::sleep(std::time::Duration::from_millis(100));
        h.run_steps(1);
    }
    h.run_steps(2);
    let app = h.state();
    assert!(!app.crowd.busy(), "the bake stopped");
    assert!(app.error.is_none(), "a cancel opened the error dialog: {:?}", app.error);
    assert!(
        app.log
            .iter()
            .any(|l| l.text.contains("cancelled") && l.level == super::app::LogLevel::Info),
        "{:?}",
        app.log.iter().map(|l| &l.text).collect::<Vec<_>>()
    );
    assert!(!dir.join("crowd.pack").exists(), "nothing was written");
    let _ = std::fs::remove_dir_all(dir);
}

/// A part added in the Segment tab joins every drawing order set by hand (drawn in front):
/// the bake ignores an order that does not list each part, so adding one threw them away.
/// One undo takes back the part and the orders' new entry.
#[test]
fn an_added_part_joins_the_hand_set_drawing_orders() {
    let dir = temp_project("addpart");
    let mut h = harness(Some(dir.clone()));
    h.run_steps(3);
    h.get_by_label("Segment").click();
    h.run_steps(2);
    let n = {
        let doc = h.state_mut().doc.as_mut().unwrap();
        let n = doc.segmentation.parts.len();
        let mut order: Vec<usize> = (0..n).rev().collect();
        order.swap(0, 1);
        assert!(doc.edit_overrides("Reorder", |o| {
            for v in [0, 3] {
                o.views.entry(v).or_default().order = Some(order.clone());
            }
            true
        }));
        n
    };
    h.get_by_label("➕ Add part").click();
    h.run_steps(2);
    let doc = h.state().doc.as_ref().unwrap();
    assert_eq!(doc.segmentation.parts.len(), n + 1);
    for v in [0, 3] {
        let order = doc.project.overrides.views[&v].order.clone().unwrap();
        assert_eq!(order.len(), n + 1, "view {v}: {order:?}");
        assert_eq!(order.last(), Some(&n), "view {v}: drawn in front: {order:?}");
    }
    assert!(
        h.state()
            .log
            .iter()
            .any(|l| l.text.contains("2 hand-set drawing orders")),
        "said in the log"
    );
    h.state_mut().send(Command::Undo);
    h.run_steps(2);
    let doc = h.state().doc.as_ref().unwrap();
    assert_eq!(doc.segmentation.parts.len(), n);
    assert_eq!(doc.project.overrides.views[&0].order.as_ref().map(Vec::len), Some(n));
    let _ = std::fs::remove_dir_all(dir);
}

/// A stroke of one part far from the rest of it (the Torso on a foot) is said in the Segment
/// tab, and its button gives the triangles back to the part around them, in one undo step.
#[test]
fn a_stray_stroke_is_said_and_given_back() {
    use polypostor::edit::paint;
    let dir = temp_project("stray");
    let mut h = harness(Some(dir.clone()));
    h.run_steps(3);
    h.get_by_label("Segment").click();
    h.run_steps(2);
    let (leg, stroke) = {
        let doc = h.state().doc.as_ref().unwrap();
        let seg = &doc.segmentation;
        let leg = seg.parts.iter().position(|p| p.name == "Left Leg").unwrap() as u16;
        let (pos, _) =
            polypostor::animation::skin_vertices(&doc.character, &polypostor::animation::Pose::rest(&doc.character));
        let low = |t: usize| {
            (0..3)
                .map(|k| pos[doc.character.indices[3 * t + k] as usize].y)
                .sum::<f32>()
        };
        let foot = (0..seg.labels.len())
            .filter(|&t| seg.labels[t] == leg)
            .min_by(|&a, &b| low(a).total_cmp(&low(b)))
            .unwrap();
        (leg, vec![foot])
    };
    assert!(
        h.state_mut()
            .doc
            .as_mut()
            .unwrap()
            .edit("Paint", |seg, _| paint::paint(seg, &stroke, 0, None) > 0)
    );
    h.run_steps(2);
    let button = format!("Give to {}", "Left Leg");
    h.get_by_label(&button).click();
    h.run_steps(2);
    let doc = h.state().doc.as_ref().unwrap();
    assert_eq!(doc.segmentation.labels[stroke[0]], leg, "given back");
    let topo = paint::Topology::new(&doc.character);
    assert!(paint::stray_pieces(&doc.character, &topo, &doc.segmentation).is_empty());
    assert!(h.query_by_label(&button).is_none(), "the warning is gone");
    h.state_mut().send(Command::Undo);
    h.run_steps(2);
    assert_eq!(
        h.state().doc.as_ref().unwrap().segmentation.labels[stroke[0]],
        0,
        "one undo step"
    );
    let _ = std::fs::remove_dir_all(dir);
}

/// The palette refuses a part past the bake's limit and says why.
#[test]
fn the_palette_stops_at_the_part_limit() {
    let dir = temp_project("parts");
    let mut h = harness(Some(dir.clone()));
    h.run_steps(3);
    h.get_by_label("Segment").click();
    h.run_steps(2);
    let limit = polypostor::limits::MAX_PARTS;
    // All but the last through the library (the list grows past the window), the last by a
    // click.
    {
        let doc = h.state_mut().doc.as_mut().unwrap();
        while doc.segmentation.parts.len() < limit - 1 {
            doc.edit("Add part", |seg, _| polypostor::edit::paint::add_part(seg, "").is_ok());
        }
    }
    h.run_steps(2);
    h.get_by_label("➕ Add part").click();
    h.run_steps(2);
    assert_eq!(h.state().doc.as_ref().unwrap().segmentation.parts.len(), limit);
    h.get_by_label("➕ Add part").click();
    h.run_steps(2);
    assert_eq!(
        h.state().doc.as_ref().unwrap().segmentation.parts.len(),
        limit,
        "no part past the limit"
    );
    let mut seg = h.state().doc.as_ref().unwrap().segmentation.clone();
    assert!(polypostor::edit::paint::add_part(&mut seg, "").is_err());
    let note = format!("No more parts: {}", polypostor::edit::paint::part_limit_message());
    h.get_by_label(&note);
    assert!(h.state().error.is_none());
    let _ = std::fs::remove_dir_all(dir);
}

/// Every string literal in the crate's sources that holds a non-ASCII character lays out
/// with the fonts the editor installs and no missing glyph (the harness panics on one only
/// when that text is drawn; this finds one in a label no test happens to show).
#[test]
fn every_ui_string_has_its_glyphs() {
    let ctx = egui::Context::default();
    ctx.set_missing_glyph_policy(egui::MissingGlyphPolicy::Panic);
    let mut out = ctx.run_ui(Default::default(), |_| {});
    out.textures_delta.clear();
    // The studio and both libraries: their messages reach the editor's log and status bar too.
    let mut files = Vec::new();
    let mut dirs = vec![
        repo().join("src"),
        repo().join("crates/polypostor-bake/src"),
        repo().join("crates/polypostor-runtime/src"),
    ];
    while let Some(dir) = dirs.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                dirs.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                files.push(path);
            }
        }
    }
    files.sort();
    assert!(
        files.len() > 20,
        "sources not found under {}",
        repo().join("src").display()
    );
    let mut literals = Vec::new();
    for file in &files {
        let text = std::fs::read_to_string(file).unwrap();
        for line in text.lines() {
            let code = line.trim_start();
            if code.starts_with("//") {
                continue;
            }
            // String literals on this line (between unescaped double quotes).
            let mut current: Option<String> = None;
            let mut prev = ' ';
            for c in code.chars() {
                if c == '"' && prev != '\\' {
                    match current.take() {
                        Some(s) => {
                            if !s.is_ascii() {
                                literals.push((s, file.clone()));
                            }
                        }
                        None => current = Some(String::new()),
                    }
                } else if let Some(s) = current.as_mut() {
                    s.push(c);
                }
                prev = c;
            }
        }
    }
    assert!(
        !literals.is_empty(),
        "no non-ASCII UI strings found: the scan is broken"
    );
    let mut missing = Vec::new();
    for (text, file) in &literals {
        for font in [egui::FontId::proportional(14.0), egui::FontId::monospace(14.0)] {
            let laid_out = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                ctx.fonts_mut(|f| f.layout_no_wrap(text.clone(), font.clone(), egui::Color32::WHITE))
            }));
            if laid_out.is_err() {
                missing.push(format!("{text:?} ({:?}) in {}", font.family, file.display()));
            }
        }
    }
    assert!(missing.is_empty(), "strings with a missing glyph: {missing:#?}");
}

/// A character exported lying down is stood up from the Character panel's up-axis choice:
/// the character is read again standing, the choice is one undo step (the character lies
/// again after Ctrl+Z), and the saved project reopens standing.
#[test]
fn the_up_axis_choice_stands_a_lying_character_up_and_undoes() {
    let dir = std::env::temp_dir().join(format!("polypostor-up-axis-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let mut c = polypostor::default_character::generate();
    c.move_rigidly(
        glam::Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2),
        glam::Vec3::ZERO,
    );
    let glb = dir.join("lying.glb");
    std::fs::write(&glb, polypostor::gltf_write::write_glb(&c).unwrap()).unwrap();
    let height = |h: &Harness<'static, EditorApp>| {
        let s = &h.state().doc.as_ref().unwrap().summary;
        s.bounds_max[1] - s.bounds_min[1]
    };
    let mut h = harness(Some(glb));
    h.run_steps(3);
    assert!(
        !h.state().doc.as_ref().unwrap().dirty,
        "a character just imported holds no unsaved work"
    );
    let lying = height(&h);
    assert!(lying < 0.5, "lies: {lying} m tall");
    h.get_by_label("Up axis").click();
    h.run_steps(2);
    h.get_by_label("-z").click();
    h.run_steps(4);
    {
        let doc = h.state().doc.as_ref().unwrap();
        assert_eq!(doc.project.character.up, polypostor::UpAxis::NegZ);
        assert_eq!(doc.character.up_axis, polypostor::UpAxis::NegZ);
        assert!(doc.dirty);
    }
    let standing = height(&h);
    assert!((1.5..2.2).contains(&standing), "stands: {standing} m tall");
    // A bake made with glTF's axis (as before the choice) is marked in the Views tab.
    let (bake_dir, out) = bake_small(
        "up-axis",
        "plain.pack",
        "polypostor",
        polypostor::bake::pipeline::BakeOptions {
            views: 2,
            resolution: 32,
            fps: 5.0,
            ..Default::default()
        },
    );
    h.state_mut().views.set_source(Some(&out));
    h.get_by_label("Views").click();
    h.run_steps(2);
    assert!(
        h.query_by_label_contains("This bake read the character with +y as up")
            .is_some(),
        "the stale bake is marked"
    );
    h.get_by_label("Character").click();
    h.run_steps(2);
    std::fs::remove_dir_all(bake_dir).unwrap();
    h.state_mut().send(Command::Undo);
    h.run_steps(4);
    assert_eq!(
        h.state().doc.as_ref().unwrap().character.up_axis,
        polypostor::UpAxis::PosY
    );
    assert!((height(&h) - lying).abs() < 1e-4, "lies again after the undo");
    h.state_mut().send(Command::Redo);
    h.run_steps(4);
    assert!((height(&h) - standing).abs() < 1e-4, "stands again after the redo");
    let project_dir = dir.join("project");
    h.state_mut().send(Command::SaveAs(project_dir.clone()));
    h.run_steps(3);
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
    let mut again = harness(Some(project_dir));
    again.run_steps(3);
    assert!(
        (height(&again) - standing).abs() < 1e-4,
        "the saved project reopens standing"
    );
    std::fs::remove_dir_all(dir).unwrap();
}

/// A re-import for an up-axis change that fails (the file was deleted after it was opened)
/// is reported once, not tried again every frame; choosing the axis back and forth tries it
/// again, and the document keeps the character it had.
#[test]
fn a_failed_up_axis_reimport_is_reported_once() {
    let dir = std::env::temp_dir().join(format!("polypostor-up-axis-gone-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let glb = dir.join("gone.glb");
    let c = polypostor::default_character::generate();
    std::fs::write(&glb, polypostor::gltf_write::write_glb(&c).unwrap()).unwrap();
    let mut h = harness(Some(glb.clone()));
    h.run_steps(3);
    std::fs::remove_file(&glb).unwrap();
    let failures = |h: &Harness<'static, EditorApp>| {
        h.state()
            .log
            .iter()
            .filter(|e| e.text.contains("Cannot import") && e.text.contains("gone.glb"))
            .count()
    };
    h.state_mut().send(Command::SetUpAxis(polypostor::UpAxis::NegZ));
    h.run_steps(12);
    assert_eq!(failures(&h), 1, "one report: {:?}", h.state().log);
    let doc = h.state().doc.as_ref().unwrap();
    assert_eq!(
        doc.character.up_axis,
        polypostor::UpAxis::PosY,
        "the character it had stays"
    );
    assert_eq!(doc.project.character.up, polypostor::UpAxis::NegZ);
    h.state_mut().error = None;
    // Undo (back to the axis the character was read with), then redo: tried once more.
    h.state_mut().send(Command::Undo);
    h.run_steps(3);
    h.state_mut().send(Command::Redo);
    h.run_steps(12);
    assert_eq!(
        failures(&h),
        2,
        "tried again after the axis came back: {:?}",
        h.state().log
    );
    std::fs::remove_dir_all(dir).unwrap();
}
