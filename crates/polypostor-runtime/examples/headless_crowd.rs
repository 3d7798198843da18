//! Draw a crowd of a baked character, headless, into a PNG: the smallest program an engine
//! programmer needs to see how the run time is used.
//!
//! ```sh
//! cargo run --release -p polypostor-runtime --example headless_crowd -- \
//!     BAKED_FOLDER [--character CHARACTER.glb] [--count 2000] [--out crowd.png] [--no-ground]
//! ```
//!
//! `BAKED_FOLDER` is what `polypostor bake --representation all` wrote (a pack alone works
//! too: characters that would be impostors are then drawn as Polypostors). The glTF the
//! folder was baked from is read from the path its `representations.json` records unless
//! `--character` names it.

use std::path::PathBuf;

use polypostor_runtime::crowd::lod::{Level, LodDistances, LodPolicy};
use polypostor_runtime::gpu::{GpuContext, RenderTarget, read_rgba8};
use polypostor_runtime::scene::{CrowdAssets, CrowdScene, bench_camera};

struct Args {
    folder: PathBuf,
    character: Option<PathBuf>,
    count: usize,
    out: PathBuf,
    ground: bool,
}

fn parse_args(argv: &[String]) -> Result<Args, String> {
    let mut args = argv.iter().cloned();
    let mut folder = None;
    let mut character = None;
    let mut count = 2000;
    let mut out = PathBuf::from("crowd.png");
    let mut ground = true;
    while let Some(a) = args.next() {
        let mut value = || args.next().ok_or(format!("{a} needs a value"));
        match a.as_str() {
            "--character" => character = Some(PathBuf::from(value()?)),
            "--count" => {
                let v = value()?;
                count = v.parse().map_err(|_| format!("--count: '{v}' is not a number"))?;
                if !(1..=1_000_000).contains(&count) {
                    return Err(format!("--count: {count} is outside 1..=1000000"));
                }
            }
            "--out" => out = PathBuf::from(value()?),
            "--no-ground" => ground = false,
            _ if a.starts_with("--") => return Err(format!("unknown option {a}")),
            _ => folder = Some(PathBuf::from(a)),
        }
    }
    let folder =
        folder.ok_or("usage: headless_crowd BAKED_FOLDER [--character GLB] [--count N] [--out PNG] [--no-ground]")?;
    Ok(Args {
        folder,
        character,
        count,
        out,
        ground,
    })
}

/// Runs the example on its arguments (without the program name); returns what it printed.
pub fn run(argv: &[String]) -> Result<String, String> {
    let args = parse_args(argv)?;

    // 1. The baked folder (validated as it is read) and the character it was baked from.
    let assets = CrowdAssets::load(&args.folder, args.character.as_deref(), None)?;

    // 2. A GPU device: any wgpu device works; this one is headless (hardware first, then
    //    software adapters).
    let gpu = GpuContext::from_env().map_err(|e| e.to_string())?;
    let (device, queue) = (&gpu.device, &gpu.queue);

    // 3. The crowd: agents spread for this character's real size, with its clips, views and
    //    representations on the GPU (far impostors only: the mix does not need the full ones).
    let params = assets.crowd_params(args.count);
    let mut scene = CrowdScene::with_impostors(device, queue, &assets, params, false).map_err(|e| e.to_string())?;
    scene.ground = args.ground;

    // 4. The three-level mix: skinned meshes near, Polypostors in the middle, impostors far,
    //    switching by how many screen pixels a baked texel covers.
    let policy = LodPolicy::Mixed(LodDistances {
        texels: assets.resolution() as f32,
        ..Default::default()
    });

    // 5. Your render target (colour + depth); a camera looking across the crowd.
    let (width, height) = (960, 540);
    let target = RenderTarget::new(device, width, height);
    let camera = bench_camera(&scene.crowd);
    let sky = wgpu::Color {
        r: 0.55,
        g: 0.65,
        b: 0.78,
        a: 1.0,
    };

    // 6. Step and draw a second of frames at 30 Hz (agents walk, level fades settle).
    let mut stats = None;
    for _ in 0..30 {
        stats = Some(scene.frame(device, queue, &target, &camera, &policy, 1.0 / 30.0, sky));
    }
    let stats = stats.expect("30 frames were drawn");

    // 7. Read the picture back and save it.
    let image = read_rgba8(device, queue, &target.color).map_err(|e| e.to_string())?;
    image
        .save(&args.out)
        .map_err(|e| format!("{}: {e}", args.out.display()))?;
    let drawn = |level: Level| stats.frame.per_level[level as usize];
    Ok(format!(
        "{} agents of {} drawn into {} ({}×{}): skinned {}, Polypostor {}, impostor {}, {} draw calls",
        args.count,
        assets.character.name,
        args.out.display(),
        width,
        height,
        drawn(Level::Skinned),
        drawn(Level::Polypostor),
        drawn(Level::Impostor),
        stats.draw_calls
    ))
}

fn main() {
    let argv: Vec<String> = std::env::args().skip(1).collect();
    match run(&argv) {
        Ok(summary) => println!("{summary}"),
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    }
}
