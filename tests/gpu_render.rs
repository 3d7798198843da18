//! GPU rendering core, headless: GPU skinning agrees with CPU skinning (silhouette IoU), and
//! colour / normal / depth readbacks are consistent.

mod common;

use common::images::{iou, mask};
use polypostor::Character;
use polypostor::animation::{Pose, clip_bounds};
use polypostor::gpu::*;

fn context() -> GpuContext {
    common::gpu()
}

fn camera_for(c: &Character, clip: Option<usize>, yaw: f32) -> Camera {
    let (min, max) = clip_bounds(c, clip, 8);
    let dir = glam::Vec3::new(yaw.sin(), 0.25, yaw.cos());
    Camera::ortho_framing(min, max, dir, 0.05)
}

fn skinning_agreement(ctx: &GpuContext, c: &Character, label: &str) {
    let renderer = CharacterRenderer::new(&ctx.device);
    let mut gpu = GpuCharacter::new(&renderer, &ctx.device, &ctx.queue, c);
    let target = RenderTarget::new(&ctx.device, 192, 192);
    let clip = (!c.clips.is_empty()).then_some(0);
    let duration = clip.map_or(0.0, |i| c.clips[i].duration_secs);
    for (k, yaw) in [0.0f32, 1.3, 2.6].into_iter().enumerate() {
        let t = duration * (k as f32 + 0.5) / 3.0;
        let pose = Pose::sample_index(c, clip, t);
        let cam = camera_for(c, clip, yaw);
        let opts = DrawOptions {
            shading: Shading::Unlit,
            ..Default::default()
        };
        renderer.render(
            &ctx.device,
            &ctx.queue,
            &target,
            &mut gpu,
            c,
            &pose,
            SkinningMode::Gpu,
            &cam,
            &opts,
        );
        let gpu_img = target.read_normal(&ctx.device, &ctx.queue).unwrap();
        renderer.render(
            &ctx.device,
            &ctx.queue,
            &target,
            &mut gpu,
            c,
            &pose,
            SkinningMode::Cpu,
            &cam,
            &opts,
        );
        let cpu_img = target.read_normal(&ctx.device, &ctx.queue).unwrap();
        let (a, b) = (mask(&gpu_img), mask(&cpu_img));
        // The test can fail: the posed silhouette is not the bind-pose one.
        if label == "default" {
            let rest = Pose::rest(c);
            renderer.render(
                &ctx.device,
                &ctx.queue,
                &target,
                &mut gpu,
                c,
                &rest,
                SkinningMode::Gpu,
                &cam,
                &opts,
            );
            let rest_img = target.read_normal(&ctx.device, &ctx.queue).unwrap();
            let moved = iou(&a, &mask(&rest_img));
            assert!(
                moved < 0.97,
                "{label}: pose barely changes the silhouette (IoU {moved})"
            );
        }
        let covered = a.iter().filter(|x| **x).count();
        let score = iou(&a, &b);
        eprintln!("{label}: t={t:.2} yaw={yaw}: silhouette IoU {score:.5} ({covered} px)");
        assert!(covered > 1500, "{label}: the character barely shows ({covered} px)");
        assert!(
            score >= 0.99,
            "{label}: GPU/CPU skinning silhouettes differ: IoU {score}"
        );
        if std::env::var_os("POLYPOSTOR_TEST_IMAGES").is_some() {
            let dir = std::env::temp_dir();
            gpu_img.save(dir.join(format!("{label}-{k}-gpu.png"))).unwrap();
            cpu_img.save(dir.join(format!("{label}-{k}-cpu.png"))).unwrap();
        }
    }
}

#[test]
fn gpu_and_cpu_skinning_agree_on_every_character() {
    let ctx = context();
    let default = polypostor::default_character::generate();
    skinning_agreement(&ctx, &default, "default");
    for f in common::real_characters() {
        let c = polypostor::import_path(&f).unwrap();
        skinning_agreement(&ctx, &c, &f.file_stem().unwrap().to_string_lossy());
    }
}

