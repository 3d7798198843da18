//! Block-compressed textures (issue 20): a pack written with BC7 atlases in KTX2 files reads
//! back as the same pack as its PNG twin up to BC7's loss, draws the same on a device that
//! samples BC7 as on one that decodes the blocks on the CPU, and its KTX2 files parse with an
//! independent reader (the `ktx2` crate).

mod common;

use std::sync::atomic::AtomicBool;

use common::images::{psnr, psnr_where};
use polypostor::bake::caps::CapOverrides;
use polypostor::bake::pipeline::{BakeOptions, KeyFrame, TextureEncoding, bake};
use polypostor::bake::segment::auto_segment;
use polypostor::crowd::Instance;
use polypostor::gpu::{AdapterPreference, GpuContext, GpuPolypostors, PolypostorStyle, RenderTarget};
use polypostor::pack::{load_pack, write_pack};

/// A context that samples BC7 wherever the adapter can, software rasterisers included
/// (`GpuContext::new` leaves it off there: see `optional_features`), so both upload paths
/// are drawn here.
fn bc_gpu() -> GpuContext {
    let ctx = GpuContext::with_features(&AdapterPreference::SoftwareFirst, polypostor::gpu::OPTIONAL_FEATURES)
        .expect("a wgpu adapter (install mesa-vulkan-drivers)");
    eprintln!("adapter: {}", ctx.adapter_description());
    ctx
}

/// Every view of `pack` drawn at frame 2 by a renderer on `ctx`.
fn draw_views(ctx: &GpuContext, pack: &polypostor::pack::LoadedPack) -> (Vec<image::RgbaImage>, u64) {
    let (device, queue) = (&ctx.device, &ctx.queue);
    let mut gpu = GpuPolypostors::new(device, queue, &pack.gpu_input()).unwrap();
    let target = RenderTarget::new(device, 128, 128);
    let style = PolypostorStyle {
        lit: true,
        tint: 0.0,
        ..Default::default()
    };
    let frames = pack.manifest.frames;
    let mut out = Vec::new();
    for (v, view) in pack.manifest.views.iter().enumerate() {
        let cam = &view.camera;
        let camera = cam.to_camera(cam.half_size * 4.0, cam.half_size, cam.half_size * 8.0);
        let instance = Instance {
            pos: [0.0, 0.0],
            facing: [0.0, 1.0],
            view: v as u32,
            frame: polypostor::crowd::looping_pair(2, frames),
            blend: 0.0,
            variant: 3,
        };
        gpu.render(device, queue, &target, camera.clip_from_world(1.0), &style, &[instance])
            .unwrap();
        out.push(target.read_color(device, queue).unwrap());
    }
    (out, gpu.gpu_bytes)
}

