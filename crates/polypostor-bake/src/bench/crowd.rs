//! `polypostor bench crowd` and `bench stability`.

use std::path::{Path, PathBuf};

use super::*;

/// Seconds `bench crowd` spends timing one representation at one size, at most (about).
pub const TIMED_SECS: f64 = 60.0;

/// The most frames `bench crowd` times per figure (`--frames`).
pub const MAX_FRAMES: usize = 100_000;

/// Frames to time of the `frames` asked when one takes `frame_secs` (from the warm-up): all
/// of them while they fit in [`TIMED_SECS`], else as many as fit, at least one.
pub fn timed_frames(frames: usize, frame_secs: f64) -> usize {
    if !(frame_secs > 0.0) || frame_secs * frames as f64 <= TIMED_SECS {
        return frames;
    }
    ((TIMED_SECS / frame_secs).floor() as usize).clamp(1, frames)
}

/// `bench crowd`: every representation at every size, one after the other on the same
/// crowd and camera, each frame simulated, selected, uploaded, drawn and waited for.
#[allow(clippy::too_many_arguments)]
pub fn bench_crowd(
    env: &Env,
    counts: &[usize],
    frames: usize,
    pack: Option<PathBuf>,
    character: Option<PathBuf>,
    only: &[String],
    (with, shares): (&[PathBuf], &[f32]),
    out: &Path,
    (width, height): (u32, u32),
    json: bool,
) -> anyhow::Result<String> {
    let mut t = String::new();
    use crate::crowd::lod::{Level, LodDistances, LodPolicy};
    use crate::scene::{CrowdAssets, CrowdScene, bench_camera};
    if counts.is_empty() || counts.iter().any(|&c| c == 0 || c > 1_000_000) || !(1..=MAX_FRAMES).contains(&frames) {
        anyhow::bail!("--counts must list crowd sizes from 1 to 1,000,000 and --frames must be 1 to 100,000");
    }
    if with.len() + 1 > crate::crowd::MAX_SPECIES {
        anyhow::bail!(
            "--with: {} characters in one crowd, at most {}",
            with.len() + 1,
            crate::crowd::MAX_SPECIES
        );
    }
    let shares = if shares.is_empty() {
        vec![1.0; with.len() + 1]
    } else {
        shares.to_vec()
    };
    if shares.len() != with.len() + 1
        || shares.iter().any(|s| !s.is_finite() || *s < 0.0)
        || !(shares.iter().sum::<f32>() > 0.0)
    {
        anyhow::bail!(
            "--shares: give {} ≥ 0 (finite), not all 0 (the pack's character, then each --with)",
            crate::import::plural(with.len() + 1, "number")
        );
    }
    // The other characters load (and are checked) before any work.
    let guests = with
        .iter()
        .map(|d| CrowdAssets::load(d, None, None).map_err(|e| anyhow::anyhow!("--with {e}")))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let shots: Vec<String> = counts.iter().map(|c| format!("crowd_{c}.png")).collect();
    let mut names = vec!["crowd_fps.png", "crowd_fps.json"];
    names.extend(shots.iter().map(String::as_str));
    check_output_files(out, &names)?;
    let ctx = crate::gpu::GpuContext::from_env()?;
    crate::limits::check_render_size(&ctx.device, width, height, "--width × --height")?;
    // Without --pack: a bake of the default character in a temporary folder, removed when
    // the benchmark ends (or is interrupted).
    let mut temp = None;
    let dir = match pack {
        Some(p) => p,
        None => {
            let t = crate::safe_fs::TempDir::new("polypostor-bench")?;
            let d = t.path().join("default.pack");
            temp = Some(t);
            env.bake_default_all(&ctx, &d)?;
            d
        }
    };
    let assets = CrowdAssets::load(&dir, character.as_deref(), None).map_err(|e| anyhow::anyhow!(e))?;
    let (device, queue) = (&ctx.device, &ctx.queue);
    let target = crate::gpu::RenderTarget::new(device, width, height);
    // The full-resolution impostor sheets only when the impostor level alone is measured
    // (the mix draws from the far ones).
    let full = only.is_empty() || only.iter().any(|n| n == "impostor");
    let mut scene = if guests.is_empty() {
        CrowdScene::with_impostors(device, queue, &assets, assets.crowd_params(counts[0]), full)?
    } else {
        let all: Vec<&CrowdAssets> = std::iter::once(&assets).chain(&guests).collect();
        CrowdScene::mixed(device, queue, &all, &shares, counts[0], full)?
    };
    // Characters only: no ground, so each figure is the representation's own cost.
    scene.ground = false;
    let mut reps: Vec<(&str, LodPolicy)> = Level::ALL
        .iter()
        .filter(|l| scene.renderers.has(**l))
        .map(|l| (l.name(), LodPolicy::Only(*l)))
        .collect();
    reps.push((
        "mixed",
        LodPolicy::Mixed(LodDistances {
            texels: assets.resolution() as f32,
            ..Default::default()
        }),
    ));
    if let Some(unknown) = only.iter().find(|n| !reps.iter().any(|r| r.0 == n.as_str())) {
        anyhow::bail!(
            "--representations: '{unknown}' is not one of {}",
            reps.iter().map(|r| r.0).collect::<Vec<_>>().join(", ")
        );
    }
    if !only.is_empty() {
        reps.retain(|r| only.iter().any(|n| n == r.0));
    }
    if !json {
        eprintln!(
            "crowd rendering, {width}×{height} offscreen on {}, {frames} frames per figure",
            ctx.adapter_description()
        );
        // Each character's clips and what its agents do with them (a mixed crowd listed the
        // first pack's clips with every character's agents counted under them).
        use crate::crowd::Gait;
        let per_kind = scene.crowd.kind_counts();
        for (k, (a, share)) in std::iter::once(&assets).chain(&guests).zip(&shares).enumerate() {
            if !guests.is_empty() {
                eprintln!(
                    "  character {:<16} share {share:.2}: {} agents, {} tall, {}",
                    a.character.name,
                    per_kind.get(k).copied().unwrap_or(0),
                    crate::crowd::metres(a.size.height),
                    crate::import::plural(a.timeline.spans.len(), "clip")
                );
            }
            let indent = if guests.is_empty() { "  " } else { "    " };
            let gaits = crate::crowd::Gaits::new(&a.timeline.spans, a.timeline.fps);
            let n = scene.crowd.gait_counts_of(k);
            for (i, c) in a.timeline.spans.iter().enumerate() {
                let role = match gaits.role(i) {
                    Some(g @ (Gait::Walk | Gait::Run)) => format!("{} ({} agents)", g.name(), n[g as usize]),
                    Some(g) => g.name().to_string(),
                    None => "not played (does not loop)".into(),
                };
                eprintln!(
                    "{indent}clip {:<14} {:>4} frames, ground speed {:.3}/s: {role}",
                    c.name, c.frames, c.ground_speed
                );
            }
            if n[2] > 0 {
                eprintln!("{indent}{} agents standing", n[2]);
            }
        }
        if !guests.is_empty() {
            let heights: Vec<f32> = std::iter::once(&assets).chain(&guests).map(|a| a.size.height).collect();
            if let Some(note) = crate::crowd::size_spread_note(&heights) {
                eprintln!("warning: {note}");
            }
        }
    }
    let mut rows = Vec::new();
    for &count in counts {
        scene.respawn(assets.crowd_params(count));
        let camera = bench_camera(&scene.crowd);
        let mut per_rep = Vec::new();
        for (name, policy) in &reps {
            // The switch from the last representation measured starts a level cross-fade that
            // draws every character twice (in both levels) until it ends: end it first, so each
            // figure is this representation's own cost.
            // (The first frame starts the fades, the second, as long as a whole fade, ends them.)
            let settle = crate::crowd::LEVEL_FADE_SCALE * scene.crowd.params.fade_secs + 0.05;
            for dt in [1.0 / 60.0, settle] {
                scene.frame(device, queue, &target, &camera, policy, dt, wgpu::Color::BLACK);
            }
            // Wall time per frame, and the part of it the CPU spent before submitting
            // (simulation, selection, upload, encoding): the rest is waiting for the GPU.
            let mut run = |n: usize| {
                let t = std::time::Instant::now();
                let mut cpu = 0.0;
                let mut last = Default::default();
                for _ in 0..n {
                    // Ctrl+C (or SIGTERM) ends the run at the next frame.
                    if env.cancel.load(std::sync::atomic::Ordering::Relaxed) {
                        break;
                    }
                    let c = std::time::Instant::now();
                    last = scene.frame(device, queue, &target, &camera, policy, 1.0 / 60.0, wgpu::Color::BLACK);
                    cpu += c.elapsed().as_secs_f64();
                    let _ = device.poll(wgpu::PollType::Wait {
                        submission_index: None,
                        timeout: Some(std::time::Duration::from_secs(120)),
                    });
                }
                (t.elapsed().as_secs_f64(), cpu, last)
            };
            // A representation far too slow for the size (a million skinned meshes take
            // seconds a frame) is timed over fewer frames, so the run stays within about
            // TIMED_SECS per figure; the table says over how many.
            let (warm, _, _) = run(3);
            let timed = timed_frames(frames, warm / 3.0);
            let (secs, cpu, last) = run(timed);
            if env.cancel.load(std::sync::atomic::Ordering::Relaxed) {
                anyhow::bail!("cancelled");
            }
            let fps = timed as f64 / secs.max(1e-9);
            let cpu_ms = 1e3 * cpu / timed as f64;
            if !json {
                let fewer = if timed < frames {
                    format!(", {timed} of {frames} frames timed: too slow for more")
                } else {
                    String::new()
                };
                eprintln!(
                    "  {count:>7} {name:<11} {fps:>9.2} fps  ({} drawn, {} draw calls; CPU {cpu_ms:.1} ms a frame, GPU wait {:.1} ms{fewer})",
                    last.frame.visible,
                    last.draw_calls,
                    1e3 * (secs - cpu) / timed as f64,
                );
            }
            per_rep.push((name.to_string(), fps, cpu_ms, timed, last));
        }
        // One frame of the three-level mix on its ground, to look at (the character at its
        // real size, spacing and camera following it).
        scene.ground = true;
        let mix = LodPolicy::Mixed(LodDistances {
            texels: assets.resolution() as f32,
            ..Default::default()
        });
        // A first frame long enough to end the level cross-fades the switch of representation
        // started (the picture shows the mix settled, not half-dithered).
        let settle = crate::crowd::LEVEL_FADE_SCALE * scene.crowd.params.fade_secs + 0.05;
        scene.frame(device, queue, &target, &camera, &mix, 1.0 / 60.0, wgpu::Color::BLACK);
        scene.frame(device, queue, &target, &camera, &mix, settle, wgpu::Color::BLACK);
        scene.frame(device, queue, &target, &camera, &mix, 1.0 / 60.0, wgpu::Color::BLACK);
        let shot = target.read_color(device, queue)?;
        std::fs::create_dir_all(out)?;
        crate::safe_fs::write_png(&out.join(format!("crowd_{count}.png")), &shot).map_err(anyhow::Error::msg)?;
        scene.ground = false;
        let poly = per_rep.iter().find(|r| r.0 == "polypostor").map(|r| r.1);
        // GPU bytes per representation: the impostor level alone draws the full-resolution
        // sheets, the mix its far characters from the quarter-resolution ones.
        // Summed over every character of the crowd.
        let all = || std::iter::once(&scene.renderers).chain(&scene.guests);
        let sum = |f: &dyn Fn(&crate::gpu::CrowdRenderers) -> Option<u64>| -> Option<u64> {
            all().map(f).reduce(|a, b| Some(a? + b?)).flatten()
        };
        let far = sum(&|r| Some(r.far_impostor.as_ref().map_or(0, |p| p.gpu_bytes))).unwrap_or(0);
        // `None` where some character's full-resolution sheets were not loaded (no impostor
        // level asked for): not said, rather than said to be nothing.
        let full = sum(&|r| r.impostor.as_ref().map(|p| p.gpu_bytes));
        let poly_bytes = sum(&|r| r.polypostor.as_ref().map(|p| p.gpu_bytes));
        let mix_bytes = scene.gpu_bytes(Level::Skinned) + poly_bytes.unwrap_or(0) + far;
        let bytes_of = |name: &str| -> Option<u64> {
            match name {
                "impostor" => sum(&|r| r.impostor.as_ref().map(|p| p.gpu_bytes)),
                "mixed" => Some(mix_bytes),
                _ => Level::ALL
                    .iter()
                    .find(|l| l.name() == name)
                    .map(|l| scene.gpu_bytes(*l)),
            }
        };
        if !json && let Some(poly) = poly_bytes {
            eprintln!(
                "  {count:>7} GPU memory: mix {:.1} MB ({:.2}× the Polypostor's {:.1} MB; far impostors {:.1} MB{})",
                mix_bytes as f64 / 1e6,
                mix_bytes as f64 / poly.max(1) as f64,
                poly as f64 / 1e6,
                far as f64 / 1e6,
                full.map_or(String::new(), |b| format!(
                    ", full-resolution impostors {:.1} MB",
                    b as f64 / 1e6
                )),
            );
        }
        for (name, fps, cpu_ms, timed, last) in per_rep {
            rows.push(serde_json::json!({
                "representation": name,
                "count": count,
                "fps": fps,
                "ms_per_frame": 1e3 / fps,
                "cpu_ms_per_frame": cpu_ms,
                "frames_timed": timed,
                "polypostor_over_this": poly.map(|p| p / fps),
                "visible": last.frame.visible,
                "draw_calls": last.draw_calls,
                "gpu_bytes": bytes_of(&name),
            }));
        }
    }
    drop(temp);
    let names: Vec<&str> = reps.iter().map(|r| r.0).collect();
    std::fs::create_dir_all(out)?;
    crate::safe_fs::write_json(
        &out.join("crowd_fps.json"),
        serde_json::json!({ "adapter": ctx.adapter_description(), "width": width, "height": height, "rows": rows }),
    )
    .map_err(anyhow::Error::msg)?;
    let fps_of = |count: usize, name: &str| {
        rows.iter()
            .find(|r| r["count"] == count && r["representation"] == name)
            .and_then(|r| r["fps"].as_f64())
            .unwrap_or(f64::NAN)
    };
    crate::plot::bar_chart(
        &out.join("crowd_fps.png"),
        &format!(
            "Frames per second by crowd size ({width}×{height}, {})",
            ctx.adapter_description().split(" (").next().unwrap_or("")
        ),
        "frames per second (log scale)",
        &counts.iter().map(|c| format!("{c} characters")).collect::<Vec<_>>(),
        &names
            .iter()
            .map(|n| (n.to_string(), counts.iter().map(|&c| fps_of(c, n)).collect()))
            .collect::<Vec<_>>(),
        true,
    )
    .map_err(|e| anyhow::anyhow!(e))?;
    if json {
        say!(t, "{}", serde_json::to_string_pretty(&rows)?);
        return Ok(t);
    }
    say!(t, "frames per second ({width}×{height}, {})", ctx.adapter_description());
    say_part!(t, "{:>8}", "count");
    for n in &names {
        say_part!(t, " {n:>11}");
    }
    say!(t, "");
    for &count in counts {
        say_part!(t, "{count:>8}");
        for n in &names {
            say_part!(t, " {:>11.2}", fps_of(count, n));
        }
        say!(t, "");
    }
    say!(
        t,
        "polypostor fps ÷ each representation's fps (>1: polypostors are faster)"
    );
    for &count in counts {
        say_part!(t, "{count:>8}");
        for n in &names {
            let r = rows
                .iter()
                .find(|r| r["count"] == count && r["representation"] == *n)
                .and_then(|r| r["polypostor_over_this"].as_f64());
            match r {
                Some(r) => say_part!(t, " {r:>10.2}×"),
                None => say_part!(t, " {:>11}", "-"),
            }
        }
        say!(t, "");
    }
    say!(t, "wrote crowd_fps.png and crowd_fps.json in {}", out.display());
    Ok(t)
}

