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
    /// Regenerate the built-in default character (.glb).
    GenerateDefault {
        /// Output path (default: assets/characters/default_humanoid.glb).
        #[arg(long, short)]
        out: Option<PathBuf>,
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

fn main() -> ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn,polypostor=info")).init();
    let cli = Cli::parse();
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
        None => {
            let path = cli
                .path
                .unwrap_or_else(|| repo_root().join(polypostor::project::DEFAULT_PROJECT_DIR));
            editor::run(path)
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(1)
        }
    }
}

fn inspect(file: &Path, json: bool) -> anyhow::Result<()> {
    match polypostor::import_path(file) {
        Ok(c) => {
            let s = c.summary();
            if json {
                println!("{}", serde_json::to_string_pretty(&s)?);
            } else {
                print!("{}", s.to_text());
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
    let ctx = GpuContext::from_env()?;
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
    img.save(out)?;
    eprintln!("wrote {}", out.display());
    Ok(())
}

fn generate_default(out: Option<PathBuf>) -> anyhow::Result<()> {
    let out = out.unwrap_or_else(|| polypostor::default_character::default_path(&repo_root()));
    let bytes = polypostor::default_character::generate_glb();
    polypostor::project::write_atomic(&out, &bytes)?;
    eprintln!("wrote {} ({} bytes)", out.display(), bytes.len());
    Ok(())
}
