//! `polypostor bench sim`.

use super::*;

/// `bench sim`: a 1600×900 camera at the edge of the crowd looking across it from 10 m up,
/// 137 hemisphere views, a 10-frame clip, the default three-level mix; the simulation on one
/// thread, the selection on the rayon pool (`RAYON_NUM_THREADS=1`: one thread).
/// Most agents `bench sim` takes (as `bench crowd`).
pub const MAX_AGENTS: usize = 1_000_000;

/// Most timed frames `bench sim` takes.
pub const MAX_FRAMES: usize = 100_000;

pub fn bench_sim(agents: usize, frames: usize, mixed: bool, json: bool) -> anyhow::Result<String> {
    if !(1..=MAX_AGENTS).contains(&agents) {
        anyhow::bail!("--agents {agents}: choose 1 to 1,000,000");
    }
    if !(1..=MAX_FRAMES).contains(&frames) {
        anyhow::bail!("--frames {frames}: choose 1 to {MAX_FRAMES}");
    }
    let mut t = String::new();
    use crate::bake::viewpoints::{Coverage, ViewLookup, directions};
    use crate::crowd::lod::{Level, LodDistances, LodPolicy};
    use crate::crowd::{ClipTiming, Crowd, CrowdCamera, CrowdParams};
    let mut params = CrowdParams {
        count: agents,
        ..Default::default()
    };
    // `--mixed`: the default character's four clips (speeds as measured) and a quadruped-like
    // character 0.9 m tall and 2.4 m long, its own three clips at 12 fps and 40 views.
    let span = |name: &str, start: u32, frames: u32, ground_speed: f32| crate::timeline::ClipSpan {
        name: name.into(),
        start,
        frames,
        looping: true,
        ground_speed,
        secs_per_frame: 0.0,
    };
    let beast_size =
        crate::crowd::CharacterSize::from_bounds(glam::Vec3::new(-0.3, 0.0, -1.2), glam::Vec3::new(0.3, 0.9, 1.2));
    if mixed {
        params.spaced_for_shares(&[beast_size], &[0.7, 0.3]);
    }
    let mut crowd = Crowd::new(params);
    if mixed {
        crowd.set_clips(
            &[
                span("Walk", 0, 10, 1.73),
                span("Run", 10, 7, 4.74),
                span("Idle", 17, 20, 0.0),
                span("Wave", 37, 20, 0.0),
            ],
            10.0,
        );
        let beast = crate::crowd::Species::new(
            beast_size,
            None,
            &[
                span("Pace", 0, 16, 2.0),
                span("Trot", 16, 9, 3.5),
                span("Sniff", 25, 30, 0.0),
            ],
            &directions(40, Coverage::UpperHemisphere),
            ClipTiming { frames: 55, fps: 12.0 },
        );
        crowd.mix(vec![beast], &[0.7, 0.3]).map_err(anyhow::Error::msg)?;
    }
    let (w, h, fov) = (1600.0f32, 900.0f32, 50f32.to_radians());
    let eye = glam::Vec3::new(0.0, 10.0, -crowd.half_extent - 5.0);
    let cam = crate::gpu::Camera {
        eye,
        target: glam::Vec3::new(0.0, 0.0, 0.0),
        up: glam::Vec3::Y,
        projection: crate::gpu::Projection::Perspective { fov_y_rad: fov },
        near: 0.1,
        far: 4.0 * crowd.half_extent + 100.0,
    };
    let camera = CrowdCamera {
        eye,
        clip_from_world: cam.clip_from_world(w / h),
        focal_px: h / (2.0 * (fov / 2.0).tan()),
    };
    let views = ViewLookup::new(&directions(137, Coverage::UpperHemisphere));
    let policy = LodPolicy::Mixed(LodDistances::default());
    let clip = ClipTiming {
        frames: if mixed { 57 } else { 10 },
        fps: 10.0,
    };
    let mut sim = Vec::with_capacity(frames);
    let mut sel = Vec::with_capacity(frames);
    let mut up = Vec::with_capacity(frames);
    let mut last = Default::default();
    // The CPU side of the upload: the Polypostor instances sorted by view, then every level's
    // records copied once (what `queue.write_buffer` does into its staging memory).
    let (mut sorted, mut ranges, mut staging) = (Vec::new(), Vec::new(), Vec::<u8>::new());
    for k in 0..frames + 30 {
        let s = crowd.frame(1.0 / 60.0, &camera, &policy, &views, clip);
        let t = std::time::Instant::now();
        staging.clear();
        for lists in &crowd.instances {
            crate::crowd::sort_by_view(
                &lists[Level::Polypostor as usize],
                137,
                clip.frames as u32,
                &mut sorted,
                &mut ranges,
            );
            staging.extend_from_slice(bytemuck::cast_slice(&sorted));
            for (l, list) in lists.iter().enumerate() {
                if l != Level::Polypostor as usize {
                    staging.extend_from_slice(bytemuck::cast_slice(list));
                }
            }
        }
        std::hint::black_box(&staging);
        let upload = t.elapsed().as_secs_f64();
        if k >= 30 {
            sim.push(s.simulate_secs * 1e3);
            sel.push(s.select_secs * 1e3);
            up.push(upload * 1e3);
            last = s;
        }
    }
    let total: Vec<f64> = sim.iter().zip(&sel).zip(&up).map(|((a, b), c)| a + b + c).collect();
    let stat = |v: &[f64]| {
        let mut s = v.to_vec();
        s.sort_by(f64::total_cmp);
        let mean = s.iter().sum::<f64>() / s.len().max(1) as f64;
        let p95 = s
            .get((s.len() * 95 / 100).min(s.len().saturating_sub(1)))
            .copied()
            .unwrap_or(0.0);
        (mean, p95)
    };
    let (sm, sp) = stat(&sim);
    let (lm, lp) = stat(&sel);
    let (um, upp) = stat(&up);
    let (tm, tp) = stat(&total);
    let levels: serde_json::Map<String, serde_json::Value> = Level::ALL
        .iter()
        .map(|l| (l.name().to_string(), serde_json::json!(last.per_level[*l as usize])))
        .collect();
    if json {
        say!(
            t,
            "{}",
            serde_json::json!({
                "agents": crowd.len(),
                "frames": frames,
                "simulate_ms": {"mean": sm, "p95": sp},
                "select_ms": {"mean": lm, "p95": lp},
                "upload_ms": {"mean": um, "p95": upp},
                "cpu_ms": {"mean": tm, "p95": tp},
                "visible": last.visible,
                "per_level": levels,
                "view_candidates_per_query": views.mean_candidates(),
            })
        );
    } else {
        say!(
            t,
            "crowd CPU work per frame, {} agents, {frames} frames (selection on {} threads)",
            crowd.len(),
            rayon::current_num_threads()
        );
        say!(t, "  {:<34} {:>8} {:>8}", "pass", "mean ms", "p95 ms");
        say!(t, "  {:<34} {sm:>8.3} {sp:>8.3}", "simulate (wander, occupancy grid)");
        say!(t, "  {:<34} {lm:>8.3} {lp:>8.3}", "cull, LOD, view, frame, instances");
        say!(t, "  {:<34} {um:>8.3} {upp:>8.3}", "upload (sort by view, copy)");
        say!(t, "  {:<34} {tm:>8.3} {tp:>8.3}", "total (target <= 2 ms at 20,000)");
        say!(
            t,
            "  visible {} of {}: {}",
            last.visible,
            crowd.len(),
            Level::ALL
                .iter()
                .filter(|l| last.per_level[**l as usize] > 0)
                .map(|l| format!("{} {}", l.name(), last.per_level[*l as usize]))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    Ok(t)
}