/// `bench stability`: the mix's temporal stability with cuts and with cross-fades.
pub fn bench_stability(
    pack: &Path,
    character: Option<PathBuf>,
    frames: usize,
    size: u32,
    json: bool,
) -> anyhow::Result<String> {
    let mut t = String::new();
    use crate::scene::{CrowdAssets, temporal_stability};
    if !(2..=10_000).contains(&frames) || !(16..=4096).contains(&size) {
        anyhow::bail!("--frames must be 2 to 10,000 and --size 16 to 4096");
    }
    let ctx = crate::gpu::GpuContext::from_env()?;
    crate::limits::check_render_size(&ctx.device, size, size, "--size")?;
    let assets = CrowdAssets::load(pack, character.as_deref(), None).map_err(|e| anyhow::anyhow!(e))?;
    let cut = temporal_stability(&ctx.device, &ctx.queue, &assets, 0.0, frames, size)?;
    let faded = temporal_stability(&ctx.device, &ctx.queue, &assets, 0.25, frames, size)?;
    if json {
        say!(
            t,
            "{}",
            serde_json::json!({ "cut": cut, "cross_faded": faded, "adapter": ctx.adapter_description() })
        );
        return Ok(t);
    }
    say!(
        t,
        "temporal stability of the mix ({frames} frames at 60 Hz, {size}², {}): largest frame-to-frame change per covered pixel",
        ctx.adapter_description()
    );
    say!(t, "  switches        mix       skinned   ratio   frames fading");
    for (name, s) in [("cut", &cut), ("cross-faded", &faded)] {
        say!(
            t,
            "  {name:<12} {:>9.4} {:>9.4} {:>7.2}× {:>6}",
            s.mix_max,
            s.skinned_max,
            s.ratio,
            s.fading_frames
        );
    }
    Ok(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slow_representations_are_timed_over_fewer_frames() {
        assert_eq!(timed_frames(10, 0.016), 10);
        assert_eq!(timed_frames(10, 6.0), 10, "exactly the limit");
        assert_eq!(timed_frames(10, 7.5), 8);
        assert_eq!(timed_frames(10, 45.0), 1);
        assert_eq!(timed_frames(10, 600.0), 1, "never none");
        assert_eq!(timed_frames(10, 0.0), 10);
        assert_eq!(timed_frames(10, f64::NAN), 10);
        assert_eq!(timed_frames(1, 100.0), 1);
    }
}
