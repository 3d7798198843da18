//! `polypostor`: the editor (no arguments, or a project / glTF path) and the command-line tools.

mod editor;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "polypostor",
    version,
    about = "Polypostor Studio: crowd level-of-detail assets from skinned glTF characters"
)]
#[command(args_conflicts_with_subcommands = true)]
struct Cli {
    /// A project (folder or project.json) or a .glb/.gltf to open in the editor.
    /// Default: projects/default.
    path: Option<PathBuf>,
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Print a character summary: vertices, triangles, joints, clips, textures, warnings.
    Inspect {
        /// A .glb or .gltf file.
        file: PathBuf,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Render a character headless to a PNG (colour, or normals with --normals).
    Render {
        /// A .glb or .gltf file.
        file: PathBuf,
        /// Output PNG.
        #[arg(long, short)]
        out: PathBuf,
        /// Clip name (default: the first clip).
        #[arg(long)]
        clip: Option<String>,
        /// Time in seconds within the clip.
        #[arg(long, default_value_t = 0.0)]
        time: f32,
        /// Image size in pixels (square).
        #[arg(long, default_value_t = 512)]
        size: u32,
        /// Camera yaw in degrees (0 = from the front, +Z).
        #[arg(long, default_value_t = 30.0)]
        yaw: f32,
        /// Camera pitch in degrees.
        #[arg(long, default_value_t = 10.0)]
        pitch: f32,
        /// Write the view-space normal image instead of colour.
        #[arg(long)]
        normals: bool,
        /// Unlit base colour instead of lit shading.
        #[arg(long)]
        unlit: bool,
    },
    /// Bake a character into a Polypostor pack (with report.json).
    Bake(BakeArgs),
    /// Benchmarks (figures for the README).
    Bench {
        #[command(subcommand)]
        what: BenchWhat,
    },
    /// Compare every representation in a folder baked with --representation all: memory
    /// (uncompressed and block-compressed) and error against the real mesh at the baked
    /// frames and between them, as tables and PNG plots.
    Compare {
        /// A folder holding a pack and/or representations.json.
        pack_dir: PathBuf,
        /// The character it was baked from (default: the path the folder names).
        #[arg(long)]
        character: Option<PathBuf>,
        /// Views to measure the error from, spread evenly (0: every view).
        #[arg(long, default_value_t = 24)]
        views: usize,
        /// Folder for the PNG plots and compare.json (default: <PACK_DIR>/compare).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Print one JSON object instead of tables.
        #[arg(long)]
        json: bool,
    },
    /// Regenerate the built-in default character (.glb).
    GenerateDefault {
        /// Output path (default: assets/characters/default_humanoid.glb).
        #[arg(long, short)]
        out: Option<PathBuf>,
    },
}

#[derive(clap::Subcommand)]
enum BenchWhat {
    /// Bakes each character at default settings (137 views, 10 Hz, 128²) one after the other
    /// and prints where the time went, stage by stage, and how far the fast fitting mode lands
    /// from the exact DP on a few views.
    Bake {
        /// Characters (.glb/.gltf) or projects (default: the default project and every
        /// character in ../shared/assets/characters).
        inputs: Vec<PathBuf>,
        /// Views per character on which to fit every part both ways (fast and exact DP; the
        /// exact DP takes about a second per part and frame). 0 skips the comparison.
        #[arg(long, default_value_t = 2)]
        gap_views: usize,
        /// Representations to bake (as `bake --representation`).
        #[arg(long, default_value = "polypostor")]
        representation: String,
        /// Folder for bench_bake.json.
        #[arg(long, default_value = "bench-bake")]
        out: PathBuf,
        /// Print one JSON object instead of tables.
        #[arg(long)]
        json: bool,
    },
    /// Frames per second of every representation at every crowd size, rendered offscreen in
    /// one run (the Polypostor paper's Figure 7 experiment).
    Crowd {
        /// Crowd sizes, comma-separated.
        #[arg(long, default_value = "2000,5000,10000,20000", value_delimiter = ',')]
        counts: Vec<usize>,
        /// Frames to time per representation and size (after 3 warm-up frames).
        #[arg(long, default_value_t = 10)]
        frames: usize,
        /// A folder baked with --representation all (default: bake the default character
        /// into a temporary folder first, about a minute).
        #[arg(long)]
        pack: Option<PathBuf>,
        /// The character the pack was baked from (default: the path the pack names).
        #[arg(long)]
        character: Option<PathBuf>,
        /// Only these representations (comma-separated; default: every one baked, and mixed).
        #[arg(long, value_delimiter = ',')]
        representations: Vec<String>,
        /// Another baked folder (any character) sharing the crowd; repeat for more (at most 7).
        #[arg(long = "with")]
        with: Vec<PathBuf>,
        /// Shares of the crowd, comma-separated: the pack's character first, then each
        /// --with (default: equal).
        #[arg(long, value_delimiter = ',')]
        shares: Vec<f32>,
        /// Folder for the plot (crowd_fps.png) and the figures (crowd_fps.json).
        #[arg(long, default_value = "bench-crowd")]
        out: PathBuf,
        /// Offscreen image size.
        #[arg(long, default_value_t = 1280)]
        width: u32,
        #[arg(long, default_value_t = 720)]
        height: u32,
        /// Print a JSON list instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Temporal stability of the three-level mix: the largest frame-to-frame image change of
    /// one still character while the camera orbits it through baked views and backs away
    /// through the Polypostor → impostor switch, relative to the skinned mesh filmed the same
    /// way; with level and view switches cut, then cross-faded.
    Stability {
        /// A folder baked with --representation all.
        #[arg(long)]
        pack: PathBuf,
        /// The character the pack was baked from (default: the path the pack names).
        #[arg(long)]
        character: Option<PathBuf>,
        /// Frames along the camera path (60 a second).
        #[arg(long, default_value_t = 240)]
        frames: usize,
        /// Offscreen image side (pixels).
        #[arg(long, default_value_t = 512)]
        size: u32,
        /// Print one JSON object instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// CPU work per crowd frame on one thread: simulation, then culling, level of detail,
    /// view and frame choice and instance records.
    Sim {
        /// Agents.
        #[arg(long, default_value_t = 20_000)]
        agents: usize,
        /// Frames to time (after 30 warm-up frames).
        #[arg(long, default_value_t = 300)]
        frames: usize,
        /// Two characters with clip tables: people walking, running and standing (70 %) and
        /// a long, low four-legged one with its own clips and views (30 %).
        #[arg(long)]
        mixed: bool,
        /// Print one JSON object instead of a table.
        #[arg(long)]
        json: bool,
    },
}

/// The repository root: the current folder if it holds the project layout, else the
/// folder this binary was built from.
pub fn repo_root() -> PathBuf {
    let cwd = std::env::current_dir().unwrap_or_else(|_| PathBuf::from("."));
    if cwd.join(polypostor::project::DEFAULT_PROJECT_DIR).is_dir() {
        return cwd;
    }
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Set by Ctrl-C (or SIGTERM): a running bake stops at its next check.
static CANCEL: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);
/// A bake is running and will stop on [`CANCEL`] (else an interrupt exits at once).
static BAKING: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// The command-line tools, unlike the editor, behave as Unix filters: a closed pipe ends the
/// process quietly (`inspect --json | head`), and an interrupt removes the temporary folders
/// before exiting (a bake finishes cancelling first).
fn cli_process_setup() {
    #[cfg(unix)]
    // SAFETY: restoring the default disposition of SIGPIPE, before any thread writes output.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let _ = ctrlc::set_handler(|| {
        use std::sync::atomic::Ordering;
        if BAKING.load(Ordering::Relaxed) && !CANCEL.swap(true, Ordering::Relaxed) {
            eprintln!("\ncancelling…");
            return;
        }
        polypostor::safe_fs::remove_temp_dirs();
        std::process::exit(130);
    });
}

/// A bake that was cancelled: not an error, exit 130 quietly.
#[derive(Debug)]
struct Cancelled;

impl std::fmt::Display for Cancelled {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("cancelled: nothing was written")
    }
}

