//! Whole-character packs: several clips baked into one pack. The clip table round-trips and
//! damaged tables are refused; every key image draws only frames whose neighbours in their
//! own clip it fits; the report gives each clip's error and memory; and the GPU renderer
//! blends a clip's last frame into that clip's first, not into the next clip.

mod common;

use polypostor::bake::report::build_report;
use polypostor::crowd::{Instance, frame_pair};
use polypostor::gpu::*;
use polypostor::pack::{load_pack, write_pack};
use polypostor::timeline::next_frame;

#[test]
fn several_clips_share_one_pack_and_each_loops_on_its_own() {
    let ctx = common::gpu();
    let (device, queue) = (&ctx.device, &ctx.queue);
    let c = polypostor::default_character::generate();
    let (walk, run, idle) = (
        c.find_clip("Walk").unwrap(),
        c.find_clip("Run").unwrap(),
        c.find_clip("Idle").unwrap(),
    );
    let options = polypostor::bake::pipeline::BakeOptions {
        clip: Some(walk),
        extra_clips: vec![run, idle],
        ..common::cheap_keys(3, 64)
    };
    let (c, b) = common::bake_default(&ctx, &options);
    // The timeline: Walk (10 frames), Run (7), Idle (20), one after another.
    let spans = &b.timeline.spans;
    let names: Vec<&str> = spans.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, ["Walk", "Run", "Idle"]);
    assert_eq!(
        spans.iter().map(|s| (s.start, s.frames)).collect::<Vec<_>>(),
        [(0, 10), (10, 7), (17, 20)]
    );
    assert_eq!(b.frame_times.len(), 37);
    // Each frame's time is its time in its own clip.
    assert_eq!(b.frame_times[10], 0.0);
    assert!((b.frame_times[16] - 0.6).abs() < 1e-6);
    // Measured ground speeds: the run is faster than the walk, the idle still.
    assert!(spans[1].ground_speed > 1.3 * spans[0].ground_speed && spans[0].ground_speed > 0.5);
    assert!(spans[2].ground_speed < 0.1 * spans[0].ground_speed);

    // Brute force: a frame drawn from an extra key has itself and both its neighbours in its
    // clip inside that key's fitted span.
    let frames = b.frame_times.len();
    let mut drawn_by_extra = 0;
    for view in &b.views {
        for part in &view.parts {
            for (f, &k) in part.frame_key.iter().enumerate() {
                if k == 0 {
                    continue;
                }
                let e = &part.extra[k as usize - 1];
                let s = spans.iter().find(|s| s.range().contains(&f)).unwrap();
                let r = s.range();
                let prev = r.start + (f - r.start + r.len() - 1) % r.len();
                let next = r.start + (f - r.start + 1) % r.len();
                for g in [prev, f, next] {
                    assert!(
                        e.span.contains(g, frames),
                        "frame {f} (clip {}) by key {k}: {g} outside",
                        s.name
                    );
                }
                drawn_by_extra += 1;
            }
        }
    }
    assert!(drawn_by_extra > 0, "cheap keys drew no frame from an extra key");

    // Pack and report.
    let dir = common::temp_dir("whole-pack");
    let out = dir.join("clips.pack");
    let stats = write_pack(&b, &c.name, Some("Walk"), &out).unwrap();
    let report = build_report(&b, &c.name, Some("Walk"), &stats, 1.0);
    assert_eq!(report.clips.len(), 3);
    for (r, s) in report.clips.iter().zip(spans) {
        assert_eq!(
            (r.name.as_str(), r.first_frame, r.frames),
            (s.name.as_str(), s.start as usize, s.frames as usize)
        );
        assert!(
            r.mean_psnr > 10.0 && r.mean_ssim > 0.3,
            "{}: {} dB",
            r.name,
            r.mean_psnr
        );
        // Impostors of the clip: 3 views × its frames × 64² × (colour + normal).
        assert_eq!(r.impostor_bytes, 3 * s.frames as u64 * 64 * 64 * 8);
        assert!(r.alone_bytes < stats.pack_bytes && r.animation_bytes > 0);
    }
    // The animation of the clips together is the pack's.
    let sum: u64 = report.clips.iter().map(|r| r.animation_bytes).sum();
    assert_eq!(sum, polypostor::bake::report::animation_bytes(&b, 0..frames));
    // The whole pack's mean is the frame-weighted mean of the clips' (both the PSNR of a mean
    // RMSE, so weighed as RMSE).
    let rmse = |db: f64| 10f64.powf(-db / 20.0);
    let weighted: f64 = report
        .clips
        .iter()
        .map(|r| rmse(r.mean_psnr) * r.frames as f64)
        .sum::<f64>()
        / frames as f64;
    assert!(
        (rmse(report.mean_psnr) - weighted).abs() < 1e-9 * weighted.max(1e-6),
        "{weighted} {}",
        report.mean_psnr
    );

    let p = load_pack(&out).unwrap();
    assert_eq!(&p.manifest.clips, spans);
    assert_eq!(p.manifest.frames as usize, frames);
    for f in 0..frames {
        assert_eq!(p.manifest.next_frame(f), next_frame(spans, f));
    }
    assert_eq!(p.manifest.next_frame(9), 0, "Walk loops on itself");
    assert_eq!(p.manifest.next_frame(16), 10, "Run loops on itself");

    // Damaged clip tables are refused, naming the table.
    let text = std::fs::read_to_string(out.join("manifest.json")).unwrap();
    let damage = |name: &str, f: &dyn Fn(&mut serde_json::Value)| -> String {
        let d = dir.join(name);
        common::copy_folder(&out, &d);
        let mut m: serde_json::Value = serde_json::from_str(&text).unwrap();
        f(&mut m["clips"]);
        std::fs::write(d.join("manifest.json"), serde_json::to_string(&m).unwrap()).unwrap();
        load_pack(&d)
            .err()
            .unwrap_or_else(|| panic!("{name}: damaged pack loaded"))
            .to_string()
    };
    let e = damage("clips-gap", &|c| c[1]["start"] = 11.into());
    assert!(e.contains("starts at frame"), "{e}");
    let e = damage("clips-short", &|c| c[2]["frames"] = 3.into());
    assert!(e.contains("hold"), "{e}");
    let e = damage("clips-empty", &|c| *c = serde_json::json!([]));
    assert!(e.contains("empty"), "{e}");
    let e = damage("clips-speed", &|c| c[0]["ground_speed"] = (-1.0).into());
    assert!(e.contains("ground speed"), "{e}");
    let e = damage("clips-none-frames", &|c| c[0]["frames"] = 0.into());
    assert!(e.contains("no frames"), "{e}");

    // On the GPU: half-way from Walk's last frame (9) the character is half-way to Walk's
    // first (0), exactly as drawing 9 → 0 says, and not to Run's first (10).
    let mut gpu = GpuPolypostors::new(device, queue, &p.gpu_input()).unwrap();
    let size = 160u32;
    let target = RenderTarget::new(device, size, size);
    let style = PolypostorStyle {
        lit: false,
        tint: 0.0,
        ..Default::default()
    };
    let v = 0usize;
    let cam = p.manifest.views[v].camera.clone();
    let camera = cam.to_camera(cam.half_size * 4.0, cam.half_size, cam.half_size * 8.0);
    let mut draw = |pair: u32, blend: f32| {
        let i = Instance {
            pos: [0.0, 0.0],
            facing: [0.0, 1.0],
            view: v as u32,
            frame: pair,
            blend,
            variant: 3,
        };
        gpu.render(device, queue, &target, camera.clip_from_world(1.0), &style, &[i])
            .unwrap();
        target.read_color(device, queue).unwrap()
    };
    let diff = |a: &image::RgbaImage, b: &image::RgbaImage| -> f64 {
        a.pixels()
            .zip(b.pixels())
            .map(|(x, y)| (0..3).map(|k| (x[k] as f64 - y[k] as f64).abs()).sum::<f64>())
            .sum::<f64>()
            / (3 * size * size) as f64
    };
    // Blend 1 towards frame 0 is frame 0 drawn whole; towards 10 it is Run's first frame.
    let end_of_walk = draw(frame_pair(9, 0), 1.0);
    let walk_start = draw(frame_pair(0, 1), 0.0);
    let run_start = draw(frame_pair(10, 11), 0.0);
    assert!(
        diff(&end_of_walk, &walk_start) < 0.05,
        "{}",
        diff(&end_of_walk, &walk_start)
    );
    assert!(
        diff(&walk_start, &run_start) > 1.0,
        "Walk's and Run's first frames look alike ({}): the check proves nothing",
        diff(&walk_start, &run_start)
    );
    // And the same on the skinned crowd meshes: their joint samples follow each clip's loop.
    let timeline = polypostor::timeline::Timeline::new(&c, &[Some(walk), Some(run), Some(idle)], 10.0).unwrap();
    let labels: Vec<u32> = b.segmentation.labels.iter().map(|&l| l as u32).collect();
    let timing = polypostor::crowd::ClipTiming { frames, fps: 10.0 };
    let mut crowd = CrowdRenderers::new(
        device,
        queue,
        &c,
        &timeline,
        &labels,
        &inputs::CrowdInputs::meshes(timing),
    )
    .unwrap();
    let mut mesh = |pair: u32, blend: f32| {
        let mut inst: [Vec<Instance>; polypostor::crowd::lod::Level::COUNT] = Default::default();
        inst[polypostor::crowd::lod::Level::Skinned as usize].push(Instance {
            pos: [0.0, 0.0],
            facing: [0.0, 1.0],
            view: 0,
            frame: pair,
            blend,
            variant: 3,
        });
        crowd.render(
            device,
            queue,
            &target,
            camera.clip_from_world(1.0),
            &style,
            &inst,
            wgpu::Color::BLACK,
        );
        target.read_color(device, queue).unwrap()
    };
    let m_end = mesh(frame_pair(9, 0), 0.999);
    let m_start = mesh(frame_pair(0, 1), 0.0);
    let m_run = mesh(frame_pair(10, 11), 0.0);
    assert!(diff(&m_end, &m_start) < 0.3, "{}", diff(&m_end, &m_start));
    assert!(diff(&m_start, &m_run) > 1.0, "{}", diff(&m_start, &m_run));
}

#[test]
fn clip_lists_are_parsed_and_refused_clearly() {
    use polypostor::timeline::{Timeline, parse_clip_list};
    let c = polypostor::default_character::generate();
    assert_eq!(parse_clip_list("all", &c).unwrap(), ["Walk", "Run", "Idle", "Wave"]);
    assert_eq!(parse_clip_list(" Run , Walk ", &c).unwrap(), ["Run", "Walk"]);
    assert!(
        parse_clip_list("Walk,Jump", &c)
            .unwrap_err()
            .contains("no clip named 'Jump'")
    );
    assert!(parse_clip_list("Walk,Walk", &c).unwrap_err().contains("twice"));
    assert!(parse_clip_list("Walk,,Run", &c).unwrap_err().contains("empty"));
    // The frame limit counts every clip together.
    let mut long = c.clone();
    for clip in &mut long.clips {
        clip.duration_secs = 300.0;
    }
    let all: Vec<Option<usize>> = (0..long.clips.len()).map(Some).collect();
    let e = Timeline::new(&long, &all, 10.0).unwrap_err().to_string();
    assert!(e.contains("together"), "{e}");
}