#[test]
fn bc7_packs_load_draw_and_parse_like_their_png_twins() {
    let ctx = bc_gpu();
    let options = BakeOptions {
        views: 4,
        resolution: 128,
        key_frame: KeyFrame::Frame(0),
        ..Default::default()
    };
    assert_eq!(options.textures, TextureEncoding::Bc7, "BC7 is the default");
    let (c, b) = common::bake_default(&ctx, &options);
    let dir = common::temp_dir("bc-textures");
    let (bc_dir, png_dir) = (dir.join("bc7.pack"), dir.join("png.pack"));
    let bc_stats = write_pack(&b, &c.name, Some("Walk"), &bc_dir).unwrap();
    let mut png_bake = b;
    png_bake.options.textures = TextureEncoding::Png;
    let png_stats = write_pack(&png_bake, &c.name, Some("Walk"), &png_dir).unwrap();
    let (bc, png) = (load_pack(&bc_dir).unwrap(), load_pack(&png_dir).unwrap());

    // Same geometry, same atlases up to BC7's loss; the blocks kept for upload.
    assert_eq!(bc.vertices, png.vertices);
    assert_eq!(bc.indices, png.indices);
    assert_eq!(bc_stats.texture_bytes, png_stats.texture_bytes);
    for (v, (a, b)) in bc.views.iter().zip(&png.views).enumerate() {
        assert!(bc.manifest.views[v].atlas.ends_with(".ktx2"));
        assert!(png.manifest.views[v].atlas.ends_with(".png"));
        assert!(a.atlas_blocks.is_some() && a.normal_blocks.is_some());
        assert!(b.atlas_blocks.is_none());
        assert_eq!(a.atlas.dimensions(), b.atlas.dimensions());
        assert_eq!(a.atlas.width() % 8, 0);
        assert_eq!(a.atlas.height() % 8, 0);
        // Colour everywhere; normals (RGB) where the normal atlas holds a surface.
        let (pc, pn) = (
            psnr(&a.atlas, &b.atlas),
            psnr_where(&a.normals, &b.normals, |q| q[3] > 0, 3),
        );
        println!("view {v}: BC7 colour atlas {pc:.1} dB, normals {pn:.1} dB");
        assert!(
            pc > 35.0 && pn > 25.0,
            "view {v}: BC7 atlas {pc:.1} dB, normals {pn:.1} dB"
        );
        assert!(
            pc.is_finite(),
            "BC7 is lossy: identical atlases mean nothing was compressed"
        );
        // The blocks are a quarter of RGBA8.
        let blocks = a.atlas_blocks.as_ref().unwrap();
        assert_eq!(blocks.blocks.len() as u32, a.atlas.width() * a.atlas.height());
    }

    // An independent KTX2 reader agrees on the container.
    let name = &bc.manifest.views[0].atlas;
    let bytes = std::fs::read(bc_dir.join(name)).unwrap();
    let reader = ktx2::Reader::new(&bytes[..]).expect("a valid KTX2 file");
    let h = reader.header();
    assert_eq!(h.format, Some(ktx2::Format::BC7_SRGB_BLOCK));
    assert_eq!([h.pixel_width, h.pixel_height], bc.manifest.views[0].atlas_size);
    assert_eq!(h.level_count, 1);
    assert_eq!(h.supercompression_scheme, None);
    let level = reader.levels().next().unwrap();
    assert_eq!(level.data, &bc.views[0].atlas_blocks.as_ref().unwrap().blocks[..]);
    match reader.dfd_blocks().first().expect("a data format descriptor") {
        ktx2::dfd::Block::Basic(b) => {
            assert_eq!(b.color_model, Some(ktx2::ColorModel::BC7));
            assert_eq!(b.transfer_function, Some(ktx2::TransferFunction::SRGB));
        }
        other => panic!("not a basic descriptor: {other:?}"),
    }
    let normal_bytes = std::fs::read(bc_dir.join(&bc.manifest.views[0].normal_atlas)).unwrap();
    let normal = ktx2::Reader::new(&normal_bytes[..]).unwrap();
    assert_eq!(normal.header().format, Some(ktx2::Format::BC7_UNORM_BLOCK));

    // Drawn on a device that samples BC7 and on one that cannot (the loader's decoding is
    // uploaded instead): the same pictures; a quarter of the texture memory.
    let plain = GpuContext::with_features(&AdapterPreference::SoftwareFirst, wgpu::Features::empty()).unwrap();
    assert!(!plain.device.features().contains(wgpu::Features::TEXTURE_COMPRESSION_BC));
    let (decoded, decoded_bytes) = draw_views(&plain, &bc);
    let (from_png, _) = draw_views(&plain, &png);
    if ctx.device.features().contains(wgpu::Features::TEXTURE_COMPRESSION_BC) {
        let (sampled, sampled_bytes) = draw_views(&ctx, &bc);
        for (v, (a, b)) in sampled.iter().zip(&decoded).enumerate() {
            let p = psnr(a, b);
            assert!(p > 50.0, "view {v}: BC7 sampled vs decoded on the CPU: {p:.1} dB");
        }
        assert!(sampled_bytes < decoded_bytes, "{sampled_bytes} vs {decoded_bytes}");
    } else {
        println!("this adapter samples no BC7: only the decoding path was drawn");
    }
    for (v, (a, b)) in decoded.iter().zip(&from_png).enumerate() {
        let p = psnr(a, b);
        println!("view {v}: BC7 pack vs PNG pack drawn (lit): {p:.1} dB");
        assert!(p > 30.0, "view {v}: BC7 pack vs PNG pack drawn: {p:.1} dB");
    }
}