impl std::error::Error for Cancelled {}

fn main() -> ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn,polypostor=info")).init();
    let cli = Cli::parse();
    if cli.command.is_some() {
        cli_process_setup();
    }
    let result = match cli.command {
        Some(Command::Inspect { file, json }) => inspect(&file, json),
        Some(Command::Render {
            file,
            out,
            clip,
            time,
            size,
            yaw,
            pitch,
            normals,
            unlit,
        }) => render(&file, &out, clip.as_deref(), time, size, yaw, pitch, normals, unlit),
        Some(Command::GenerateDefault { out }) => generate_default(out),
        Some(Command::Compare {
            pack_dir,
            character,
            views,
            out,
            json,
        }) => compare_cmd(&pack_dir, character.as_deref(), views, out, json),
        Some(Command::Bake(args)) => bake_cmd(args),
        Some(Command::Bench {
            what:
                BenchWhat::Sim {
                    agents,
                    frames,
                    mixed,
                    json,
                },
        }) => bench_sim(agents, frames, mixed, json),
        Some(Command::Bench {
            what:
                BenchWhat::Stability {
                    pack,
                    character,
                    frames,
                    size,
                    json,
                },
        }) => bench_stability(&pack, character, frames, size, json),
        Some(Command::Bench {
            what:
                BenchWhat::Bake {
                    inputs,
                    gap_views,
                    representation,
                    out,
                    json,
                },
        }) => bench_bake(inputs, gap_views, &representation, &out, json),
        Some(Command::Bench {
            what:
                BenchWhat::Crowd {
                    counts,
                    frames,
                    pack,
                    character,
                    representations,
                    with,
                    shares,
                    out,
                    width,
                    height,
                    json,
                },
        }) => bench_crowd(
            &counts,
            frames,
            pack,
            character,
            &representations,
            (&with, &shares),
            &out,
            (width, height),
            json,
        ),
        None => {
            let path = cli
                .path
                .unwrap_or_else(|| repo_root().join(polypostor::project::DEFAULT_PROJECT_DIR));
            editor::run(path)
        }
    };
    // Temporary folders (a benchmark's bake) go with the process.
    polypostor::safe_fs::remove_temp_dirs();
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.is::<Cancelled>() => {
            eprintln!("{e}");
            ExitCode::from(130)
        }
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(1)
        }
    }
}

fn inspect(file: &Path, json: bool) -> anyhow::Result<()> {
    match polypostor::import_path(file) {
        Ok(c) => {
            let s = polypostor::summary::Summary::of(&c);
            // How each clip moves (what a crowd does with it).
            let motion: Vec<(String, polypostor::timeline::ClipMotion)> = (0..c.clips.len())
                .map(|i| {
                    (
                        c.clips[i].name.clone(),
                        polypostor::timeline::measure_motion(&c, Some(i)),
                    )
                })
                .collect();
            if json {
                let mut v = serde_json::to_value(&s)?;
                v["clip_motion"] = motion
                    .iter()
                    .map(|(name, m)| {
                        serde_json::json!({
                            "name": name,
                            "ground_speed": m.ground_speed(),
                            "loops": m.loops(),
                            "locomotion": m.is_locomotion(),
                            "closure": m.closure,
                            "contact": m.contact,
                            "spread": m.spread,
                        })
                    })
                    .collect();
                println!("{}", serde_json::to_string_pretty(&v)?);
            } else {
                print!("{}", s.to_text());
                if !motion.is_empty() {
                    println!("clip motion (ground speed in scene units/s; closure, contact and spread as measured)");
                    for (name, m) in &motion {
                        println!(
                            "  {:<24} {:>8.3}/s  {:<16} closure {:.3}  contact {:.2}  spread {:.2}",
                            name,
                            m.ground_speed(),
                            if m.is_locomotion() {
                                "locomotion"
                            } else if m.loops() {
                                "loops in place"
                            } else {
                                "does not loop"
                            },
                            m.closure,
                            m.contact,
                            m.spread
                        );
                    }
                }
            }
            Ok(())
        }
        Err(e) => {
            if json {
                println!(
                    "{}",
                    serde_json::json!({ "error": e.to_string(), "file": file.display().to_string() })
                );
            }
            Err(anyhow::anyhow!("{}: {e}", file.display()))
        }
    }
}

