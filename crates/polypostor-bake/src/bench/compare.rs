//! `polypostor compare`.

use std::path::{Path, PathBuf};

use super::*;

/// `compare`: memory and error of every representation in a baked folder against the real
/// mesh; writes the plots, the quality sheet and `compare.json` into `out`.
pub fn compare(
    dir: &Path,
    character: Option<&Path>,
    views: usize,
    out: Option<PathBuf>,
    json: bool,
    progress: &dyn Fn(usize, usize),
) -> anyhow::Result<String> {
    use crate::reps::compare;
    let mut t = String::new();
    let out = out.unwrap_or_else(|| dir.join("compare"));
    check_output_files(
        &out,
        &["memory.png", "error.png", "ssim.png", "quality.png", "compare.json"],
    )?;
    let assets = crate::scene::CrowdAssets::load(dir, character, None).map_err(|e| anyhow::anyhow!(e))?;
    let memory = compare::memory(&assets);
    let ctx = crate::gpu::GpuContext::from_env()?;
    let total_views = assets.view_directions().len();
    let chosen = compare::chosen_views(total_views, views);
    let errors = compare::errors(&ctx, &assets, &chosen, progress)?;
    // The quality sheet: the Polypostor's worst views and a spread of others.
    let rows = crate::reps::quality::sheet_rows(&errors, 3, 3);
    let (sheet, _) = {
        let mut renders = compare::Renders::new(&ctx, &assets)?;
        let title = format!("{}: PSNR / SSIM against the real mesh", assets.character.name);
        crate::reps::quality::render_sheet(&mut renders, &title, &rows, assets.resolution().min(256))?
    };
    std::fs::create_dir_all(&out)?;
    crate::safe_fs::write_png(&out.join("quality.png"), &sheet).map_err(anyhow::Error::msg)?;
    let names: Vec<String> = memory.iter().map(|m| m.representation.clone()).collect();
    let mb = |f: &dyn Fn(&compare::MemoryRow) -> u64| memory.iter().map(|m| f(m) as f64 / 1e6).collect::<Vec<f64>>();
    crate::plot::bar_chart(
        &out.join("memory.png"),
        "Memory per character, one clip, all views",
        "MB (log scale)",
        &names,
        &[
            ("uncompressed".into(), mb(&|m| m.bytes.total)),
            ("block-compressed (BC3)".into(), mb(&|m| m.bytes.total_bc)),
        ],
        true,
    )
    .map_err(|e| anyhow::anyhow!(e))?;
    let series: Vec<(String, Vec<(f64, f64)>)> = errors
        .iter()
        .map(|e| {
            (
                e.representation.clone(),
                e.samples
                    .iter()
                    .map(|s| (s.time_frames as f64, s.psnr.min(60.0)))
                    .collect(),
            )
        })
        .collect();
    crate::plot::line_chart(
        &out.join("error.png"),
        &format!(
            "Error against the real mesh ({} views; x.5 = between baked frames)",
            chosen.len()
        ),
        "time (frames)",
        "PSNR (dB, capped at 60)",
        &series,
    )
    .map_err(|e| anyhow::anyhow!(e))?;
    let ssim_series: Vec<(String, Vec<(f64, f64)>)> = errors
        .iter()
        .map(|e| {
            (
                e.representation.clone(),
                e.samples.iter().map(|s| (s.time_frames as f64, s.ssim)).collect(),
            )
        })
        .collect();
    crate::plot::line_chart(
        &out.join("ssim.png"),
        &format!(
            "Structural similarity to the real mesh ({} views; x.5 = between baked frames)",
            chosen.len()
        ),
        "time (frames)",
        "SSIM (1 = identical)",
        &ssim_series,
    )
    .map_err(|e| anyhow::anyhow!(e))?;
    let report = serde_json::json!({
        "folder": dir.display().to_string(),
        "character": assets.character.name,
        "views_compared": chosen.len(),
        "views_baked": total_views,
        "memory": memory,
        "error": errors,
        "plots": [
            out.join("memory.png").display().to_string(),
            out.join("error.png").display().to_string(),
            out.join("ssim.png").display().to_string(),
            out.join("quality.png").display().to_string(),
        ],
        "quality_sheet_rows": rows.iter().map(|r| serde_json::json!({"view": r.view, "time_frames": r.time, "why": r.why})).collect::<Vec<_>>(),
    });
    crate::safe_fs::write_json(&out.join("compare.json"), report.clone()).map_err(anyhow::Error::msg)?;
    if json {
        say!(t, "{}", serde_json::to_string_pretty(&report)?);
        return Ok(t);
    }
    say!(
        t,
        "memory (one character, {}, all {total_views} views)",
        match assets.timeline.spans.len() {
            1 => "one clip".to_string(),
            n => format!("{n} clips"),
        }
    );
    say!(
        t,
        "  {:<11} {:>10} {:>10} {:>12} {:>14}",
        "",
        "textures",
        "geometry",
        "total",
        "block-compr."
    );
    for m in &memory {
        say!(
            t,
            "  {:<11} {:>10} {:>10} {:>12} {:>14}   {}",
            m.representation,
            human_bytes(m.bytes.texture),
            human_bytes(m.bytes.geometry),
            human_bytes(m.bytes.total),
            human_bytes(m.bytes.total_bc),
            m.vs_polypostor
                .map_or(String::new(), |r| format!("{r:.1}× the polypostor"))
        );
    }
    say!(
        t,
        "error against the real mesh over {}: mean PSNR and SSIM (higher is better)",
        crate::import::plural(chosen.len(), "view")
    );
    say!(
        t,
        "  {:<11} {:>10} {:>12} {:>10}   {:>6} {:>9} {:>8}   worst view",
        "",
        "all",
        "on frames",
        "between",
        "SSIM",
        "on frames",
        "between"
    );
    for e in &errors {
        say!(
            t,
            "  {:<11} {:>7.2} dB {:>9.2} dB {:>7.2} dB   {:>6.3} {:>9.3} {:>8.3}   {} ({:.1} dB)",
            e.representation,
            e.mean_psnr,
            e.mean_psnr_on_frames,
            e.mean_psnr_between_frames,
            e.mean_ssim,
            e.mean_ssim_on_frames,
            e.mean_ssim_between_frames,
            e.worst_view,
            e.worst_view_psnr
        );
    }
    say_part!(
        t,
        "silhouette agreement (IoU of the covered pixels, all display times):"
    );
    for e in &errors {
        say_part!(t, " {} {:.3}", e.representation, e.mean_silhouette_iou);
    }
    say!(t, "");
    if let Some(note) = errors
        .first()
        .and_then(|e| crate::bake::pipeline::dark_note(e.truth_brightness))
    {
        say!(t, "note: {note}");
    }
    // A whole-character pack: each clip's error per representation.
    if assets.timeline.spans.len() > 1 {
        say!(t, "per clip: mean PSNR dB / SSIM");
        say_part!(t, "  {:<11}", "");
        for c in &assets.timeline.spans {
            say_part!(t, " {:>16}", c.name);
        }
        say!(t, "");
        for e in &errors {
            say_part!(t, "  {:<11}", e.representation);
            for c in &e.per_clip {
                say_part!(t, " {:>9.2} / {:.3}", c.psnr, c.ssim);
            }
            say!(t, "");
        }
    }
    say!(
        t,
        "wrote memory.png, error.png, ssim.png, quality.png and compare.json in {}",
        out.display()
    );
    Ok(t)
}