/// Normals of a character whose root is scaled unevenly (squash and stretch): the GPU's
/// skinning carries them as the CPU's does (`animation::normal_transform`, tested against the
/// surface's own tangents), pixel by pixel in the view-space normal image. The test can fail:
/// the matrix itself (the old rule) turns them by up to 20° here.
#[test]
fn gpu_skinning_carries_normals_of_unevenly_scaled_joints_as_the_cpu_does() {
    let ctx = context();
    let mut c = polypostor::default_character::generate();
    for n in c.skeleton.nodes.iter_mut().filter(|n| n.parent.is_none()) {
        n.rest.scale = glam::Vec3::new(1.8, 1.0, 0.6);
    }
    let renderer = CharacterRenderer::new(&ctx.device);
    let mut gpu = GpuCharacter::new(&renderer, &ctx.device, &ctx.queue, &c);
    let target = RenderTarget::new(&ctx.device, 160, 160);
    let clip = c.find_clip("Walk");
    let pose = Pose::sample_index(&c, clip, 0.3);
    let opts = DrawOptions {
        shading: Shading::Unlit,
        ..Default::default()
    };
    let mut draw = |mode| {
        renderer.render(
            &ctx.device,
            &ctx.queue,
            &target,
            &mut gpu,
            &c,
            &pose,
            mode,
            &camera_for(&c, clip, 0.8),
            &opts,
        );
        target.read_normal(&ctx.device, &ctx.queue).unwrap()
    };
    let (on_gpu, on_cpu) = (draw(SkinningMode::Gpu), draw(SkinningMode::Cpu));
    let decode = |p: &image::Rgba<u8>| glam::Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32) / 127.5 - glam::Vec3::ONE;
    let (mut both, mut far) = (0, 0);
    for (a, b) in on_gpu.pixels().zip(on_cpu.pixels()) {
        if a[3] > 127 && b[3] > 127 {
            both += 1;
            if decode(a).normalize().dot(decode(b).normalize()) < 0.996 {
                far += 1;
            }
        }
    }
    assert!(both > 2000, "{both} pixels");
    // Silhouette edges may differ by a pixel's rasterisation; the surface must not.
    assert!(
        far * 50 < both,
        "{far} of {both} pixels' normals differ by more than 5°"
    );
    // The old rule (the matrix itself) is far from the CPU's on this pose: the test can tell.
    let turned = c
        .vertices
        .iter()
        .filter(|v| {
            let m = polypostor::animation::vertex_matrix(&pose.skin_from_bind, v.bones, v.weights);
            let old = m.transform_vector3(v.normal).normalize();
            old.angle_between(polypostor::animation::normal_transform(&m, v.normal).normalize()) > 0.1
        })
        .count();
    assert!(
        turned * 5 > c.vertices.len(),
        "{turned} of {} normals turned by more than 5.7°",
        c.vertices.len()
    );
}

#[test]
fn colour_normal_and_depth_are_consistent() {
    let ctx = context();
    let c = polypostor::default_character::generate();
    let renderer = CharacterRenderer::new(&ctx.device);
    let mut gpu = GpuCharacter::new(&renderer, &ctx.device, &ctx.queue, &c);
    let target = RenderTarget::new(&ctx.device, 128, 160);
    let pose = Pose::rest(&c);
    // From the front: the face (+Z normals) is towards the camera.
    let (min, max) = c.bind_bounds();
    let cam = Camera::ortho_framing(min, max, glam::Vec3::Z, 0.05);
    let (color, _) = common::unlit_truth(&ctx.device, &ctx.queue, &renderer, &target, &mut gpu, &c, &pose, &cam);
    let normal = target.read_normal(&ctx.device, &ctx.queue).unwrap();
    let depth = target.read_depth(&ctx.device, &ctx.queue).unwrap();
    assert_eq!((color.width(), color.height()), (128, 160));
    assert_eq!(depth.data.len(), 128 * 160);
    // The shader readback (what the OpenGL backend uses) gives the same depths bit for bit.
    let via_shader = read_depth_via_shader(&ctx.device, &ctx.queue, &target.depth).unwrap();
    let bits = |d: &DepthImage| d.data.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&via_shader), bits(&depth));
    let mut covered = 0;
    let mut facing = 0.0f64;
    for (i, (c, n)) in color.pixels().zip(normal.pixels()).enumerate() {
        let on = n[3] > 127;
        // Colour alpha and normal alpha and depth agree on coverage.
        assert_eq!(c[3] > 127, on, "pixel {i}");
        assert_eq!(depth.data[i] < 1.0, on, "pixel {i}");
        if on {
            covered += 1;
            facing += (n[2] as f64 / 255.0) * 2.0 - 1.0;
        }
    }
    assert!(covered > 2000, "{covered}");
    // Seen from the front, the visible normals point at the camera on average.
    assert!(
        facing / covered as f64 > 0.5,
        "mean view-space z {}",
        facing / covered as f64
    );
    // Unlit colour reproduces the texture's palette: the shirt's blue is present.
    let blue = color
        .pixels()
        .filter(|p| p[3] > 0 && p[2] as i32 > p[0] as i32 + 40)
        .count();
    assert!(blue > 200, "{blue}");
}