#[test]
fn damaged_ktx2_atlases_are_named() {
    let ctx = bc_gpu();
    let c = polypostor::default_character::generate();
    let options = BakeOptions {
        views: 2,
        resolution: 32,
        key_frame: KeyFrame::Frame(0),
        ..Default::default()
    };
    let b = bake(
        &ctx,
        &c,
        &auto_segment(&c),
        &CapOverrides::default(),
        &options,
        &|_| {},
        &AtomicBool::new(false),
    )
    .unwrap();
    let dir = common::temp_dir("bc-damaged");
    let out = dir.join("p.pack");
    write_pack(&b, &c.name, Some("Walk"), &out).unwrap();
    let name = load_pack(&out).unwrap().manifest.views[1].atlas.clone();
    let path = out.join(&name);
    let good = std::fs::read(&path).unwrap();
    // A forged level length, resealed so only the KTX2 check can catch it.
    let mut bad = good.clone();
    bad[88..96].copy_from_slice(&(1u64 << 40).to_le_bytes());
    std::fs::write(&path, &bad).unwrap();
    common::reseal(&out.join("manifest.json"));
    let e = load_pack(&out).unwrap_err().to_string();
    assert!(e.contains(&name) && e.contains("level data"), "{e}");
    // Another format.
    let mut bad = good.clone();
    bad[12..16].copy_from_slice(&145u32.to_le_bytes());
    std::fs::write(&path, &bad).unwrap();
    common::reseal(&out.join("manifest.json"));
    let e = load_pack(&out).unwrap_err().to_string();
    assert!(e.contains(&name) && e.contains("Vulkan format"), "{e}");
    std::fs::write(&path, &good).unwrap();
    common::reseal(&out.join("manifest.json"));
    assert!(load_pack(&out).is_ok());
}

