//! Measures the fast fitting mode against the exact DP on a subset of views of a character,
//! over every frame of the clip (the exact costs are cached, so fast-mode variants can be
//! compared quickly). Usage: `cargo run --release --example fit_gap -- [default|PATH.glb]
//! [VIEWS] [STRIDE] [KEY]`.

use std::collections::BTreeMap;

use polypostor::bake::caps::{CapOverrides, find_caps};
use polypostor::bake::image_cost::PartTile;
use polypostor::bake::part_fit::{PartFitOptions, fit_part};
use polypostor::bake::renders::{frame_times, merge_parts, sample_frames, view_cameras};
use polypostor::bake::segment::auto_segment;
use polypostor::bake::viewpoints::{Coverage, directions};
use polypostor::gpu::*;
use rayon::prelude::*;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let input = args.first().cloned().unwrap_or_else(|| "default".into());
    let views_n: usize = args.get(1).map_or(137, |s| s.parse().unwrap());
    let stride: usize = args.get(2).map_or(10, |s| s.parse().unwrap());
    let key: usize = args.get(3).map_or(0, |s| s.parse().unwrap());
    let c = if input == "default" {
        polypostor::default_character::generate()
    } else {
        polypostor::import_path(std::path::Path::new(&input)).unwrap()
    };
    let label = std::path::Path::new(&input)
        .file_stem()
        .unwrap()
        .to_string_lossy()
        .to_string();
    // FIT_CLIP=N: the character's N-th clip instead of its first.
    let clip: usize = std::env::var("FIT_CLIP").ok().and_then(|s| s.parse().ok()).unwrap_or(0);
    let cache = if clip == 0 {
        format!("/tmp/fitgap_{label}_{views_n}_{stride}_{key}.json")
    } else {
        format!("/tmp/fitgap_{label}_clip{clip}_{views_n}_{stride}_{key}.json")
    };
    let mut exact: BTreeMap<String, Vec<f64>> = std::fs::read_to_string(&cache)
        .ok()
        .and_then(|s| serde_json::from_str(&s).ok())
        .unwrap_or_default();
    let ctx = GpuContext::new(&AdapterPreference::SoftwareFirst).expect("adapter");
    let seg = auto_segment(&c);
    let caps = find_caps(&c, &seg);
    let (merged, ranges) = merge_parts(&c, &seg, &caps, &CapOverrides::default());
    let times = frame_times(c.clips[clip].duration_secs, 10.0);
    let (poses, points) = sample_frames(&merged, Some(clip), &times);
    let dirs = directions(views_n, Coverage::UpperHemisphere);
    let cameras = view_cameras(&points, &dirs);
    let renderer = CharacterRenderer::new(&ctx.device);
    let batch = PartRenderer::new(&renderer, &ctx.device, &ctx.queue, &merged, ranges, &poses, 128);
    let frames = times.len();
    let mut jobs = Vec::new();
    // FIT_VIEWS=34,102: these views instead of every `stride`-th (the exact cache is keyed
    // by view, so any set can share it).
    let chosen: Vec<usize> = match std::env::var("FIT_VIEWS") {
        Ok(list) => list.split(',').map(|x| x.trim().parse().unwrap()).collect(),
        Err(_) => (0..views_n).step_by(stride).collect(),
    };
    for v in chosen {
        let img = batch
            .render_view(&renderer, &ctx.device, &ctx.queue, &cameras[v])
            .unwrap();
        for p in 0..seg.parts.len() {
            let tiles: Vec<PartTile> = (0..frames)
                .map(|f| PartTile::from_images(&img.tile(&img.color, p, f), &img.tile(&img.normal, p, f)))
                .collect();
            jobs.push((v, p, tiles));
        }
    }
    if let Ok(focus) = std::env::var("FOCUS") {
        let (v, p): (usize, usize) = {
            let mut it = focus.split('/').map(|x| x.parse().unwrap());
            (it.next().unwrap(), it.next().unwrap())
        };
        let (_, _, tiles) = jobs.iter().find(|j| j.0 == v && j.1 == p).expect("focus job");
        let fast = fit_part(tiles, key, &PartFitOptions::default(), &[]).unwrap();
        let ex = fit_part(
            tiles,
            key,
            &PartFitOptions {
                exhaustive: true,
                ..Default::default()
            },
            &[],
        )
        .unwrap();
        println!("S = {:?}", fast.key_polygon);
        println!("tris = {:?}", fast.key_triangles);
        for f in 0..frames {
            println!("f{f}: fast {:.2} exact {:.2}", fast.costs[f], ex.costs[f]);
            println!("  T = {:?}", fast.targets[f]);
            println!("  fast  {:?}", fast.mappings[f]);
            println!("  exact {:?}", ex.mappings[f]);
        }
        return;
    }
    let missing: Vec<_> = jobs
        .iter()
        .filter(|j| !exact.contains_key(&format!("{}/{}", j.0, j.1)))
        .collect();
    if !missing.is_empty() {
        eprintln!("exact for {} part-views ...", missing.len());
        let t = std::time::Instant::now();
        let got: Vec<(String, Vec<f64>)> = missing
            .par_iter()
            .map(|(v, p, tiles)| {
                let o = PartFitOptions {
                    exhaustive: true,
                    ..Default::default()
                };
                let costs = fit_part(tiles, key.min(frames - 1), &o, &[]).map_or(vec![], |f| f.costs);
                (format!("{v}/{p}"), costs)
            })
            .collect();
        exact.extend(got);
        std::fs::write(&cache, serde_json::to_string(&exact).unwrap()).unwrap();
        eprintln!("exact took {:.1}s", t.elapsed().as_secs_f64());
    }
    let mut options = PartFitOptions::default();
    if let Some(t) = std::env::var("FIT_TAU").ok().and_then(|s| s.parse().ok()) {
        options.restart_threshold = t;
    }
    if let Some(t) = std::env::var("FIT_STEP").ok().and_then(|s| s.parse().ok()) {
        options.restart_step = t;
    }
    let knob = |name: &str, field: &mut usize| {
        if let Some(v) = std::env::var(name).ok().and_then(|s| s.parse().ok()) {
            *field = v;
        }
    };
    knob("FIT_WINDOW", &mut options.window);
    knob("FIT_HINT", &mut options.hint_radius);
    knob("FIT_REFINE", &mut options.refine_passes);
    knob("FIT_SWEEPS", &mut options.sweeps);
    knob("FIT_FREE", &mut options.sweep_free);
    knob("FIT_GAP", &mut options.sweep_gap);
    knob("FIT_RWIN", &mut options.refine_window);
    if let Some(t) = std::env::var("FIT_JUMP").ok().and_then(|s| s.parse().ok()) {
        options.restart_jump = t;
    }
    knob("FIT_RHINT", &mut options.refine_hint);
    if let Some(t) = std::env::var("FIT_TRUST").ok().and_then(|s| s.parse().ok()) {
        options.restart_trust = t;
    }
    if let Some(t) = std::env::var("FIT_STILL").ok().and_then(|s| s.parse().ok()) {
        options.near_still_px2 = t;
    }
    options.finish_exact = std::env::var("FIT_EXACT").is_ok();
    options.respread = std::env::var("FIT_NORESPREAD").is_err();
    if let Some(t) = std::env::var("FIT_BOUND").ok().and_then(|s| s.parse().ok()) {
        options.restart_bound = t;
    }
    let cpu = || {
        let mut u: libc::rusage = unsafe { std::mem::zeroed() };
        unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut u) };
        u.ru_utime.tv_sec as f64 + u.ru_utime.tv_usec as f64 * 1e-6
    };
    let t = cpu();
    let e0 = polypostor::bake::part_fit::evaluations();
    let p0 = polypostor::bake::part_fit::evaluations_by_phase();
    let l0 = polypostor::bake::part_fit::lookups();
    let fast: Vec<(usize, usize, Vec<f64>)> = jobs
        .par_iter()
        .map(|(v, p, tiles)| {
            let costs = fit_part(tiles, key.min(frames - 1), &options, &[]).map_or(vec![], |f| f.costs);
            (*v, *p, costs)
        })
        .collect();
    let fast_secs = cpu() - t;
    let evals = (polypostor::bake::part_fit::evaluations() - e0) as f64 / 1e6;
    let p1 = polypostor::bake::part_fit::evaluations_by_phase();
    let phases: Vec<String> = (0..4).map(|i| format!("{:.1}", (p1[i] - p0[i]) as f64 / 1e6)).collect();
    println!(
        "  M evaluations: windows {}, sweeps {}, restart {}, exact {}; {:.1} M asked",
        phases[0],
        phases[1],
        phases[2],
        phases[3],
        (polypostor::bake::part_fit::lookups() - l0) as f64 / 1e6
    );
    let (mut ft, mut et) = (0.0, 0.0);
    let mut by_dist: BTreeMap<usize, (f64, f64)> = BTreeMap::new();
    let mut worst: Vec<(f64, String)> = Vec::new();
    for (v, p, fc) in &fast {
        let ec = &exact[&format!("{v}/{p}")];
        if fc.len() != ec.len() {
            continue;
        }
        for f in 0..fc.len() {
            ft += fc[f];
            et += ec[f];
            let d = (f + frames - key) % frames;
            let d = d.min(frames - d);
            let e = by_dist.entry(d).or_default();
            e.0 += fc[f];
            e.1 += ec[f];
            worst.push((
                fc[f] - ec[f],
                format!("v{v} p{p} f{f} fast {:.1} exact {:.1}", fc[f], ec[f]),
            ));
        }
    }
    println!(
        "{label}: fast/exact = {:.4}  (fast {:.1} CPU s, {evals:.1} M evaluations, {} part-views, {frames} frames)",
        ft / et,
        fast_secs,
        fast.len()
    );
    for (d, (f, e)) in by_dist {
        println!("  distance {d}: {:.4}", f / e);
    }
    worst.sort_by(|a, b| b.0.total_cmp(&a.0));
    let gap = ft - et;
    for (g, s) in worst.iter().take(8) {
        println!("  {:.1}% of gap: {s}", 100.0 * g / gap);
    }
}
