//! `polypostor bench bake`.

use std::path::{Path, PathBuf};

use super::*;

/// The stages of `bench bake`'s table: a column name and the `cpu_seconds` keys it sums
/// (`*` matches any job: `*/trace` is tracing wherever it ran).
const BENCH_STAGES: [(&str, &[&str]); 14] = [
    ("render", &["render", "prepare"]),
    ("key frame", &["key frame", "key frame/*"]),
    ("trace", &["part fit/trace", "key choice/trace"]),
    ("fit", &["part fit", "part fit/fold rescue", "part fit/respread"]),
    ("restarts", &["part fit/restart"]),
    (
        "keys",
        &[
            "key choice",
            "key choice/restart",
            "key choice/fold rescue",
            "key choice/respread",
            "key choice/simplify",
        ],
    ),
    ("simplify", &["part fit/simplify"]),
    ("sub-pixel", &["part fit/subpixel", "key choice/subpixel"]),
    (
        "interior",
        &["part fit/interior vertices", "key choice/interior vertices"],
    ),
    ("measure", &["measure", "composite"]),
    ("order", &["order"]),
    ("atlas", &["atlas"]),
    ("encode+write", &["encode", "write"]),
    ("other reps", &["other representations"]),
];

/// The count in `report.json`'s `cpu_counts` of the triangle costs the fit evaluated.
const TRIANGLE_COSTS: &str = crate::bake::part_fit::TRIANGLE_COSTS_COUNT;

/// CPU seconds of one column of [`BENCH_STAGES`].
fn stage_sum(cpu: &std::collections::BTreeMap<String, f64>, keys: &[&str]) -> f64 {
    cpu.iter()
        .filter(|(k, _)| {
            keys.iter().any(|pat| match pat.strip_suffix("/*") {
                Some(job) => k.starts_with(&format!("{job}/")),
                None => k.as_str() == *pat,
            })
        })
        .map(|(_, v)| v)
        .sum()
}