#[allow(clippy::too_many_arguments)]
fn render(
    file: &Path,
    out: &Path,
    clip: Option<&str>,
    time: f32,
    size: u32,
    yaw: f32,
    pitch: f32,
    normals: bool,
    unlit: bool,
) -> anyhow::Result<()> {
    use polypostor::animation::{Pose, clip_bounds};
    use polypostor::gpu::*;
    let c = polypostor::import_path(file).map_err(|e| anyhow::anyhow!("{}: {e}", file.display()))?;
    let clip_index = match clip {
        Some(name) => Some(
            c.find_clip(name)
                .ok_or_else(|| anyhow::anyhow!("no clip named '{name}'"))?,
        ),
        None => (!c.clips.is_empty()).then_some(0),
    };
    polypostor::safe_fs::check_output_file(out, polypostor::safe_fs::OutputFile::Png).map_err(anyhow::Error::msg)?;
    if !time.is_finite() || !yaw.is_finite() || !pitch.is_finite() {
        anyhow::bail!("--time, --yaw and --pitch must be finite numbers");
    }
    let ctx = GpuContext::from_env()?;
    polypostor::limits::check_render_size(&ctx.device, size, size, "--size")?;
    eprintln!("adapter: {}", ctx.adapter_description());
    let renderer = CharacterRenderer::new(&ctx.device);
    let mut gpu = GpuCharacter::new(&renderer, &ctx.device, &ctx.queue, &c);
    let (min, max) = clip_bounds(&c, clip_index, 16);
    let center = (min + max) * 0.5;
    let radius = ((max - min) * 0.5).length().max(1e-3);
    let fov = 35f32.to_radians();
    let camera = Camera::orbit(
        center,
        yaw.to_radians(),
        pitch.to_radians(),
        radius / (fov * 0.5).sin() * 1.05,
        fov,
    );
    let target = RenderTarget::new(&ctx.device, size, size);
    let pose = Pose::sample_index(&c, clip_index, time);
    let options = DrawOptions {
        shading: if unlit { Shading::Unlit } else { Shading::Lit },
        clear_color: [0.02, 0.02, 0.025, 1.0],
        grid: false,
    };
    renderer.render(
        &ctx.device,
        &ctx.queue,
        &target,
        &mut gpu,
        &c,
        &pose,
        SkinningMode::Gpu,
        &camera,
        &options,
    );
    let img = if normals {
        target.read_normal(&ctx.device, &ctx.queue)?
    } else {
        target.read_color(&ctx.device, &ctx.queue)?
    };
    polypostor::safe_fs::write_png(out, &img).map_err(anyhow::Error::msg)?;
    eprintln!("wrote {}", out.display());
    Ok(())
}

fn generate_default(out: Option<PathBuf>) -> anyhow::Result<()> {
    let out = out.unwrap_or_else(|| polypostor::default_character::default_path(&repo_root()));
    polypostor::safe_fs::check_output_file(&out, polypostor::safe_fs::OutputFile::Glb).map_err(anyhow::Error::msg)?;
    let bytes = polypostor::default_character::generate_glb();
    polypostor::safe_fs::write_file_atomic(&out, &bytes).map_err(anyhow::Error::msg)?;
    eprintln!("wrote {} ({} bytes)", out.display(), bytes.len());
    Ok(())
}

#[derive(clap::Args)]
struct BakeArgs {
    /// A .glb/.gltf, or a project (folder or project.json).
    input: PathBuf,
    /// Project whose segmentation and cap colours to use (when INPUT is a glTF).
    #[arg(long)]
    project: Option<PathBuf>,
    /// Clip name (default: the project's clip, else Walk, else the first).
    #[arg(long, conflicts_with = "clips")]
    clip: Option<String>,
    /// Several clips in one whole-character pack, comma-separated (`Walk,Run,Idle`), or
    /// `all`: one set of key images for all of them (default: the project's clip set when it
    /// has one, else one clip as --clip).
    #[arg(long)]
    clips: Option<String>,
    /// Output pack folder (default: <input>-<clip>.pack in the current folder).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Number of viewpoints (default: the project's bake settings, else 137; so for every
    /// setting below).
    #[arg(long)]
    views: Option<usize>,
    /// Part image resolution (pixels, square; default 128).
    #[arg(long)]
    resolution: Option<u32>,
    /// Clip sampling rate (frames per second; default 10).
    #[arg(long)]
    fps: Option<f32>,
    /// Texture key-frame: a frame number, or auto.
    #[arg(long, default_value = "auto")]
    key_frame: String,
    /// Exact dynamic programme over every target vertex (slow) instead of the fast mode.
    #[arg(long)]
    exhaustive: bool,
    /// Let fitted triangles turn inside out (the paper's unconstrained objective); by default
    /// a triangle may degenerate but not fold over.
    #[arg(long)]
    allow_folds: bool,
    /// The paper's objective: the fit charges only what the source texture maps onto, not the
    /// target coverage the mapped polygon leaves out.
    #[arg(long)]
    paper_objective: bool,
    /// Fast mode without restarts from a coarse global solution: about twice as fast on
    /// characters with thin limbs, about 3 % further from the exact optimum.
    #[arg(long, conflicts_with = "exhaustive")]
    no_restarts: bool,
    /// Most key images per part and view (1: the paper's single key; up to 8; default 4).
    #[arg(long)]
    max_keys: Option<usize>,
    /// Least cut (dB) of a part's error over all frames an added key image must buy
    /// (default 0.5).
    #[arg(long)]
    key_gain_db: Option<f64>,
    /// Bytes of added key images a view may spend, as a fraction of its first key images'
    /// (default 0.5).
    #[arg(long)]
    key_budget: Option<f64>,
    /// Views on the whole sphere instead of the upper hemisphere.
    #[arg(long)]
    full_sphere: bool,
    /// How the pack's atlases are stored: bc7 (block-compressed, in KTX2 files: what a GPU
    /// samples; the default) or png (lossless, for tools).
    #[arg(long)]
    textures: Option<String>,
    /// Write per-view PNGs of the traced and fitted polygons into <out>/debug/.
    #[arg(long)]
    debug_images: bool,
    /// What to bake: polypostor, impostor, np3d, rigid or all, comma-separated (same views,
    /// resolution and frame rate for every one, so comparisons are fair; default polypostor).
    #[arg(long)]
    representation: Option<String>,
}

/// What a bake's INPUT names: the project (when one is given or INPUT is one), its file, and
/// the character's path.
fn resolve_input(
    input: &Path,
    project: Option<&Path>,
) -> anyhow::Result<(Option<polypostor::project::Project>, Option<PathBuf>, PathBuf)> {
    use polypostor::project::Project;
    let is_gltf = input
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("glb") || e.eq_ignore_ascii_case("gltf"));
    Ok(if is_gltf {
        let (project, file) = match project {
            Some(p) => {
                let (p, f) = Project::load(p)?;
                (Some(p), Some(f))
            }
            None => (None, None),
        };
        (project, file, input.to_owned())
    } else {
        let (p, file) = Project::load(input)?;
        let path = p.character_path(&file);
        (Some(p), Some(file), path)
    })
}

/// The project's segmentation when it fits the character, else the automatic one (said).
fn segmentation_for(
    project: Option<&polypostor::project::Project>,
    c: &polypostor::Character,
) -> polypostor::bake::segment::Segmentation {
    match project.and_then(|p| p.segmentation.as_ref()) {
        Some(s) => match s.to_segmentation(c.triangle_count()) {
            Ok(seg) => seg,
            Err(e) => {
                eprintln!(
                    "warning: the project's segmentation does not fit this character ({e}); using the automatic one"
                );
                polypostor::bake::segment::auto_segment(c)
            }
        },
        None => polypostor::bake::segment::auto_segment(c),
    }
}

