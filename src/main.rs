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
        /// Which of the file's axes points up: y (glTF's, the default), z, -z, x, -x or -y
        /// (a file exported lying down is stood up).
        #[arg(long, default_value = "y", value_parser = parse_up, allow_hyphen_values = true)]
        up: polypostor::UpAxis,
    },
    /// Render a character headless to a PNG (colour, or normals with --normals).
    // `--pitch -90` is a number (clap otherwise suggests `-- -90`, which does not work).
    #[command(allow_negative_numbers = true)]
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
        /// Which of the file's axes points up (as for `inspect`).
        #[arg(long, default_value = "y", value_parser = parse_up, allow_hyphen_values = true)]
        up: polypostor::UpAxis,
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
    /// Regenerate the built-in default character (.glb), or write the generated quadruped.
    GenerateDefault {
        /// Output path (default: assets/characters/default_humanoid.glb; with --quadruped,
        /// quadruped.glb in the current folder).
        #[arg(long, short)]
        out: Option<PathBuf>,
        /// Write the generated long-bodied quadruped instead (Walk and Trot with root motion,
        /// Idle; joints named as a Blender rig names them) for trying the tool beyond the humanoid.
        #[arg(long)]
        quadruped: bool,
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
    /// CPU work per crowd frame: simulation (one thread), then culling, level of detail, view
    /// and frame choice and instance records (on every core; RAYON_NUM_THREADS=1 for one).
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
        Some(Command::Inspect { file, json, up }) => inspect(&file, json, up),
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
            up,
        }) => render(&file, &out, clip.as_deref(), time, size, yaw, pitch, normals, unlit, up),
        Some(Command::GenerateDefault { out, quadruped }) => generate_default(out, quadruped),
        Some(Command::Compare {
            pack_dir,
            character,
            views,
            out,
            json,
        }) => {
            let bar = indicatif::ProgressBar::new(views as u64);
            if json {
                bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
            }
            let r = polypostor::bench::compare::compare(&pack_dir, character.as_deref(), views, out, json, &|d, n| {
                bar.set_length(n as u64);
                bar.set_position(d as u64)
            });
            bar.finish_and_clear();
            r.map(|t| print!("{t}"))
        }
        Some(Command::Bake(args)) => bake_cmd(args),
        Some(Command::Bench {
            what:
                BenchWhat::Sim {
                    agents,
                    frames,
                    mixed,
                    json,
                },
        }) => polypostor::bench::sim::bench_sim(agents, frames, mixed, json).map(|t| print!("{t}")),
        Some(Command::Bench {
            what:
                BenchWhat::Stability {
                    pack,
                    character,
                    frames,
                    size,
                    json,
                },
        }) => polypostor::bench::crowd::bench_stability(&pack, character, frames, size, json).map(|t| print!("{t}")),
        Some(Command::Bench {
            what:
                BenchWhat::Bake {
                    inputs,
                    gap_views,
                    representation,
                    out,
                    json,
                },
        }) => with_bake_progress(|env| {
            polypostor::bench::bake::bench_bake(env, inputs, gap_views, &representation, &out, json)
        }),
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
        }) => with_bake_progress(|env| {
            polypostor::bench::crowd::bench_crowd(
                env,
                &counts,
                frames,
                pack,
                character,
                &representations,
                (&with, &shares),
                &out,
                (width, height),
                json,
            )
        }),
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

/// `--up`: an axis as `y`, `+z`, `-x`, ….
fn parse_up(text: &str) -> Result<polypostor::UpAxis, String> {
    polypostor::UpAxis::parse(text).ok_or_else(|| format!("'{text}' is not an axis: give y, z, -z, x, -x or -y"))
}