/// The editor's playback path (the grid drawn once into a backdrop, then each pose drawn
/// over a copy of it) gives the same image as drawing character and grid together, and a
/// second pose over the same backdrop leaves no trace of the first.
#[test]
fn character_over_a_cached_grid_backdrop_matches_a_full_draw() {
    let ctx = context();
    let c = polypostor::default_character::generate();
    let renderer = CharacterRenderer::new(&ctx.device);
    let mut gpu = GpuCharacter::new(&renderer, &ctx.device, &ctx.queue, &c);
    let (w, h) = (200, 150);
    let full = RenderTarget::new(&ctx.device, w, h);
    let backdrop = RenderTarget::new(&ctx.device, w, h);
    let over = RenderTarget::new(&ctx.device, w, h);
    let cam = Camera::orbit(glam::Vec3::new(0.0, 0.9, 0.0), 0.6, 0.35, 4.0, 0.8);
    let opts = DrawOptions {
        shading: Shading::Lit,
        clear_color: [0.045, 0.05, 0.06, 1.0],
        grid: true,
    };
    let clip = c.find_clip("Walk");
    let d = clip.map_or(1.0, |i| c.clips[i].duration_secs);
    for (k, t) in [0.1f32, 0.6].into_iter().enumerate() {
        let pose = Pose::sample_index(&c, clip, t * d);
        gpu.set_pose(&ctx.queue, &c, &pose, SkinningMode::Gpu);
        gpu.set_camera(&ctx.queue, &cam, w as f32 / h as f32, opts.shading);
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        renderer.encode(&mut encoder, &full, &gpu, &opts);
        if k == 0 {
            // Drawn once, for the first pose only.
            renderer.encode_backdrop(&mut encoder, &backdrop, &gpu, &opts);
        }
        renderer.encode_over(&mut encoder, &over, &backdrop, &gpu);
        ctx.queue.submit([encoder.finish()]);
        let a = full.read_color(&ctx.device, &ctx.queue).unwrap();
        let b = over.read_color(&ctx.device, &ctx.queue).unwrap();
        // The background's red byte (sRGB-encoded).
        let clear_r = (0.045f32.powf(1.0 / 2.2) * 255.0) as i32;
        let (mut differ, mut grid, mut figure) = (0, 0, 0);
        for (p, q) in a.pixels().zip(b.pixels()) {
            if (0..4).any(|i| (p[i] as i32 - q[i] as i32).abs() > 2) {
                differ += 1;
            }
            // Grid lines are lighter grey than the background; the character is brighter
            // still and coloured.
            if (p[0] as i32 - clear_r).abs() > 12 && (p[0] as i32 - p[2] as i32).abs() < 6 {
                grid += 1;
            }
            if p[0] as i32 + p[1] as i32 + p[2] as i32 > 250 && (p[0] as i32 - p[2] as i32).abs() > 30 {
                figure += 1;
            }
        }
        eprintln!("pose {k}: grid {grid} px, character {figure} px, {differ} px differ");
        assert!(grid > 500, "pose {k}: the grid shows ({grid} px)");
        assert!(figure > 300, "pose {k}: the character shows ({figure} px)");
        // The character's feet reach a little below the ground, where the full draw blends
        // grid lines over them and the backdrop path does not.
        assert!(
            differ * 200 < (w * h) as usize,
            "pose {k}: {differ} of {} pixels differ",
            w * h
        );
    }
}