impl BakeArgs {
    /// The `bake` command's defaults for INPUT into OUT.
    fn defaults(input: PathBuf, out: PathBuf, representation: &str) -> Self {
        Self {
            input,
            project: None,
            clip: None,
            clips: None,
            out: Some(out),
            views: None,
            resolution: None,
            fps: None,
            key_frame: "auto".into(),
            exhaustive: false,
            allow_folds: false,
            paper_objective: false,
            no_restarts: false,
            max_keys: None,
            key_gain_db: None,
            key_budget: None,
            full_sphere: false,
            textures: None,
            debug_images: false,
            representation: Some(representation.into()),
        }
    }
}

fn bake_cmd(a: BakeArgs) -> anyhow::Result<()> {
    use polypostor::bake::pipeline::{BakeOptions, KeyFrame};
    let started = std::time::Instant::now();
    let (project, project_file, character_path) = resolve_input(&a.input, a.project.as_deref())?;
    // The settings first: the project's (else the defaults), each flag given overriding its
    // field; nothing is read or rendered for a bake that cannot run.
    let mut settings = project.as_ref().map(|p| p.bake.clone()).unwrap_or_default();
    if let Some(v) = a.views {
        settings.views = v;
    }
    if let Some(r) = a.resolution {
        settings.resolution = r;
    }
    if let Some(f) = a.fps {
        settings.fps = f;
    }
    if let Some(k) = a.max_keys {
        settings.max_keys = k;
    }
    if let Some(g) = a.key_gain_db {
        settings.key_gain_db = g;
    }
    if let Some(b) = a.key_budget {
        settings.key_budget = b;
    }
    if let Some(r) = &a.representation {
        settings.representations = r.clone();
    }
    if let Some(t) = &a.textures {
        settings.textures = polypostor::bake::pipeline::TextureEncoding::parse(t)
            .ok_or_else(|| anyhow::anyhow!("--textures {t}: choose bc7 or png"))?;
    }
    settings.full_sphere |= a.full_sphere;
    settings.exhaustive |= a.exhaustive;
    settings.allow_folds |= a.allow_folds;
    settings.paper_objective |= a.paper_objective;
    settings.no_restarts |= a.no_restarts;
    settings.validate().map_err(|e| anyhow::anyhow!("{e}"))?;
    let set = settings.representation_set();

    let stem = character_path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "character".into());
    let default_out = |clip: Option<&str>| PathBuf::from(format!("{stem}-{}.pack", clip.unwrap_or("rest")));
    // Where the pack goes, before any work: never over what this tool did not write, never
    // over an input, never into the project's own folder.
    let check_out = |out: &Path| -> anyhow::Result<()> {
        let mut protected: Vec<&Path> = vec![&character_path];
        if let Some(f) = &project_file {
            protected.push(f);
            if let Some(dir) = f.parent().filter(|d| !d.as_os_str().is_empty()) {
                let (dir_real, out_real) = (polypostor::safe_fs::resolved(dir), polypostor::safe_fs::resolved(out));
                if out_real.starts_with(&dir_real) {
                    anyhow::bail!(
                        "--out '{}' {} the project folder '{}'; write packs beside the project, not into it",
                        out.display(),
                        if out_real == dir_real { "is" } else { "lies inside" },
                        dir.display()
                    );
                }
            }
        }
        polypostor::safe_fs::check_bake_output(out, &protected).map_err(|e| anyhow::anyhow!("--out: {e}"))
    };
    if let Some(out) = &a.out {
        check_out(out)?;
    }
    let c =
        polypostor::import_path(&character_path).map_err(|e| anyhow::anyhow!("{}: {e}", character_path.display()))?;
    for w in &c.warnings {
        eprintln!("warning: {w}");
    }
    let find = |n: &str| {
        c.find_clip(n).ok_or_else(|| {
            anyhow::anyhow!(
                "no clip named '{n}' (clips: {})",
                c.clips.iter().map(|k| k.name.as_str()).collect::<Vec<_>>().join(", ")
            )
        })
    };
    // Several clips: --clips, else the project's clip set.
    let clip_set: Option<Vec<String>> = match a.clips.as_deref() {
        Some(list) => {
            Some(polypostor::timeline::parse_clip_list(list, &c).map_err(|e| anyhow::anyhow!("--clips: {e}"))?)
        }
        None if a.clip.is_none() => project.as_ref().map(|p| p.clips.clone()).filter(|l| !l.is_empty()),
        None => None,
    };
    let (clip_name, extra_clips) = match &clip_set {
        Some(list) => {
            let mut idx = Vec::with_capacity(list.len());
            for n in list {
                idx.push(find(n)?);
            }
            (list.first().cloned(), idx.into_iter().skip(1).collect::<Vec<_>>())
        }
        None => (
            a.clip
                .clone()
                .or_else(|| project.as_ref().and_then(|p| p.view.clip.clone()))
                .or_else(|| c.find_clip("Walk").map(|_| "Walk".to_string()))
                .or_else(|| c.clips.first().map(|k| k.name.clone())),
            Vec::new(),
        ),
    };
    let clip = match &clip_name {
        Some(n) => Some(find(n)?),
        None => None,
    };
    let seg = segmentation_for(project.as_ref(), &c);
    let caps = project.as_ref().map(|p| p.caps.clone()).unwrap_or_default();
    let overrides = project.as_ref().map(|p| p.overrides.clone()).unwrap_or_default();
    let key_frame = match a.key_frame.as_str() {
        "auto" => KeyFrame::Auto,
        k => KeyFrame::Frame(
            k.parse()
                .map_err(|_| anyhow::anyhow!("--key-frame must be a frame number or 'auto', not '{k}'"))?,
        ),
    };
    let options = BakeOptions {
        clip,
        extra_clips,
        key_frame,
        overrides,
        keep_frame_images: a.debug_images,
        ..settings.options()
    };
    let out = match &a.out {
        Some(o) => o.clone(),
        None => {
            let o = if clip_set.as_ref().is_some_and(|l| l.len() > 1) {
                PathBuf::from(format!("{stem}-clips.pack"))
            } else {
                default_out(clip_name.as_deref())
            };
            check_out(&o)?;
            o
        }
    };
    let ctx = polypostor::gpu::GpuContext::from_env()?;
    // Every setting against its limit and this GPU, and the memory it needs.
    let plan = polypostor::bake::plan::check(&c, &seg, &options, set, ctx.device.limits().max_texture_dimension_2d)?;
    log::info!(
        "bake plan: {} views × {} frames × {} parts at {}², about {} of memory (budget {})",
        plan.views,
        plan.frames,
        plan.parts,
        plan.resolution,
        polypostor::limits::human_bytes(plan.estimated_bytes),
        polypostor::limits::human_bytes(plan.budget_bytes)
    );
    eprintln!(
        "baking {} ({} parts: {}), clip {}, {} views, {}², {} fps, on {}",
        c.name,
        seg.parts.len(),
        seg.parts.iter().map(|p| p.name.as_str()).collect::<Vec<_>>().join(", "),
        clip_name.as_deref().unwrap_or("(rest pose)"),
        options.views,
        options.resolution,
        options.fps,
        ctx.adapter_description()
    );
    // Corrections that cannot apply are said before the bake, never dropped silently.
    let basis = polypostor::bake::overrides::OverrideBasis {
        views: options.views,
        full_sphere: a.full_sphere,
        frames: plan.frames,
    };
    let dropped_before = options.overrides.audit(basis, seg.parts.len());
    for line in dropped_before.lines() {
        eprintln!("warning: {line}");
    }
    let bar = indicatif::ProgressBar::new(options.views as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{spinner} {prefix:>10} [{bar:40}] {pos}/{len} {elapsed_precise} {msg}",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    // The remaining time of the current stage at its own pace (see `bake::eta`).
    let eta = std::sync::Mutex::new(polypostor::bake::eta::Eta::new());
    let progress = |p: polypostor::bake::pipeline::Progress| {
        let now = std::time::Instant::now();
        let left = eta
            .lock()
            .map(|mut e| {
                e.update(p.stage, p.done, p.total, now);
                e.describe(now)
            })
            .unwrap_or_default();
        bar.set_prefix(p.stage);
        bar.set_length(p.total as u64);
        bar.set_position(p.done as u64);
        bar.set_message(if left.is_empty() {
            String::new()
        } else {
            format!("({left} in this stage)")
        });
    };
    let job = polypostor::reps::bake::FolderBake {
        character: &c,
        character_path: &character_path,
        clip_name: clip_name.as_deref(),
        segmentation: &seg,
        caps: &caps,
        options: &options,
        set,
        out: &out,
        previous: None,
        reuse_representations: false,
    };
    let debug_images = |dir: &Path, b: Option<&polypostor::bake::pipeline::Bake>| -> Result<(), String> {
        if let (true, Some(b)) = (a.debug_images, b) {
            let d = dir.join("debug");
            std::fs::create_dir_all(&d).map_err(|e| e.to_string())?;
            for v in 0..b.views.len() {
                let img = polypostor::bake::report::debug_image(b, v, &b.views[v].frame_colors);
                img.save(d.join(format!("view_{v:03}.png")))
                    .map_err(|e| e.to_string())?;
            }
        }
        Ok(())
    };
    BAKING.store(true, std::sync::atomic::Ordering::Relaxed);
    let result = polypostor::reps::bake::bake_folder(&ctx, &job, &progress, &CANCEL, &debug_images);
    BAKING.store(false, std::sync::atomic::Ordering::Relaxed);
    bar.finish_and_clear();
    let written = match result {
        Ok(r) => r,
        Err(polypostor::reps::bake::FolderError::Bake(polypostor::bake::pipeline::BakeError::Cancelled)) => {
            return Err(Cancelled.into());
        }
        Err(e) => return Err(e.into()),
    };
    let (Some(b), Some(stats)) = (written.bake, written.stats) else {
        eprintln!(
            "wrote {} ({}) in {:.1} s",
            out.display(),
            settings.representations,
            started.elapsed().as_secs_f64()
        );
        return Ok(());
    };
    // Pins past the fitted polygons' vertices are known only now.
    let late_pins = b.dropped_corrections().pins.saturating_sub(dropped_before.pins);
    let late = polypostor::bake::overrides::DroppedCorrections {
        pins: late_pins,
        ..Default::default()
    };
    for line in late.lines() {
        eprintln!("warning: {line}");
    }
    let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(out.join("report.json"))?)?;
    eprintln!(
        "wrote {} in {:.1} s: key frame {}, mean PSNR {:.2} dB (worst {:.2}), SSIM {:.3}, {} KiB vs {} KiB for impostors ({:.1}×), {:.0} triangles per view{}",
        out.display(),
        started.elapsed().as_secs_f64(),
        b.key_frame,
        report["mean_psnr"].as_f64().unwrap_or(0.0),
        report["worst_psnr"].as_f64().unwrap_or(0.0),
        report["mean_ssim"].as_f64().unwrap_or(0.0),
        stats.pack_bytes / 1024,
        report["impostor_bytes"].as_u64().unwrap_or(0) / 1024,
        report["memory_ratio"].as_f64().unwrap_or(0.0),
        stats.triangles_per_view,
        if set.any_other() {
            format!(", plus {}", settings.representations)
        } else {
            String::new()
        }
    );
    let parsed: Option<polypostor::bake::report::Report> = serde_json::from_value(report).ok();
    if let Some(r) = parsed.filter(|r| r.clips.len() > 1) {
        eprintln!(
            "{:<16} {:>6} {:>9} {:>9} {:>7} {:>11} {:>11} {:>8}",
            "clip", "frames", "speed", "PSNR dB", "SSIM", "alone", "impostors", "ratio"
        );
        for c in &r.clips {
            eprintln!(
                "{:<16} {:>6} {:>9.3} {:>9.2} {:>7.3} {:>11} {:>11} {:>7.1}×",
                c.name,
                c.frames,
                c.ground_speed,
                c.mean_psnr,
                c.mean_ssim,
                human_bytes(c.alone_bytes),
                human_bytes(c.impostor_bytes),
                c.memory_ratio
            );
        }
        eprintln!(
            "{:<16} {:>6} {:>9} {:>9.2} {:>7.3} {:>11} {:>11} {:>7.1}×",
            "whole pack",
            r.settings.frames,
            "",
            r.mean_psnr,
            r.mean_ssim,
            human_bytes(r.pack_bytes),
            human_bytes(r.impostor_bytes),
            r.memory_ratio
        );
    }
    Ok(())
}