/// Impostor sheets written as BC7 (colour sRGB; normals linear and opaque, with the body parts
/// beside them in lossless greyscale PNGs) read back with every part number exact, normals
/// close to the PNG twin's, and draw (tinted per part, lit) like the PNG twin, from less GPU
/// memory where the device samples BC7; NP3D's key images likewise.
#[test]
fn impostor_sheets_in_bc7_keep_exact_parts_and_draw_like_their_png_twins() {
    use polypostor::bake::viewpoints::Coverage;
    use polypostor::crowd::lod::Level;
    use polypostor::crowd::{ClipTiming, looping_pair};
    use polypostor::reps::bake::{RepsOptions, bake_representations};
    use polypostor::reps::{RepSet, load_representations, write_representations, write_representations_with};
    use polypostor_runtime::texture::BcFormat;
    let ctx = bc_gpu();
    let (device, queue) = (&ctx.device, &ctx.queue);
    let c = polypostor::default_character::generate();
    let seg = auto_segment(&c);
    let labels: Vec<u32> = seg.labels.iter().map(|&l| l as u32).collect();
    let options = RepsOptions {
        views: 3,
        coverage: Coverage::UpperHemisphere,
        resolution: 64,
        fps: 10.0,
        clip: Some(0),
        extra_clips: Vec::new(),
        key_frame: 0,
        set: RepSet::parse("impostor,np3d").unwrap(),
        np3d_triangles: 400,
        part_labels: labels.clone(),
    };
    let reps = bake_representations(&ctx, &c, None, Some("Walk"), &options, &|_| {}, &AtomicBool::new(false)).unwrap();
    let dir = common::temp_dir("bc-impostors");
    let (bc_dir, png_dir) = (dir.join("bc7"), dir.join("png"));
    std::fs::create_dir_all(&bc_dir).unwrap();
    std::fs::create_dir_all(&png_dir).unwrap();
    let encode = |img: &image::RgbaImage, format: BcFormat| polypostor::pack::bc::encode_ktx2(img, format);
    write_representations_with(&reps, &bc_dir, Some(&encode)).unwrap();
    write_representations(&reps, &png_dir).unwrap();
    let (bc, png) = (
        load_representations(&bc_dir).unwrap(),
        load_representations(&png_dir).unwrap(),
    );
    // (Far normal sheets are an eighth of the resolution: 8 × 8 texel tiles here, where a
    // 4 × 4 block spans a quarter of a character.)
    for (what, a, b, min_db) in [
        (
            "full",
            bc.impostor.as_ref().unwrap(),
            png.impostor.as_ref().unwrap(),
            25.0,
        ),
        (
            "far",
            bc.far_impostor.as_ref().unwrap(),
            png.far_impostor.as_ref().unwrap(),
            20.0,
        ),
    ] {
        assert_eq!(a.color_blocks.len(), 3, "{what}: colour blocks");
        assert_eq!(a.normal_blocks.len(), 3, "{what}: normal blocks");
        assert!(b.color_blocks.is_empty() && b.normal_blocks.is_empty());
        for (v, (na, nb)) in a.normal.iter().zip(&b.normal).enumerate() {
            let parts_equal = na.pixels().zip(nb.pixels()).all(|(p, q)| p[3] == q[3]);
            assert!(parts_equal, "{what} view {v}: a part number changed");
            let p = psnr_where(na, nb, |q| q[3] > 0, 3);
            println!("{what} view {v}: BC7 normals {p:.1} dB");
            assert!(p > min_db && p.is_finite(), "{what} view {v}: BC7 normals {p:.1} dB");
            let pc = psnr(&a.color[v], &b.color[v]);
            assert!(
                pc > min_db + 3.0 && pc.is_finite(),
                "{what} view {v}: BC7 colour {pc:.1} dB"
            );
        }
    }
    for name in [
        "impostor_normal_000.ktx2",
        "impostor_part_000.png",
        "far_impostor_part_002.png",
    ] {
        assert!(bc_dir.join(name).is_file(), "{name}");
        assert!(polypostor::safe_fs::is_bake_file_name(name), "{name} is one of ours");
    }

    // Drawn: each character tinted per part (a wrong part number shows as a wrong colour).
    let timing = ClipTiming {
        frames: reps.manifest.frames as usize,
        fps: 10.0,
    };
    let timeline = polypostor::timeline::Timeline::new(&c, &[Some(0)], 10.0).unwrap();
    let size = 128u32;
    let target = RenderTarget::new(device, size, size);
    let style = PolypostorStyle {
        tint: 0.6,
        ..Default::default()
    };
    let draw = |reps: &polypostor::reps::Representations| {
        let inputs = polypostor::scene::crowd_inputs(None, Some(reps), timing, reps.impostor.as_ref());
        let mut crowd = polypostor::gpu::CrowdRenderers::new(device, queue, &c, &timeline, &labels, &inputs).unwrap();
        let cam = &reps.manifest.views[1].camera;
        let camera = cam.to_camera(cam.half_size * 4.0, cam.half_size, cam.half_size * 8.0);
        let mut instances: [Vec<Instance>; Level::COUNT] = Default::default();
        instances[Level::Impostor as usize].push(Instance {
            pos: [0.0, 0.0],
            facing: [0.0, 1.0],
            view: 1,
            frame: looping_pair(3, timing.frames as u32),
            blend: 0.0,
            variant: 7,
        });
        crowd.render(
            device,
            queue,
            &target,
            camera.clip_from_world(1.0),
            &style,
            &instances,
            wgpu::Color::TRANSPARENT,
        );
        (
            target.read_color(device, queue).unwrap(),
            crowd.gpu_bytes(Level::Impostor),
        )
    };
    let ((from_bc, bc_bytes), (from_png, png_bytes)) = (draw(&bc), draw(&png));
    let p = psnr(&from_bc, &from_png);
    let s = common::images::ssim(&from_bc, &from_png);
    println!("BC7 impostor vs PNG impostor drawn: {p:.1} dB, SSIM {s:.4}");
    let ok = p > 30.0 && s > 0.95;
    let pictures = common::images::save_on_failure(ok, "bc7_impostor", &from_png, &from_bc).unwrap_or_default();
    assert!(
        ok,
        "BC7 impostor vs PNG impostor drawn: {p:.1} dB, SSIM {s:.4}; {pictures}"
    );
    if ctx.device.features().contains(wgpu::Features::TEXTURE_COMPRESSION_BC) {
        // Colour 4 → 1 byte a texel, normals and parts 4 → 1 + 1.
        assert!(bc_bytes * 2 < png_bytes, "{bc_bytes} vs {png_bytes} bytes");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