/// `bench bake`: each character baked at default settings, its time per stage, and the fast
/// mode's gap to the exact DP on a few views.
pub fn bench_bake(
    env: &Env,
    mut inputs: Vec<PathBuf>,
    gap_views: usize,
    representation: &str,
    out: &Path,
    json: bool,
) -> anyhow::Result<String> {
    use crate::bake::report::Report;
    let mut t = String::new();
    if inputs.is_empty() {
        inputs.push(env.repo_root.join(crate::project::DEFAULT_PROJECT_DIR));
        let shared = env.repo_root.join("../shared/assets/characters");
        let mut found: Vec<PathBuf> = std::fs::read_dir(&shared)
            .map(|d| {
                d.flatten()
                    .map(|e| e.path())
                    .filter(|p| {
                        p.extension()
                            .is_some_and(|e| e.eq_ignore_ascii_case("glb") || e.eq_ignore_ascii_case("gltf"))
                    })
                    .collect()
            })
            .unwrap_or_default();
        found.sort();
        if found.is_empty() {
            eprintln!(
                "no characters in {} (only the default is benchmarked)",
                shared.display()
            );
        }
        inputs.extend(found);
    }
    // Every input must resolve before the first (long) bake starts.
    for input in &inputs {
        crate::job::BakeInput::resolve(input, None).map_err(|e| anyhow::anyhow!("{}: {e}", input.display()))?;
    }
    let ctx = crate::gpu::GpuContext::from_env()?;
    let mut rows = Vec::new();
    for input in &inputs {
        let tmp = crate::safe_fs::TempDir::new("polypostor-bench")?;
        let pack = tmp.path().join("pack");
        env.bake(&ctx, input, &pack, representation)?;
        let report: Report = serde_json::from_str(&std::fs::read_to_string(pack.join("report.json"))?)?;
        let gap = if gap_views > 0 {
            let input = crate::job::BakeInput::resolve(input, None).map_err(anyhow::Error::msg)?;
            let c = crate::import_path_with(&input.character_path, crate::ImportOptions { up: input.up })
                .map_err(|e| anyhow::anyhow!("{}: {e}", input.character_path.display()))?;
            let (seg, _) = input.segmentation(&c);
            let (caps, _) = input.caps_and_overrides();
            let options = crate::bake::pipeline::BakeOptions {
                clip: report.settings.clip.as_deref().and_then(|n| c.find_clip(n)),
                ..Default::default()
            };
            eprintln!("fitting {gap_views} views of {} both ways (fast, exact DP)…", c.name);
            let g = crate::bake::gap::measure(&ctx, &c, &seg, &caps, &options, report.key_frame, gap_views, env.cancel);
            match g {
                Ok(g) => Some(g),
                Err(e) => return Err(e.into()),
            }
        } else {
            None
        };
        let name = input
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        rows.push((name, report, gap));
    }
    let cpu_total = |r: &Report| r.cpu_seconds.values().sum::<f64>();
    let value = serde_json::json!({
        "adapter": ctx.adapter_description(),
        "threads": rayon::current_num_threads(),
        "characters": rows.iter().map(|(name, r, gap)| serde_json::json!({
            "character": name,
            "wall_seconds": r.seconds_total,
            "stage_seconds": r.stage_seconds,
            "cpu_seconds": r.cpu_seconds,
            "cpu_counts": r.cpu_counts,
            "table_cpu_seconds": BENCH_STAGES.iter().map(|(col, keys)| (col.to_string(), stage_sum(&r.cpu_seconds, keys))).collect::<std::collections::BTreeMap<_, _>>(),
            "views": r.settings.views,
            "frames": r.views.first().map_or(0, |v| v.psnr.len()),
            "mean_psnr": r.mean_psnr,
            "fit_gap": gap,
            "fit_gap_percent": gap.as_ref().map(|g| g.percent()),
        })).collect::<Vec<_>>(),
    });
    std::fs::create_dir_all(out)?;
    std::fs::write(out.join("bench_bake.json"), serde_json::to_string_pretty(&value)?)?;
    if json {
        say!(t, "{}", serde_json::to_string_pretty(&value)?);
        return Ok(t);
    }
    say!(
        t,
        "bake at default settings on {} ({} threads); wall seconds, then CPU seconds per stage (summed over threads)",
        ctx.adapter_description(),
        rayon::current_num_threads()
    );
    say_part!(
        t,
        "{:<18} {:>6} {:>7} {:>6} {:>8}",
        "character",
        "frames",
        "wall s",
        "CPU s",
        "M costs"
    );
    for (col, _) in BENCH_STAGES {
        say_part!(t, " {col:>9}");
    }
    say!(t, " {:>8} {:>10}", "other", "fast−exact");
    for (name, r, gap) in &rows {
        let total = cpu_total(r);
        // The fit's unit of work, the same on any host however busy: triangle costs
        // evaluated, in millions.
        let costs = r.cpu_counts.get(TRIANGLE_COSTS).map_or(0.0, |&n| n as f64 / 1e6);
        say_part!(
            t,
            "{:<18} {:>6} {:>7.1} {:>6.1} {:>8.1}",
            name,
            r.views.first().map_or(0, |v| v.psnr.len()),
            r.seconds_total,
            total,
            costs
        );
        let mut listed = 0.0;
        for (_, keys) in BENCH_STAGES {
            let s = stage_sum(&r.cpu_seconds, keys);
            listed += s;
            say_part!(t, " {s:>9.1}");
        }
        let gap = gap
            .as_ref()
            .map_or("—".to_string(), |g| format!("{:+.2} %", g.percent()));
        say!(t, " {:>8.1} {:>10}", (total - listed).max(0.0), gap);
    }
    for (name, _, gap) in &rows {
        if let Some(g) = gap {
            say!(
                t,
                "{name}: views {:?}, {} part-frames, fast {:.1} vs exact {:.1} ({:+.2} %), optimum found in {} ({:.0} %); fit time fast {:.1} s, exact {:.1} s",
                g.views,
                g.part_frames,
                g.fast,
                g.exact,
                g.percent(),
                g.optimal,
                100.0 * g.optimal as f64 / g.part_frames.max(1) as f64,
                g.fast_secs,
                g.exact_secs
            );
        }
    }
    say!(t, "figures in {}", out.join("bench_bake.json").display());
    Ok(t)
}