fn human_bytes(b: u64) -> String {
    let b = b as f64;
    if b >= 1e6 {
        format!("{:.1} MB", b / 1e6)
    } else {
        format!("{:.0} KB", b / 1e3)
    }
}

fn compare_cmd(
    dir: &Path,
    character: Option<&Path>,
    views: usize,
    out: Option<PathBuf>,
    json: bool,
) -> anyhow::Result<()> {
    use polypostor::reps::compare;
    let out = out.unwrap_or_else(|| dir.join("compare"));
    check_output_files(
        &out,
        &["memory.png", "error.png", "ssim.png", "quality.png", "compare.json"],
    )?;
    let assets = polypostor::scene::CrowdAssets::load(dir, character, None).map_err(|e| anyhow::anyhow!(e))?;
    let memory = compare::memory(&assets);
    let ctx = polypostor::gpu::GpuContext::from_env()?;
    let total_views = assets.view_directions().len();
    let chosen = compare::chosen_views(total_views, views);
    let bar = indicatif::ProgressBar::new(chosen.len() as u64);
    if json {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let errors = compare::errors(&ctx, &assets, &chosen, &|d, _| bar.set_position(d as u64))?;
    bar.finish_and_clear();
    // The quality sheet: the Polypostor's worst views and a spread of others.
    let rows = polypostor::reps::quality::sheet_rows(&errors, 3, 3);
    let (sheet, _) = {
        let mut renders = compare::Renders::new(&ctx, &assets)?;
        let title = format!("{}: PSNR / SSIM against the real mesh", assets.character.name);
        polypostor::reps::quality::render_sheet(&mut renders, &title, &rows, assets.resolution().min(256))?
    };
    std::fs::create_dir_all(&out)?;
    polypostor::safe_fs::write_png(&out.join("quality.png"), &sheet).map_err(anyhow::Error::msg)?;
    let names: Vec<String> = memory.iter().map(|m| m.representation.clone()).collect();
    let mb = |f: &dyn Fn(&compare::MemoryRow) -> u64| memory.iter().map(|m| f(m) as f64 / 1e6).collect::<Vec<f64>>();
    polypostor::plot::bar_chart(
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
    polypostor::plot::line_chart(
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
    polypostor::plot::line_chart(
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
    polypostor::safe_fs::write_json(&out.join("compare.json"), report.clone()).map_err(anyhow::Error::msg)?;
    if json {
        println!("{}", serde_json::to_string_pretty(&report)?);
        return Ok(());
    }
    println!(
        "memory (one character, {}, all {total_views} views)",
        match assets.timeline.spans.len() {
            1 => "one clip".to_string(),
            n => format!("{n} clips"),
        }
    );
    println!(
        "  {:<11} {:>10} {:>10} {:>12} {:>14}",
        "", "textures", "geometry", "total", "block-compr."
    );
    for m in &memory {
        println!(
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
    println!(
        "error against the real mesh over {} views: mean PSNR and SSIM (higher is better)",
        chosen.len()
    );
    println!(
        "  {:<11} {:>10} {:>12} {:>10}   {:>6} {:>9} {:>8}   worst view",
        "", "all", "on frames", "between", "SSIM", "on frames", "between"
    );
    for e in &errors {
        println!(
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
    // A whole-character pack: each clip's error per representation.
    if assets.timeline.spans.len() > 1 {
        println!("per clip: mean PSNR dB / SSIM");
        print!("  {:<11}", "");
        for c in &assets.timeline.spans {
            print!(" {:>16}", c.name);
        }
        println!();
        for e in &errors {
            print!("  {:<11}", e.representation);
            for c in &e.per_clip {
                print!(" {:>9.2} / {:.3}", c.psnr, c.ssim);
            }
            println!();
        }
    }
    println!(
        "wrote memory.png, error.png, ssim.png, quality.png and compare.json in {}",
        out.display()
    );
    Ok(())
}

/// Checks, before any work, that the files a command will write into `dir` are new or its
/// own earlier output (and that `dir` is a folder, or can be made one).
fn check_output_files(dir: &Path, names: &[&str]) -> anyhow::Result<()> {
    if let Ok(m) = std::fs::symlink_metadata(dir)
        && !m.is_dir()
    {
        anyhow::bail!(
            "--out '{}' is {}, not a folder",
            dir.display(),
            polypostor::safe_fs::kind_of(&m.file_type())
        );
    }
    let kind = |n: &str| {
        if n.ends_with(".png") {
            polypostor::safe_fs::OutputFile::Png
        } else {
            polypostor::safe_fs::OutputFile::Json
        }
    };
    for n in names {
        polypostor::safe_fs::check_output_file(&dir.join(n), kind(n)).map_err(anyhow::Error::msg)?;
    }
    Ok(())
}

/// The default character baked with every representation into a temporary folder.
fn bake_default_all(out: &Path) -> anyhow::Result<()> {
    eprintln!(
        "baking the default character with every representation into {} (pass --pack to reuse a bake)",
        out.display()
    );
    bake_cmd(BakeArgs::defaults(
        repo_root().join(polypostor::project::DEFAULT_PROJECT_DIR),
        out.to_owned(),
        "all",
    ))
}

/// The stages of `bench bake`'s table: a column name and the `cpu_seconds` keys it sums
/// (`*` matches any job: `*/trace` is tracing wherever it ran).
const BENCH_STAGES: [(&str, &[&str]); 12] = [
    ("render", &["render", "prepare"]),
    ("key frame", &["key frame", "key frame/*"]),
    ("trace", &["part fit/trace", "key choice/trace"]),
    ("fit", &["part fit", "part fit/fold rescue"]),
    ("restarts", &["part fit/restart"]),
    (
        "keys",
        &[
            "key choice",
            "key choice/restart",
            "key choice/fold rescue",
            "key choice/simplify",
        ],
    ),
    ("simplify", &["part fit/simplify"]),
    ("measure", &["measure", "composite"]),
    ("order", &["order"]),
    ("atlas", &["atlas"]),
    ("encode+write", &["encode", "write"]),
    ("other reps", &["other representations"]),
];

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
fn bench_bake(
    mut inputs: Vec<PathBuf>,
    gap_views: usize,
    representation: &str,
    out: &Path,
    json: bool,
) -> anyhow::Result<()> {
    use polypostor::bake::report::Report;
    if inputs.is_empty() {
        inputs.push(repo_root().join(polypostor::project::DEFAULT_PROJECT_DIR));
        let shared = repo_root().join("../shared/assets/characters");
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
        resolve_input(input, None).map_err(|e| anyhow::anyhow!("{}: {e}", input.display()))?;
    }
    let ctx = polypostor::gpu::GpuContext::from_env()?;
    let mut rows = Vec::new();
    for input in &inputs {
        let tmp = polypostor::safe_fs::TempDir::new("polypostor-bench")?;
        let pack = tmp.path().join("pack");
        bake_cmd(BakeArgs::defaults(input.clone(), pack.clone(), representation))?;
        let report: Report = serde_json::from_str(&std::fs::read_to_string(pack.join("report.json"))?)?;
        let gap = if gap_views > 0 {
            let (project, _, character_path) = resolve_input(input, None)?;
            let c = polypostor::import_path(&character_path)
                .map_err(|e| anyhow::anyhow!("{}: {e}", character_path.display()))?;
            let seg = segmentation_for(project.as_ref(), &c);
            let caps = project.as_ref().map(|p| p.caps.clone()).unwrap_or_default();
            let options = polypostor::bake::pipeline::BakeOptions {
                clip: report.settings.clip.as_deref().and_then(|n| c.find_clip(n)),
                ..Default::default()
            };
            eprintln!("fitting {gap_views} views of {} both ways (fast, exact DP)…", c.name);
            BAKING.store(true, std::sync::atomic::Ordering::Relaxed);
            let g =
                polypostor::bake::gap::measure(&ctx, &c, &seg, &caps, &options, report.key_frame, gap_views, &CANCEL);
            BAKING.store(false, std::sync::atomic::Ordering::Relaxed);
            match g {
                Ok(g) => Some(g),
                Err(polypostor::bake::pipeline::BakeError::Cancelled) => return Err(Cancelled.into()),
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
        println!("{}", serde_json::to_string_pretty(&value)?);
        return Ok(());
    }
    println!(
        "bake at default settings on {} ({} threads); wall seconds, then CPU seconds per stage (summed over threads)",
        ctx.adapter_description(),
        rayon::current_num_threads()
    );
    print!("{:<18} {:>6} {:>7} {:>6}", "character", "frames", "wall s", "CPU s");
    for (col, _) in BENCH_STAGES {
        print!(" {col:>9}");
    }
    println!(" {:>8} {:>10}", "other", "fast−exact");
    for (name, r, gap) in &rows {
        let total = cpu_total(r);
        print!(
            "{:<18} {:>6} {:>7.1} {:>6.1}",
            name,
            r.views.first().map_or(0, |v| v.psnr.len()),
            r.seconds_total,
            total
        );
        let mut listed = 0.0;
        for (_, keys) in BENCH_STAGES {
            let s = stage_sum(&r.cpu_seconds, keys);
            listed += s;
            print!(" {s:>9.1}");
        }
        let gap = gap
            .as_ref()
            .map_or("—".to_string(), |g| format!("{:+.2} %", g.percent()));
        println!(" {:>8.1} {:>10}", (total - listed).max(0.0), gap);
    }
    for (name, _, gap) in &rows {
        if let Some(g) = gap {
            println!(
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
    println!("figures in {}", out.join("bench_bake.json").display());
    Ok(())
}

/// `bench crowd`: every representation at every size, one after the other on the same
/// crowd and camera, each frame simulated, selected, uploaded, drawn and waited for.
#[allow(clippy::too_many_arguments)]
fn bench_crowd(
    counts: &[usize],
    frames: usize,
    pack: Option<PathBuf>,
    character: Option<PathBuf>,
    only: &[String],
    (with, shares): (&[PathBuf], &[f32]),
    out: &Path,
    (width, height): (u32, u32),
    json: bool,
) -> anyhow::Result<()> {
    use polypostor::crowd::lod::{Level, LodDistances, LodPolicy};
    use polypostor::scene::{CrowdAssets, CrowdScene, bench_camera};
    if counts.is_empty() || counts.iter().any(|&c| c == 0 || c > 1_000_000) || frames == 0 {
        anyhow::bail!("--counts must list crowd sizes from 1 to 1,000,000 and --frames must be at least 1");
    }
    if with.len() + 1 > polypostor::crowd::MAX_SPECIES {
        anyhow::bail!(
            "--with: {} characters in one crowd, at most {}",
            with.len() + 1,
            polypostor::crowd::MAX_SPECIES
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
            "--shares: give {} numbers ≥ 0, not all 0 (the pack's character, then each --with)",
            with.len() + 1
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
    let ctx = polypostor::gpu::GpuContext::from_env()?;
    polypostor::limits::check_render_size(&ctx.device, width, height, "--width × --height")?;
    // Without --pack: a bake of the default character in a temporary folder, removed when
    // the benchmark ends (or is interrupted).
    let mut temp = None;
    let dir = match pack {
        Some(p) => p,
        None => {
            let t = polypostor::safe_fs::TempDir::new("polypostor-bench")?;
            let d = t.path().join("default.pack");
            temp = Some(t);
            bake_default_all(&d)?;
            d
        }
    };
    let assets = CrowdAssets::load(&dir, character.as_deref(), None).map_err(|e| anyhow::anyhow!(e))?;
    let (device, queue) = (&ctx.device, &ctx.queue);
    let target = polypostor::gpu::RenderTarget::new(device, width, height);
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
        // The pack's clips and what the agents do with them.
        use polypostor::crowd::Gait;
        let gaits = polypostor::crowd::Gaits::new(&assets.timeline.spans, assets.timeline.fps);
        let n = scene.crowd.gait_counts();
        for (i, c) in assets.timeline.spans.iter().enumerate() {
            let role = match gaits.role(i) {
                Some(g @ (Gait::Walk | Gait::Run)) => format!("{} ({} agents)", g.name(), n[g as usize]),
                Some(g) => g.name().to_string(),
                None => "not played (does not loop)".into(),
            };
            eprintln!(
                "  clip {:<14} {:>4} frames, ground speed {:.3}/s: {role}",
                c.name, c.frames, c.ground_speed
            );
        }
        if n[2] > 0 {
            eprintln!("  {} agents standing", n[2]);
        }
        if !guests.is_empty() {
            let per_kind = scene.crowd.kind_counts();
            let names = std::iter::once(&assets).chain(&guests);
            for ((a, n), share) in names.zip(per_kind).zip(&shares) {
                eprintln!(
                    "  character {:<16} share {share:.2}: {n} agents, {:.2} m tall, {} clips",
                    a.character.name,
                    a.size.height,
                    a.timeline.spans.len()
                );
            }
        }
    }
    let mut rows = Vec::new();
    for &count in counts {
        scene.respawn(assets.crowd_params(count));
        let camera = bench_camera(&scene.crowd);
        let mut per_rep = Vec::new();
        for (name, policy) in &reps {
            let mut run = |n: usize| {
                let t = std::time::Instant::now();
                let mut last = Default::default();
                for _ in 0..n {
                    last = scene.frame(device, queue, &target, &camera, policy, 1.0 / 60.0, wgpu::Color::BLACK);
                    let _ = device.poll(wgpu::PollType::Wait {
                        submission_index: None,
                        timeout: Some(std::time::Duration::from_secs(120)),
                    });
                }
                (t.elapsed().as_secs_f64(), last)
            };
            run(3);
            let (secs, last) = run(frames);
            let fps = frames as f64 / secs.max(1e-9);
            if !json {
                eprintln!(
                    "  {count:>7} {name:<11} {fps:>9.2} fps  ({} drawn, {} draw calls)",
                    last.frame.visible, last.draw_calls
                );
            }
            per_rep.push((name.to_string(), fps, last));
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
        let settle = scene.crowd.params.fade_secs + 0.05;
        scene.frame(device, queue, &target, &camera, &mix, settle, wgpu::Color::BLACK);
        scene.frame(device, queue, &target, &camera, &mix, 1.0 / 60.0, wgpu::Color::BLACK);
        let shot = target.read_color(device, queue)?;
        std::fs::create_dir_all(out)?;
        polypostor::safe_fs::write_png(&out.join(format!("crowd_{count}.png")), &shot).map_err(anyhow::Error::msg)?;
        scene.ground = false;
        let poly = per_rep.iter().find(|r| r.0 == "polypostor").map(|r| r.1);
        // GPU bytes per representation: the impostor level alone draws the full-resolution
        // sheets, the mix its far characters from the quarter-resolution ones.
        // Summed over every character of the crowd.
        let all = || std::iter::once(&scene.renderers).chain(&scene.guests);
        let sum = |f: &dyn Fn(&polypostor::gpu::CrowdRenderers) -> Option<u64>| -> Option<u64> {
            all().map(f).reduce(|a, b| Some(a? + b?)).flatten()
        };
        let far = sum(&|r| Some(r.far_impostor.as_ref().map_or(0, |p| p.gpu_bytes))).unwrap_or(0);
        let full = sum(&|r| Some(r.impostor.as_ref().map_or(0, |p| p.gpu_bytes))).unwrap_or(0);
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
                "  {count:>7} GPU memory: mix {:.1} MB ({:.2}× the Polypostor's {:.1} MB; far impostors {:.1} MB, full-resolution impostors {:.1} MB)",
                mix_bytes as f64 / 1e6,
                mix_bytes as f64 / poly.max(1) as f64,
                poly as f64 / 1e6,
                far as f64 / 1e6,
                full as f64 / 1e6,
            );
        }
        for (name, fps, last) in per_rep {
            rows.push(serde_json::json!({
                "representation": name,
                "count": count,
                "fps": fps,
                "ms_per_frame": 1e3 / fps,
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
    polypostor::safe_fs::write_json(
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
    polypostor::plot::bar_chart(
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
        println!("{}", serde_json::to_string_pretty(&rows)?);
        return Ok(());
    }
    println!("frames per second ({width}×{height}, {})", ctx.adapter_description());
    print!("{:>8}", "count");
    for n in &names {
        print!(" {n:>11}");
    }
    println!();
    for &count in counts {
        print!("{count:>8}");
        for n in &names {
            print!(" {:>11.2}", fps_of(count, n));
        }
        println!();
    }
    println!("polypostor fps ÷ each representation's fps (>1: polypostors are faster)");
    for &count in counts {
        print!("{count:>8}");
        for n in &names {
            let r = rows
                .iter()
                .find(|r| r["count"] == count && r["representation"] == *n)
                .and_then(|r| r["polypostor_over_this"].as_f64());
            match r {
                Some(r) => print!(" {r:>10.2}×"),
                None => print!(" {:>11}", "-"),
            }
        }
        println!();
    }
    println!("wrote crowd_fps.png and crowd_fps.json in {}", out.display());
    Ok(())
}

/// `bench stability`: the mix's temporal stability with cuts and with cross-fades.
fn bench_stability(
    pack: &Path,
    character: Option<PathBuf>,
    frames: usize,
    size: u32,
    json: bool,
) -> anyhow::Result<()> {
    use polypostor::scene::{CrowdAssets, temporal_stability};
    if !(2..=10_000).contains(&frames) || !(16..=4096).contains(&size) {
        anyhow::bail!("--frames must be 2 to 10,000 and --size 16 to 4096");
    }
    let ctx = polypostor::gpu::GpuContext::from_env()?;
    polypostor::limits::check_render_size(&ctx.device, size, size, "--size")?;
    let assets = CrowdAssets::load(pack, character.as_deref(), None).map_err(|e| anyhow::anyhow!(e))?;
    let cut = temporal_stability(&ctx.device, &ctx.queue, &assets, 0.0, frames, size)?;
    let faded = temporal_stability(&ctx.device, &ctx.queue, &assets, 0.25, frames, size)?;
    if json {
        println!(
            "{}",
            serde_json::json!({ "cut": cut, "cross_faded": faded, "adapter": ctx.adapter_description() })
        );
        return Ok(());
    }
    println!(
        "temporal stability of the mix ({frames} frames at 60 Hz, {size}², {}): largest frame-to-frame change per covered pixel",
        ctx.adapter_description()
    );
    println!("  switches        mix       skinned   ratio   frames fading");
    for (name, s) in [("cut", &cut), ("cross-faded", &faded)] {
        println!(
            "  {name:<12} {:>9.4} {:>9.4} {:>7.2}× {:>6}",
            s.mix_max, s.skinned_max, s.ratio, s.fading_frames
        );
    }
    Ok(())
}

/// `bench sim`: a 1600×900 camera at the edge of the crowd looking across it from 10 m up,
/// 137 hemisphere views, a 10-frame clip, the default three-level mix; one thread.
fn bench_sim(agents: usize, frames: usize, mixed: bool, json: bool) -> anyhow::Result<()> {
    use polypostor::bake::viewpoints::{Coverage, ViewLookup, directions};
    use polypostor::crowd::lod::{Level, LodDistances, LodPolicy};
    use polypostor::crowd::{ClipTiming, Crowd, CrowdCamera, CrowdParams};
    let mut params = CrowdParams {
        count: agents,
        ..Default::default()
    };
    // `--mixed`: the default character's four clips (speeds as measured) and a quadruped-like
    // character 0.9 m tall and 2.4 m long, its own three clips at 12 fps and 40 views.
    let span = |name: &str, start: u32, frames: u32, ground_speed: f32| polypostor::timeline::ClipSpan {
        name: name.into(),
        start,
        frames,
        looping: true,
        ground_speed,
    };
    let beast_size =
        polypostor::crowd::CharacterSize::from_bounds(glam::Vec3::new(-0.3, 0.0, -1.2), glam::Vec3::new(0.3, 0.9, 1.2));
    if mixed {
        params.spaced_for(&beast_size);
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
        let beast = polypostor::crowd::Species::new(
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
    let cam = polypostor::gpu::Camera {
        eye,
        target: glam::Vec3::new(0.0, 0.0, 0.0),
        up: glam::Vec3::Y,
        projection: polypostor::gpu::Projection::Perspective { fov_y_rad: fov },
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
            polypostor::crowd::sort_by_view(
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
        println!(
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
        println!(
            "crowd CPU work per frame, one thread, {} agents, {frames} frames",
            crowd.len()
        );
        println!("  {:<34} {:>8} {:>8}", "pass", "mean ms", "p95 ms");
        println!("  {:<34} {sm:>8.3} {sp:>8.3}", "simulate (wander, occupancy grid)");
        println!("  {:<34} {lm:>8.3} {lp:>8.3}", "cull, LOD, view, frame, instances");
        println!("  {:<34} {um:>8.3} {upp:>8.3}", "upload (sort by view, copy)");
        println!("  {:<34} {tm:>8.3} {tp:>8.3}", "total (target <= 2 ms at 20,000)");
        println!(
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
    Ok(())
}