/// Alpha cut-outs (glTF `MASK`, and `BLEND` drawn as a cut-out): fragments whose base colour
/// alpha falls below the material's cut-off are not drawn, so alpha-tested hair cards,
/// lashes and lace show their shape instead of their whole quads. Independent answers: a
/// texture opaque everywhere draws exactly the opaque material's pixels, one transparent
/// everywhere draws nothing, and one transparent on its left half draws a part of them
/// (and only pixels the opaque render has).
#[test]
fn alpha_cut_outs_leave_out_what_the_texture_leaves_out() {
    let ctx = context();
    let base = polypostor::default_character::generate();
    let renderer = CharacterRenderer::new(&ctx.device);
    let target = RenderTarget::new(&ctx.device, 96, 128);
    let pose = Pose::rest(&base);
    let (min, max) = base.bind_bounds();
    let cam = Camera::ortho_framing(min, max, glam::Vec3::Z, 0.05);
    let draw = |alpha: &dyn Fn(u32) -> u8, cutoff: f32| {
        let mut c = base.clone();
        for t in &mut c.textures {
            let w = t.width;
            for (k, px) in t.rgba8.chunks_exact_mut(4).enumerate() {
                px[3] = alpha(k as u32 % w * 2 / w);
            }
        }
        for m in &mut c.materials {
            m.alpha_cutoff = cutoff;
        }
        let mut gpu = GpuCharacter::new(&renderer, &ctx.device, &ctx.queue, &c);
        common::unlit_truth(&ctx.device, &ctx.queue, &renderer, &target, &mut gpu, &c, &pose, &cam).0
    };
    assert!(base.materials.iter().all(|m| m.base_color_texture.is_some()));
    let opaque = draw(&|_| 0, 0.0);
    let full = mask(&opaque);
    let covered = full.iter().filter(|&&b| b).count();
    assert!(covered > 1000, "{covered} pixels");
    let solid = draw(&|_| 255, 0.5);
    assert_eq!(solid.as_raw(), opaque.as_raw(), "an opaque texture cuts nothing");
    let clear = draw(&|_| 0, 0.5);
    assert_eq!(
        mask(&clear).iter().filter(|&&b| b).count(),
        0,
        "a clear texture draws nothing"
    );
    let half = mask(&draw(&|column_half| if column_half == 0 { 0 } else { 255 }, 0.5));
    let kept = half.iter().filter(|&&b| b).count();
    assert!(kept > covered / 10 && kept < covered * 9 / 10, "{kept} of {covered}");
    assert!(
        half.iter().zip(&full).all(|(h, f)| !h || *f),
        "drew outside the character"
    );
}

/// A character of any size, looked at from as far in its own units, draws the same picture
/// on a grid of its own scale: its root scaled by 10⁻⁵ (0.02 mm tall) or 10⁵, the orbit
/// camera's distance and the grid cell ([`polypostor::gpu::grid_cell`]) scaled alike, give
/// the person-sized image. (The orbit camera's near plane had an absolute floor of 1 mm that
/// cut the tiny one away, and the grid was 1 m lines over 50 m whatever the character.)
#[test]
fn characters_of_any_size_draw_alike_on_a_grid_of_their_scale() {
    let ctx = context();
    let base = polypostor::default_character::generate();
    let renderer = CharacterRenderer::new(&ctx.device);
    let (w, h) = (160, 120);
    let draw = |k: f32| {
        let mut c = base.clone();
        // The root joint scaled about the origin (its offset too), as a scaled root node above it would.
        assert!(c.skeleton.nodes[0].parent.is_none());
        c.skeleton.nodes[0].rest.scale *= k;
        c.skeleton.nodes[0].rest.translation *= k;
        let mut gpu = GpuCharacter::new(&renderer, &ctx.device, &ctx.queue, &c);
        let target = RenderTarget::new(&ctx.device, w, h);
        let cam = Camera::orbit(glam::Vec3::new(0.0, 0.9 * k, 0.0), 0.6, 0.35, 4.0 * k, 0.8);
        let pose = Pose::rest(&c);
        gpu.set_pose(&ctx.queue, &c, &pose, SkinningMode::Gpu);
        let cell = polypostor::gpu::grid_cell(k);
        assert!((cell / k - 1.0).abs() < 1e-3, "{k}: cell {cell}");
        gpu.set_camera_with_grid(&ctx.queue, &cam, w as f32 / h as f32, Shading::Lit, cell);
        let opts = DrawOptions {
            shading: Shading::Lit,
            clear_color: [0.045, 0.05, 0.06, 1.0],
            grid: true,
        };
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        renderer.encode(&mut encoder, &target, &gpu, &opts);
        ctx.queue.submit([encoder.finish()]);
        target.read_color(&ctx.device, &ctx.queue).unwrap()
    };
    let person = draw(1.0);
    let lit = person
        .pixels()
        .filter(|p| p[0] as i32 + p[1] as i32 + p[2] as i32 > 250)
        .count();
    assert!(lit > 300, "the character shows ({lit} px)");
    for k in [1e-5f32, 1e-3, 1e5] {
        let img = draw(k);
        let differ = person
            .pixels()
            .zip(img.pixels())
            .filter(|(p, q)| (0..3).any(|i| (p[i] as i32 - q[i] as i32).abs() > 24))
            .count();
        assert!(
            differ * 100 < (w * h) as usize,
            "scale {k}: {differ} of {} pixels differ from the person-sized picture",
            w * h
        );
    }
}

