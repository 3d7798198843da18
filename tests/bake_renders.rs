//! Part renders of the bake: every part of every frame in its tile, the union of the parts
//! equal to the whole character's render, nothing cut at the tile borders.

mod common;

use polypostor::animation::Pose;
use polypostor::bake::caps::{CapOverrides, find_caps};
use polypostor::bake::renders::{frame_times, merge_parts, sample_frames, view_cameras};
use polypostor::bake::segment::auto_segment;
use polypostor::bake::viewpoints::{Coverage, directions};
use polypostor::gpu::*;

/// The default character's parts merged, its Walk frames and `views` cameras.
struct Setup {
    ctx: GpuContext,
    c: polypostor::Character,
    seg: polypostor::bake::segment::Segmentation,
    merged: polypostor::Character,
    ranges: Vec<Vec<polypostor::character::Submesh>>,
    times: Vec<f32>,
    poses: Vec<Pose>,
    cameras: Vec<Camera>,
    renderer: CharacterRenderer,
}

fn setup(views: usize) -> Setup {
    let ctx = common::gpu();
    let c = polypostor::default_character::generate();
    let seg = auto_segment(&c);
    let caps = find_caps(&c, &seg);
    let (merged, ranges) = merge_parts(&c, &seg, &caps, &CapOverrides::default());
    let times = frame_times(c.clips[0].duration_secs, 10.0);
    let (poses, points) = sample_frames(&merged, Some(0), &times);
    let cameras = view_cameras(&points, &directions(views, Coverage::UpperHemisphere));
    let renderer = CharacterRenderer::new(&ctx.device);
    Setup {
        ctx,
        c,
        seg,
        merged,
        ranges,
        times,
        poses,
        cameras,
        renderer,
    }
}

#[test]
fn part_tiles_cover_the_character_exactly() {
    let Setup {
        ctx,
        c,
        seg,
        merged,
        ranges,
        times,
        poses,
        cameras,
        renderer,
    } = setup(5);
    let r = 96;
    let parts = PartRenderer::new(&renderer, &ctx.device, &ctx.queue, &merged, ranges, &poses, r);
    let mut whole = GpuCharacter::new(&renderer, &ctx.device, &ctx.queue, &c);
    let target = RenderTarget::new(&ctx.device, r, r);
    for (v, cam) in cameras.iter().enumerate() {
        let img = parts.render_view(&renderer, &ctx.device, &ctx.queue, cam).unwrap();
        assert_eq!((img.parts, img.frames), (seg.parts.len(), times.len()));
        for f in [0, times.len() / 2] {
            let mut union = vec![false; (r * r) as usize];
            for p in 0..img.parts {
                let mut n = 0;
                for y in 0..r {
                    for x in 0..r {
                        if img.covered(p, f, x, y) {
                            n += 1;
                            union[(y * r + x) as usize] = true;
                            let border = x == 0 || y == 0 || x == r - 1 || y == r - 1;
                            assert!(!border, "view {v} part {p} frame {f}: touches the tile border");
                        }
                    }
                }
                assert!(n > 20, "view {v} part {p} frame {f}: only {n} pixels");
            }
            let pose = Pose::sample(&c, &c.clips[0], times[f]);
            let opts = DrawOptions {
                shading: Shading::Unlit,
                ..Default::default()
            };
            renderer.render(
                &ctx.device,
                &ctx.queue,
                &target,
                &mut whole,
                &c,
                &pose,
                SkinningMode::Gpu,
                cam,
                &opts,
            );
            let full = target.read_normal(&ctx.device, &ctx.queue).unwrap();
            let full: Vec<bool> = full.pixels().map(|p| p[3] > 127).collect();
            let inter = union.iter().zip(&full).filter(|(a, b)| **a && **b).count() as f64;
            let uni = union.iter().zip(&full).filter(|(a, b)| **a || **b).count() as f64;
            assert!(
                inter / uni > 0.98,
                "view {v} frame {f}: part union vs whole IoU {}",
                inter / uni
            );
            if std::env::var_os("POLYPOSTOR_TEST_IMAGES").is_some() {
                img.color
                    .save(std::env::temp_dir().join(format!("parts-view{v}.png")))
                    .unwrap();
            }
        }
    }
}

/// Where the device cannot hold every tile in one target (long clips, high resolutions), the
/// tiles are drawn in batches through a smaller one: the images are the same.
#[test]
fn batched_part_renders_equal_one_pass() {
    let Setup {
        ctx,
        merged,
        ranges,
        poses,
        cameras,
        renderer,
        ..
    } = setup(3);
    let r = 64;
    let one = PartRenderer::new(&renderer, &ctx.device, &ctx.queue, &merged, ranges.clone(), &poses, r);
    // Three tiles per side: 5 parts × 10 frames in six batches, the last one partial.
    let batched = PartRenderer::with_max_side(&renderer, &ctx.device, &ctx.queue, &merged, ranges, &poses, r, 3 * r);
    for cam in &cameras {
        let a = one.render_view(&renderer, &ctx.device, &ctx.queue, cam).unwrap();
        let b = batched.render_view(&renderer, &ctx.device, &ctx.queue, cam).unwrap();
        assert_eq!((a.parts, a.frames), (b.parts, b.frames));
        assert_eq!(a.color.dimensions(), b.color.dimensions());
        let differ = |x: &image::RgbaImage, y: &image::RgbaImage| {
            x.pixels()
                .zip(y.pixels())
                .filter(|(p, q)| p.0.iter().zip(q.0.iter()).any(|(u, v)| u.abs_diff(*v) > 2))
                .count()
        };
        assert_eq!(differ(&a.color, &b.color), 0, "colour differs");
        assert_eq!(differ(&a.normal, &b.normal), 0, "normals differ");
        // Depth is interpolated from another viewport origin: equal to float rounding.
        let worst = a
            .depth
            .data
            .iter()
            .zip(&b.depth.data)
            .map(|(u, v)| (*u - *v).abs())
            .fold(0.0f32, f32::max);
        assert!(worst < 1e-4, "depth differs by {worst}");
        let covered = a.normal.pixels().filter(|p| p[3] > 127).count();
        assert!(covered > 1000, "the character is drawn ({covered} pixels)");
    }
}
