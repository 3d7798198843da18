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

/// A character whose clip animates a morph target renders each frame's parts in that
/// frame's shape (the bake's part renders were of the rest shape: morph weights were not
/// played). Independent answer: per frame, a copy of the character without morph targets
/// whose vertices hold that frame's shape (base + weight × offsets), cut into the same parts
/// and caps and rendered alone. The morph lifts every vertex of the left half (x > 0)
/// upwards and outwards, its weight going 0 → 1 → 0 over the clip.
#[test]
fn morph_weights_shape_every_frame_of_the_part_renders() {
    use polypostor::animation::morphed_bind;
    let ctx = common::gpu();
    let mut c = polypostor::default_character::generate();
    let (size_lo, size_hi) = polypostor::character::bounds(c.vertices.iter().map(|v| v.position));
    let height = (size_hi - size_lo).y;
    common::add_lifting_morph(&mut c, 0, 0.0, glam::Vec3::new(0.05 * height, 0.08 * height, 0.0), 0.5);
    let duration = c.clips[0].duration_secs;
    let seg = auto_segment(&c);
    let caps = find_caps(&c, &seg);
    let (merged, ranges) = merge_parts(&c, &seg, &caps, &CapOverrides::default());
    assert!(!merged.morphs.is_empty() && !merged.morphs[0].vertices.is_empty());
    let times = frame_times(duration, 10.0);
    let (poses, points) = sample_frames(&merged, Some(0), &times);
    let cameras = view_cameras(&points, &directions(3, Coverage::UpperHemisphere));
    let renderer = CharacterRenderer::new(&ctx.device);
    let r = 64;
    let parts = PartRenderer::new(&renderer, &ctx.device, &ctx.queue, &merged, ranges.clone(), &poses, r);
    let mid = times.len() / 2;
    for (v, cam) in cameras.iter().enumerate() {
        let img = parts.render_view(&renderer, &ctx.device, &ctx.queue, cam).unwrap();
        let mut changed = 0usize;
        for f in [0, mid / 2, mid] {
            // The frame's shape held in the vertices, no morphs.
            let pose = Pose::sample(&c, &c.clips[0], times[f]);
            let mut shaped = c.clone();
            if let Some((p, n)) = morphed_bind(&c, &pose) {
                for ((vx, p), n) in shaped.vertices.iter_mut().zip(p).zip(n) {
                    vx.position = p;
                    vx.normal = n;
                }
            }
            shaped.morphs.clear();
            let (m2, r2) = merge_parts(&shaped, &seg, &caps, &CapOverrides::default());
            let one = PartRenderer::new(&renderer, &ctx.device, &ctx.queue, &m2, r2, &[poses[f].clone()], r);
            let want = one.render_view(&renderer, &ctx.device, &ctx.queue, cam).unwrap();
            let mut differ = 0usize;
            for p in 0..img.parts {
                for y in 0..r {
                    for x in 0..r {
                        let a = img.covered(p, f, x, y);
                        differ += usize::from(a != want.covered(p, 0, x, y));
                        let (ox, oy) = img.tile_origin(p, f);
                        let (wx, wy) = want.tile_origin(p, 0);
                        let ca = img.color.get_pixel(ox + x, oy + y).0;
                        let cb = want.color.get_pixel(wx + x, wy + y).0;
                        differ += usize::from(ca.iter().zip(cb).any(|(a, b)| a.abs_diff(b) > 8));
                        if f == mid {
                            let c0 = img
                                .color
                                .get_pixel(img.tile_origin(p, 0).0 + x, img.tile_origin(p, 0).1 + y)
                                .0;
                            let c_mid = img.color.get_pixel(ox + x, oy + y).0;
                            changed += usize::from(c0 != c_mid);
                        }
                    }
                }
            }
            assert!(
                differ <= 4,
                "view {v} frame {f}: {differ} pixels differ from the shaped copy"
            );
        }
        assert!(
            changed > 100,
            "view {v}: the morph changed only {changed} pixels between frames 0 and {mid}"
        );
    }
}