/// A quad whose texture coordinates run from −1 to 2 across it, textured red on the left half
/// of its image and blue on the right, drawn with each glTF wrap mode: at every sampled spot
/// the GPU shows the colour [`TextureWrap::apply`] predicts (repeat tiles, mirrored repeat
/// flips every other copy, clamp continues the edge), and the three modes differ.
#[test]
fn texture_wrap_modes_are_drawn_as_gltf_defines_them() {
    use glam::{Mat4, Vec3, Vec4};
    use polypostor::character::{Bone, Material, Node, Skeleton, Submesh, Texture, TextureWrap, Transform, Vertex};
    let ctx = context();
    let renderer = CharacterRenderer::new(&ctx.device);
    let target = RenderTarget::new(&ctx.device, 160, 160);
    let vertex = |x: f32, y: f32| Vertex {
        position: Vec3::new(x, y, 0.0),
        normal: Vec3::Z,
        uv: [x + 0.5, 1.0 - y],
        color: [1.0; 4],
        bones: [0; 4],
        weights: [1.0, 0.0, 0.0, 0.0],
    };
    let (w, h) = (16u32, 4u32);
    let rgba8: Vec<u8> = (0..w * h)
        .flat_map(|i| {
            if i % w < w / 2 {
                [255, 0, 0, 255]
            } else {
                [0, 0, 255, 255]
            }
        })
        .collect();
    let mut seen = Vec::new();
    for wrap in [
        TextureWrap::Repeat,
        TextureWrap::MirroredRepeat,
        TextureWrap::ClampToEdge,
    ] {
        let c = Character {
            name: "Wall".into(),
            submeshes: vec![Submesh {
                first_index: 0,
                index_count: 6,
                material: 0,
            }],
            vertices: vec![vertex(-1.5, 0.0), vertex(1.5, 0.0), vertex(1.5, 1.0), vertex(-1.5, 1.0)],
            indices: vec![0, 1, 2, 0, 2, 3],
            materials: vec![Material {
                base_color_texture: Some(0),
                double_sided: true,
                wrap: [wrap, TextureWrap::ClampToEdge],
                ..Default::default()
            }],
            textures: vec![Texture {
                name: "halves".into(),
                width: w,
                height: h,
                rgba8: rgba8.clone(),
            }],
            skeleton: Skeleton {
                nodes: vec![Node {
                    name: "Root".into(),
                    parent: None,
                    rest: Transform::default(),
                    is_joint: true,
                }],
            },
            bones: vec![Bone {
                node: 0,
                inverse_bind: Mat4::IDENTITY,
            }],
            clips: Vec::new(),
            warnings: Vec::new(),
            up_axis: Default::default(),
            morphs: Vec::new(),
        };
        let mut gpu = GpuCharacter::new(&renderer, &ctx.device, &ctx.queue, &c);
        let cam = Camera::ortho_framing(Vec3::new(-1.5, 0.0, 0.0), Vec3::new(1.5, 1.0, 0.0), Vec3::Z, 0.05);
        let opts = DrawOptions {
            shading: Shading::Unlit,
            ..Default::default()
        };
        let pose = Pose::rest(&c);
        renderer.render(
            &ctx.device,
            &ctx.queue,
            &target,
            &mut gpu,
            &c,
            &pose,
            SkinningMode::Gpu,
            &cam,
            &opts,
        );
        let img = target.read_color(&ctx.device, &ctx.queue).unwrap();
        let m = cam.clip_from_world(1.0);
        let mut colours = Vec::new();
        // Spots a quarter of a texture copy from every seam (filtering blends near them).
        for u in [-0.75f32, -0.25, 0.25, 0.75, 1.25, 1.75] {
            let p = m * Vec4::new(u - 0.5, 0.5, 0.0, 1.0);
            let (x, y) = ((p.x / p.w + 1.0) * 0.5 * 160.0, (1.0 - p.y / p.w) * 0.5 * 160.0);
            let px = img.get_pixel(x as u32, y as u32);
            let red = px[0] > 128 && px[2] < 128;
            let blue = px[2] > 128 && px[0] < 128;
            assert!(red || blue, "{wrap:?} at u = {u}: {px:?} at ({x}, {y})");
            let expect_red = wrap.apply(u) < 0.5;
            assert_eq!(red, expect_red, "{wrap:?} at u = {u}: {px:?}");
            colours.push(red);
        }
        seen.push(colours);
    }
    assert!(
        seen[0] != seen[1] && seen[1] != seen[2] && seen[0] != seen[2],
        "{seen:?}"
    );
}