fn inspect(file: &Path, json: bool, up: polypostor::UpAxis) -> anyhow::Result<()> {
    match polypostor::import_path_with(file, polypostor::ImportOptions { up }) {
        Ok(c) => {
            let s = polypostor::summary::Summary::of(&c);
            // How each clip moves (what a crowd does with it).
            let motion: Vec<(String, polypostor::timeline::ClipMotion, f32)> = polypostor::timeline::measure_clips(&c)
                .into_iter()
                .enumerate()
                .map(|(i, m)| (c.clips[i].name.clone(), m, c.clips[i].in_place_velocity.length()))
                .collect();
            // The parts the bake would cut it into (what the editor's Segment tab starts from).
            let seg = polypostor::bake::segment::auto_segment(&c);
            let parts: Vec<(String, usize)> = seg.parts.iter().map(|p| p.name.clone()).zip(seg.part_sizes()).collect();
            if json {
                let mut v = serde_json::to_value(&s)?;
                v["automatic_parts"] = parts
                    .iter()
                    .map(|(name, triangles)| serde_json::json!({ "name": name, "triangles": triangles }))
                    .collect();
                v["clip_motion"] = motion
                    .iter()
                    .map(|(name, m, root)| {
                        serde_json::json!({
                            "name": name,
                            "ground_speed": m.ground_speed(),
                            "root_motion_taken_out": root,
                            "loops": m.loops(),
                            "locomotion": m.is_locomotion(),
                            "stride_estimate": m.is_stride_estimate(),
                            "leg_sweep": m.sweep,
                            "closure": m.closure,
                            "contact": m.contact,
                            "spread": m.spread,
                            "lift": m.lift,
                        })
                    })
                    .collect();
                println!("{}", serde_json::to_string_pretty(&v)?);
            } else {
                print!("{}", s.to_text());
                println!("automatic parts (triangles)");
                for (name, triangles) in &parts {
                    println!("  {name:<24} {triangles:>8}");
                }
                if !motion.is_empty() {
                    println!(
                        "clip motion (ground speed in scene units/s; closure, contact, spread, the legs' sweep and the lift off the ground as measured)"
                    );
                    for (name, m, root) in &motion {
                        println!(
                            "  {:<24} {:>8.3}/s  {:<16} closure {:.3}  contact {:.2}  spread {:.2}  sweep {:.3}/s  lift {:.2}{}",
                            name,
                            m.ground_speed(),
                            if m.is_locomotion() {
                                "locomotion"
                            } else if m.is_stride_estimate() {
                                "strides (sweep)"
                            } else if m.loops() {
                                "loops in place"
                            } else {
                                "does not loop"
                            },
                            m.closure,
                            m.contact,
                            m.spread,
                            m.sweep,
                            m.lift,
                            if *root > 0.0 {
                                format!("  (root motion {root:.3}/s played in place)")
                            } else {
                                String::new()
                            }
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
    up: polypostor::UpAxis,
) -> anyhow::Result<()> {
    use polypostor::animation::{Pose, clip_bounds};
    use polypostor::gpu::*;
    let c = polypostor::import_path_with(file, polypostor::ImportOptions { up })
        .map_err(|e| anyhow::anyhow!("{}: {e}", file.display()))?;
    let clip_index = match clip {
        Some(name) => Some(
            c.find_clip(name)
                .ok_or_else(|| anyhow::anyhow!("no clip named '{name}'"))?,
        ),
        None => (!c.clips.is_empty()).then_some(0),
    };
    polypostor::safe_fs::check_output_file(out, polypostor::safe_fs::OutputFile::Png).map_err(anyhow::Error::msg)?;
    // `render` writes PNG only: a .jpg name would get PNG bytes.
    if !out.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")) {
        anyhow::bail!(
            "-o {}: render writes a PNG image; give the file a .png name",
            out.display()
        );
    }
    // Said now, not after the render that would fill it.
    if let Some(folder) = out.parent().filter(|p| !p.as_os_str().is_empty())
        && !folder.is_dir()
    {
        anyhow::bail!("-o {}: the folder '{}' does not exist", out.display(), folder.display());
    }
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
    let radius = ((max - min) * 0.5).length().max(f32::MIN_POSITIVE);
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

fn generate_default(out: Option<PathBuf>, quadruped: bool) -> anyhow::Result<()> {
    let out = out.unwrap_or_else(|| {
        if quadruped {
            PathBuf::from("quadruped.glb")
        } else {
            polypostor::default_character::default_path(&repo_root())
        }
    });
    polypostor::safe_fs::check_output_file(&out, polypostor::safe_fs::OutputFile::Glb).map_err(anyhow::Error::msg)?;
    if !out.extension().is_some_and(|e| e.eq_ignore_ascii_case("glb")) {
        anyhow::bail!("-o {}: the file written is a binary glTF; name it .glb", out.display());
    }
    let bytes = if quadruped {
        polypostor::samples::quadruped_glb()
    } else {
        polypostor::default_character::generate_glb()
    };
    polypostor::safe_fs::write_file_atomic(&out, &bytes).map_err(anyhow::Error::msg)?;
    eprintln!("wrote {} ({} bytes)", out.display(), bytes.len());
    Ok(())
}

#[derive(clap::Args)]
// `--views -3` is a wrong number, said as such (clap otherwise suggests `-- -3`, which would
// take -3 for the input).
#[command(allow_negative_numbers = true)]
struct BakeArgs {
    /// A .glb/.gltf, or a project (folder or project.json).
    input: PathBuf,
    /// Project whose segmentation and cap colours to use (when INPUT is a glTF).
    #[arg(long)]
    project: Option<PathBuf>,
    /// Which of the character file's axes points up: y (glTF's), z, -z, x, -x or -y; a file
    /// exported lying down is stood up (default: the project's, else y). Recorded in the pack.
    #[arg(long, value_parser = parse_up, allow_hyphen_values = true)]
    up: Option<polypostor::UpAxis>,
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
    /// Leave every drawn vertex on the traced outline's vertices instead of placing it to a
    /// quarter pixel where that lowers the drawn error (faster bakes, about 1 dB less
    /// faithful).
    #[arg(long)]
    no_subpixel: bool,
    /// Most key images per part and view (1: the paper's single key; up to 8; default 4).
    #[arg(long)]
    max_keys: Option<usize>,
    /// Least cut (dB) of a part's error over all frames an added key image must buy
    /// (default 0.5).
    #[arg(long)]
    key_gain_db: Option<f64>,
    /// Bytes of added key images a view may spend, as a fraction of its first key images'
    /// (default 0.25).
    #[arg(long)]
    key_budget: Option<f64>,
    /// Vertices of each part's polygon in the pack (3 to 40, the fitted polygon's; default 40;
    /// fewer are chosen by deformation-aware simplification: a smaller pack and less vertex
    /// work in the crowd, coarser warps). The pack also holds each polygon simplified on to
    /// half its vertices, drawn for characters small on screen.
    #[arg(long)]
    polygon_vertices: Option<usize>,
    /// Most vertices added inside each part's polygon (0 to 24; default 24), each moved at every
    /// frame to where it lowers the drawn error: the image inside a part can then slide where
    /// its outline hardly moves (a head turning in place). 0: the outline's vertices alone.
    #[arg(long)]
    interior_vertices: Option<usize>,
    /// Most views, as a share of all, that the key budget other views left unspent goes to,
    /// worst views first (0 to 1; 0: each view spends only its own; default 0.1).
    #[arg(long)]
    key_share: Option<f64>,
    /// A view may also spend on added key images whatever keeps it this many times smaller
    /// than classic impostors of one clip, up to as many bytes as its first key images (long
    /// clips, whose packs are small beside impostors, get more keys; 0: off; default 58).
    #[arg(long)]
    key_ratio: Option<f64>,
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

impl BakeArgs {
    /// Whether the command line gave the setting `SettingError::setting` names.
    fn gave(&self, setting: &str) -> bool {
        match setting {
            "views" => self.views.is_some(),
            "resolution" => self.resolution.is_some(),
            "fps" => self.fps.is_some(),
            "max-keys" => self.max_keys.is_some(),
            "key-gain-db" => self.key_gain_db.is_some(),
            "key-budget" => self.key_budget.is_some(),
            "key-share" => self.key_share.is_some(),
            "key-ratio" => self.key_ratio.is_some(),
            "polygon-vertices" => self.polygon_vertices.is_some(),
            "interior-vertices" => self.interior_vertices.is_some(),
            "representation" => self.representation.is_some(),
            // A conflict between switches (--no-restarts with --exhaustive): the flags can
            // only switch them on, so it is said as the command line's.
            "no-restarts" => true,
            _ => true,
        }
    }

    /// `settings` (the project's, from `project_file`, else the defaults) with every flag
    /// given overriding its field, checked: a value out of range that came from the project
    /// file is said to come from there.
    fn settings(
        &self,
        mut settings: polypostor::bake::settings::BakeSettings,
        project_file: Option<&Path>,
    ) -> anyhow::Result<polypostor::bake::settings::BakeSettings> {
        if let Some(v) = self.views {
            settings.views = v;
        }
        if let Some(r) = self.resolution {
            settings.resolution = r;
        }
        if let Some(f) = self.fps {
            settings.fps = f;
        }
        if let Some(k) = self.max_keys {
            settings.max_keys = k;
        }
        if let Some(g) = self.key_gain_db {
            settings.key_gain_db = g;
        }
        if let Some(b) = self.key_budget {
            settings.key_budget = b;
        }
        if let Some(s) = self.key_share {
            settings.key_share = s;
        }
        if let Some(r) = self.key_ratio {
            settings.key_ratio = r;
        }
        if let Some(n) = self.polygon_vertices {
            settings.polygon_vertices = n;
        }
        if let Some(n) = self.interior_vertices {
            settings.interior_vertices = n;
        }
        if let Some(r) = &self.representation {
            settings.representations = r.clone();
        }
        if let Some(t) = &self.textures {
            settings.textures = polypostor::bake::pipeline::TextureEncoding::parse(t)
                .ok_or_else(|| anyhow::anyhow!("--textures {t}: choose bc7 or png"))?;
        }
        settings.full_sphere |= self.full_sphere;
        settings.exhaustive |= self.exhaustive;
        settings.allow_folds |= self.allow_folds;
        settings.paper_objective |= self.paper_objective;
        settings.no_restarts |= self.no_restarts;
        settings.no_subpixel |= self.no_subpixel;
        if let Err(e) = settings.validate() {
            // The project file's name for the setting.
            let field = match e.setting {
                "representation" => "representations".to_string(),
                s => s.replace('-', "_"),
            };
            return Err(match project_file.filter(|_| !self.gave(e.setting)) {
                Some(file) => anyhow::anyhow!(
                    "{}: the project's bake setting {} {} (correct it there, or give --{} here)",
                    file.display(),
                    field,
                    e.message,
                    e.setting
                ),
                None => anyhow::Error::msg(e),
            });
        }
        Ok(settings)
    }
}

/// A bake's progress bar: the stage, its views or frames, and the remaining time of the
/// stage at its own pace (see `bake::eta`).
fn bake_progress_bar() -> (
    indicatif::ProgressBar,
    impl Fn(polypostor::bake::pipeline::Progress) + Sync,
) {
    let bar = indicatif::ProgressBar::new(1);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{spinner} {prefix:>10} [{bar:40}] {pos}/{len} {elapsed_precise} {msg}",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    let eta = std::sync::Mutex::new(polypostor::bake::eta::Eta::new());
    let b = bar.clone();
    let progress = move |p: polypostor::bake::pipeline::Progress| {
        let now = std::time::Instant::now();
        let left = eta
            .lock()
            .map(|mut e| {
                e.update(p.stage, p.done, p.total, now);
                e.describe(now)
            })
            .unwrap_or_default();
        b.set_prefix(p.stage);
        b.set_length(p.total as u64);
        b.set_position(p.done as u64);
        b.set_message(if left.is_empty() {
            String::new()
        } else {
            format!("({left})")
        });
    };
    (bar, progress)
}

/// Runs a measurement that may bake, with a progress bar and Ctrl+C cancelling the bake;
/// prints its table.
fn with_bake_progress(f: impl FnOnce(&polypostor::bench::Env) -> anyhow::Result<String>) -> anyhow::Result<()> {
    let (bar, progress) = bake_progress_bar();
    let root = repo_root();
    let env = polypostor::bench::Env {
        repo_root: &root,
        progress: &progress,
        cancel: &CANCEL,
    };
    BAKING.store(true, std::sync::atomic::Ordering::Relaxed);
    let result = f(&env);
    BAKING.store(false, std::sync::atomic::Ordering::Relaxed);
    bar.finish_and_clear();
    match result {
        Err(_) if CANCEL.load(std::sync::atomic::Ordering::Relaxed) => Err(Cancelled.into()),
        r => r.map(|t| print!("{t}")),
    }
}

/// `n word` or `n words`.
fn counted(n: usize, word: &str) -> String {
    if n == 1 {
        format!("1 {word}")
    } else {
        format!("{n} {word}s")
    }
}

fn bake_cmd(a: BakeArgs) -> anyhow::Result<()> {
    use polypostor::job::{self, BakeInput, Prepared, Request};
    let started = std::time::Instant::now();
    let mut input = BakeInput::resolve(&a.input, a.project.as_deref()).map_err(anyhow::Error::msg)?;
    if let Some(up) = a.up {
        input.up = up;
    }
    // The settings first: the project's (else the defaults), each flag given overriding its
    // field; nothing is read or rendered for a bake that cannot run.
    let settings = a.settings(input.settings(), input.project_file.as_deref())?;
    let key_frame = polypostor::bake::pipeline::KeyFrame::parse(&a.key_frame).map_err(anyhow::Error::msg)?;
    let prepared = Prepared::new(
        input,
        Request {
            settings: settings.clone(),
            key_frame,
            clips: a.clips.as_deref(),
            clip: a.clip.as_deref(),
            out: a.out.clone(),
            keep_frame_images: a.debug_images,
        },
    )
    .map_err(anyhow::Error::msg)?;
    for w in &prepared.warnings {
        eprintln!("warning: {w}");
    }
    let (c, seg, options, set, out) = (
        &prepared.character,
        &prepared.segmentation,
        &prepared.options,
        prepared.set,
        &prepared.out,
    );
    // Every clip the pack holds (a whole-character pack names them all).
    let clip_names: Vec<&str> = prepared
        .clips
        .first
        .into_iter()
        .chain(prepared.clips.extra.iter().copied())
        .filter_map(|i| c.clips.get(i).map(|k| k.name.as_str()))
        .collect();
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
        "baking {} ({}: {}), {} {}, {}, {}², {} fps, on {}",
        c.name,
        counted(seg.parts.len(), "part"),
        seg.parts.iter().map(|p| p.name.as_str()).collect::<Vec<_>>().join(", "),
        if clip_names.len() > 1 { "clips" } else { "clip" },
        if clip_names.is_empty() {
            "(rest pose)".to_string()
        } else {
            clip_names.join(", ")
        },
        counted(options.views, "view"),
        options.resolution,
        options.fps,
        ctx.adapter_description()
    );
    // A frame rate so low that a moving clip comes out as one still frame is said.
    if let Ok(t) = polypostor::timeline::Timeline::new(c, &options.clip_list(), options.fps) {
        for (span, clip) in t.spans.iter().zip(&t.clips) {
            let secs = clip.and_then(|i| c.clips.get(i)).map_or(0.0, |k| k.duration_secs);
            if span.frames == 1 && secs > 0.0 {
                eprintln!(
                    "warning: at {} fps the clip '{}' ({secs:.2} s) is one still frame; give --fps {:.0} or more to see it move",
                    options.fps,
                    span.name,
                    (4.0 / secs)
                        .ceil()
                        .clamp(polypostor::limits::MIN_FPS, polypostor::limits::MAX_FPS)
                );
            }
        }
    }
    // Corrections that cannot apply are said before the bake, never dropped silently.
    let basis = polypostor::bake::overrides::OverrideBasis {
        views: options.views,
        full_sphere: settings.full_sphere,
        frames: plan.frames,
    };
    let dropped_before = options.overrides.audit(basis, seg.parts.len());
    for line in dropped_before.lines() {
        eprintln!("warning: {line}");
    }
    let (bar, progress) = bake_progress_bar();
    let job = prepared.job();
    let debug_images = |dir: &Path, b: Option<&polypostor::bake::pipeline::Bake>| -> Result<(), String> {
        if let (true, Some(b)) = (a.debug_images, b) {
            let d = dir.join("debug");
            std::fs::create_dir_all(&d).map_err(|e| e.to_string())?;
            for v in 0..b.views.len() {
                let img = polypostor::bake::report::debug_image(b, v, &b.views[v].frame_colors);
                // Marked as the tool's, so a later bake over this folder knows it.
                polypostor::safe_fs::write_png(&d.join(format!("view_{v:03}.png")), &img)?;
            }
        }
        Ok(())
    };
    BAKING.store(true, std::sync::atomic::Ordering::Relaxed);
    let result = job::run(&ctx, &job, &progress, &CANCEL, &debug_images);
    BAKING.store(false, std::sync::atomic::Ordering::Relaxed);
    bar.finish_and_clear();
    let written = match result {
        Ok(r) => r,
        Err(job::JobError::Bake(polypostor::bake::pipeline::BakeError::Cancelled)) => {
            return Err(Cancelled.into());
        }
        Err(e) => return Err(e.into()),
    };
    let (Some(b), Some(stats)) = (written.bake, written.stats) else {
        eprintln!(
            "wrote {} ({}) in {:.1} s",
            out.display(),
            set.words(),
            started.elapsed().as_secs_f64()
        );
        return Ok(());
    };
    // Pins past the fitted polygons' vertices are known only now.
    let late_pins = b.dropped_corrections().pins.saturating_sub(dropped_before.pins);
    if late_pins > 0 {
        eprintln!(
            "warning: {late_pins} {}pin(s) refer to polygon vertices the fitted polygons do not have; ignored",
            if dropped_before.pins > 0 { "more " } else { "" }
        );
    }
    let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(out.join("report.json"))?)?;
    eprintln!(
        "wrote {} in {:.1} s: key frame {}, mean PSNR {:.2} dB (worst {:.2}), SSIM {:.3}, silhouette {:.3}, {} KiB vs {} KiB for impostors ({:.1}×), {:.0} triangles per view{}",
        out.display(),
        started.elapsed().as_secs_f64(),
        b.key_frame,
        report["mean_psnr"].as_f64().unwrap_or(0.0),
        report["worst_psnr"].as_f64().unwrap_or(0.0),
        report["mean_ssim"].as_f64().unwrap_or(0.0),
        report["mean_silhouette_iou"].as_f64().unwrap_or(0.0),
        stats.pack_bytes / 1024,
        report["impostor_bytes"].as_u64().unwrap_or(0) / 1024,
        report["memory_ratio"].as_f64().unwrap_or(0.0),
        stats.triangles_per_view,
        if set.any_other() {
            let others = polypostor::reps::RepSet {
                polypostor: false,
                ..set
            };
            format!(", plus {}", others.words().replace(',', ", "))
        } else {
            String::new()
        }
    );
    let brightness = report["truth_brightness"].as_f64().unwrap_or(1.0);
    if let Some(note) = polypostor::bake::pipeline::dark_note(brightness) {
        eprintln!("note: {note}");
    }
    let parsed: Option<polypostor::bake::report::Report> = serde_json::from_value(report).ok();
    if let Some(note) = parsed.as_ref().and_then(|r| r.empty_views_note()) {
        eprintln!("warning: {note}");
    }
    if let Some(table) = parsed.and_then(|r| r.clip_table()) {
        eprint!("{table}");
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use clap::CommandFactory;

    /// Every "default N" that `bake --help` states by hand is the value the bake uses
    /// (`BakeSettings::default()`): a changed default cannot leave its help text behind.
    #[test]
    fn the_bake_help_states_the_real_defaults() {
        let mut cli = super::Cli::command();
        let bake = cli.find_subcommand_mut("bake").expect("a bake command");
        let help = bake.render_long_help().to_string();
        let d = polypostor::bake::settings::BakeSettings::default();
        let flat = help.split_whitespace().collect::<Vec<_>>().join(" ");
        for (flag, value) in [
            ("--views", format!("else {}", d.views)),
            ("--resolution", format!("default {}", d.resolution)),
            ("--fps", format!("default {}", d.fps)),
            ("--max-keys", format!("default {}", d.max_keys)),
            ("--key-gain-db", format!("default {}", d.key_gain_db)),
            ("--key-budget", format!("default {}", d.key_budget)),
            ("--key-share", format!("default {}", d.key_share)),
            ("--key-ratio", format!("default {}", d.key_ratio)),
            ("--polygon-vertices", format!("default {}", d.polygon_vertices)),
            ("--interior-vertices", format!("default {}", d.interior_vertices)),
        ] {
            let at = flat
                .find(&format!("{flag} <"))
                .unwrap_or_else(|| panic!("{flag} missing from:\n{help}"));
            let text = &flat[at..];
            let end = text[2..].find(" --").map_or(text.len(), |e| e + 2);
            // The value whole ("default 4" is not "default 40").
            let whole = text[..end].match_indices(&value).any(|(i, m)| {
                !text[i + m.len()..]
                    .chars()
                    .next()
                    .is_some_and(|c| c.is_ascii_digit() || c == '.')
            });
            assert!(whole, "{flag}: expected \"{value}\" in \"{}\"", &text[..end]);
        }
    }
}
