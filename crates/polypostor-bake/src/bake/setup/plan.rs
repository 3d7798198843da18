//! What a bake will take, checked before any work starts: every setting against its
//! documented limit ([`crate::limits`]), the clip's frame count, the segmentation's part
//! count, the character's extent, the GPU's texture limit for the sheets the bake writes,
//! and the estimated peak memory against a budget. A bake that would fail or exhaust the
//! machine minutes in is refused at once with the limit it hits and what would fit.

use crate::bake::pipeline::{BakeOptions, KeyFrame};
use crate::bake::segment::Segmentation;
use crate::character::Character;
use crate::limits::{
    BAKE_MEMORY_BUDGET, LimitError, MAX_FPS, MAX_PARTS, MAX_RESOLUTION, MAX_VIEWS, MIN_FPS, MIN_RESOLUTION, human_bytes,
};
use polypostor_runtime::reps::RepSet;

/// Largest coordinate of a bakeable character over its clip, in scene units (beyond it the
/// framing and the 16-bit vertex data lose all precision).
pub const MAX_EXTENT: f32 = 1e12;
/// Smallest size (largest side of its bounds over the clip) of a bakeable character, in scene
/// units: below it the pack's cameras are too small for the loader (a character 2e-12 units
/// tall was baked whole, then refused as a damaged pack).
pub const MIN_EXTENT: f32 = 1e-8;
/// Memory a bake takes whatever its settings (see [`check`]'s estimate).
pub const PROCESS_BYTES: u64 = 256 << 20;
/// Memory the part images of the views being fitted at once may take; fewer views are kept
/// in flight when each is large.
pub const VIEWS_IN_FLIGHT_BUDGET: u64 = 2 << 30;

/// A checked bake: what it will produce and roughly what it needs.
#[derive(Clone, Debug, PartialEq)]
pub struct BakePlan {
    pub views: usize,
    pub frames: usize,
    pub parts: usize,
    pub resolution: u32,
    /// Views whose part images are held at once while fitting.
    pub views_in_flight: usize,
    /// Estimated peak memory of the bake.
    pub estimated_bytes: u64,
    /// The budget it was checked against.
    pub budget_bytes: u64,
}

/// Bytes of one view's part images while it is fitted, per pixel of every part and frame: the
/// renders (colour, normal, depth: 12), the fitter's copy (seven floats: 28) and the fit's
/// working data per frame (12). Measured on a 1-part character with 1,000 and 3,000 frames
/// (4 views): about 49 bytes a pixel at the peak, where 20 were counted (a bake planned at
/// 2.7 GiB took 7.3 GB); with this count and the views in flight it sets, planned at 2.6 and
/// 5.0 GiB, they peaked at 2.5 and 5.0 GiB.
pub fn view_image_bytes(parts: usize, frames: usize, resolution: u32) -> u64 {
    let px = u64::from(resolution) * u64::from(resolution);
    (parts as u64)
        .saturating_mul(frames as u64)
        .saturating_mul(px)
        .saturating_mul(12 + 28 + 12)
}

/// How many views' images the bake keeps in flight: twice the worker threads, fewer when
/// their images would pass [`VIEWS_IN_FLIGHT_BUDGET`], at least one.
pub fn views_in_flight(parts: usize, frames: usize, resolution: u32, threads: usize) -> usize {
    let per_view = view_image_bytes(parts, frames, resolution).max(1);
    let by_memory = (VIEWS_IN_FLIGHT_BUDGET / per_view).max(1);
    (2 * threads.max(1))
        .min(by_memory.min(usize::MAX as u64) as usize)
        .max(1)
}

/// The memory budget on this machine: [`BAKE_MEMORY_BUDGET`], or three quarters of the
/// physical memory where that is less.
pub fn memory_budget() -> u64 {
    let physical = physical_memory().map_or(u64::MAX, |m| m / 4 * 3);
    BAKE_MEMORY_BUDGET.min(physical)
}

fn physical_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Checks a bake of `set` before it starts. `max_texture_side`: the GPU's largest texture
/// side (the sheets the crowd loads must fit it).
/// Farthest a character may stand from the origin, in multiples of its size, for a bake to
/// keep its detail in single precision (a 1.8 m person up to 18 km out).
pub const MAX_OFFSET_OVER_SIZE: f32 = 10_000.0;

pub fn check(
    character: &Character,
    segmentation: &Segmentation,
    options: &BakeOptions,
    set: RepSet,
    max_texture_side: u32,
) -> Result<BakePlan, LimitError> {
    let fail = |m: String| Err(LimitError(m));
    if options.views == 0 || options.views > MAX_VIEWS {
        return fail(format!("{} views: choose 1 to {MAX_VIEWS}", options.views));
    }
    let r = options.resolution;
    if !(MIN_RESOLUTION..=MAX_RESOLUTION).contains(&r) {
        return fail(format!(
            "resolution {r}: choose {MIN_RESOLUTION} to {MAX_RESOLUTION} pixels"
        ));
    }
    if !(options.fps.is_finite() && options.fps >= MIN_FPS && options.fps <= MAX_FPS) {
        return fail(format!(
            "{} frames per second: choose {MIN_FPS} to {MAX_FPS}",
            options.fps
        ));
    }
    let frames = crate::timeline::Timeline::new(character, &options.clip_list(), options.fps)?.frames();
    if let KeyFrame::Frame(k) = options.key_frame
        && k >= frames
    {
        return fail(format!(
            "key frame {k} is out of range: the bake has {frames} frames (0 to {})",
            frames - 1
        ));
    }
    if segmentation.labels.len() != character.triangle_count() {
        return fail(format!(
            "the segmentation has {} labels but the character has {} triangles",
            segmentation.labels.len(),
            character.triangle_count()
        ));
    }
    let parts = segmentation.parts.len();
    if parts == 0 || parts > MAX_PARTS {
        return fail(format!(
            "the segmentation has {parts} parts; a bake takes 1 to {MAX_PARTS} (merge some parts)"
        ));
    }
    if let Some(l) = segmentation.labels.iter().find(|&&l| l as usize >= parts) {
        return fail(format!(
            "the segmentation labels a triangle with part {l}, which does not exist"
        ));
    }
    if character.triangle_count() == 0 {
        return fail("the character has no triangles".into());
    }
    if !character.submeshes.is_empty() && character.submeshes_drawing_nothing().iter().all(|&n| n) {
        return fail(
            "nothing of the character is drawn: every material cuts out below an alpha its colour never reaches (alpha mode MASK with a high cut-off, or BLEND with alpha under 0.5); nothing to bake"
                .into(),
        );
    }
    let (lo, hi) = options
        .clip_list()
        .iter()
        .map(|&c| crate::animation::clip_bounds(character, c, 16))
        .fold((glam::Vec3::INFINITY, glam::Vec3::NEG_INFINITY), |(a, b), (lo, hi)| {
            (a.min(lo), b.max(hi))
        });
    let extent = hi - lo;
    if !(lo.is_finite() && hi.is_finite() && extent.is_finite())
        || lo.abs().max_element() > MAX_EXTENT
        || hi.abs().max_element() > MAX_EXTENT
    {
        return fail(format!(
            "the character's positions over the clip reach {:?}..{:?}, beyond the limit of {MAX_EXTENT:e} scene units",
            lo.to_array(),
            hi.to_array()
        ));
    }
    // Far from the origin for its size, single-precision positions lose the detail of the
    // character (the cameras built around it stop agreeing with their own directions: a bake
    // 100 km out failed when its pack was read back).
    let size = extent.max_element();
    if size > 0.0 && size < MIN_EXTENT {
        return fail(format!(
            "the character is {size:.4e} scene units across, below the smallest bakeable size of {MIN_EXTENT:e}: scale it up in the file (a root node's scale)"
        ));
    }
    let offset = ((lo + hi) * 0.5).length();
    if size > 0.0 && offset > MAX_OFFSET_OVER_SIZE * size {
        return fail(format!(
            "the character stands {offset:.4e} units from the origin, {:.0} times its size of {size:.4e}: single precision loses its detail there (at most {MAX_OFFSET_OVER_SIZE:.0}×); move it near the origin in the file",
            offset / size
        ));
    }
    // A character scaled to nothing in every baked frame (a clip that animates its scale to
    // 0) would bake to an empty pack that reports a perfect fit.
    let clips = options.clip_list();
    let visible = clips.iter().any(|&c| {
        let duration = c.and_then(|i| character.clips.get(i)).map_or(0.0, |c| c.duration_secs);
        (0..16).any(|s| {
            let pose = crate::animation::Pose::sample_index(character, c, duration * s as f32 / 16.0);
            let (lo, hi) = crate::character::bounds(crate::animation::skin_vertices(character, &pose).0);
            // Rounding in the skinning leaves a point-sized character a few ulps wide.
            let far = lo.abs().max(hi.abs()).max_element().max(f32::MIN_POSITIVE);
            (hi - lo).max_element() > 1e-5 * far
        })
    });
    if !visible {
        return fail(
            "the character has no size in any baked frame (every vertex at one point: a scale animated to 0?); nothing to bake"
                .into(),
        );
    }
    if !(extent.max_element() > 0.0) {
        return fail("the character has no extent (every vertex lies at one point)".into());
    }

    // Sheets the crowd loads as single textures.
    let side = max_texture_side.min(polypostor_runtime::pack::MAX_ATLAS_SIDE);
    if set.impostor {
        let columns = polypostor_runtime::reps::sheet_columns(frames);
        let rows = (frames as u32).div_ceil(columns);
        if u64::from(columns.max(rows)) * u64::from(r) > u64::from(side) {
            return fail(format!(
                "impostor sheets of {frames} frames at {r}² would be {}×{} pixels, more than the texture limit of {side}: lower --resolution or --fps, or bake a shorter clip or fewer clips",
                u64::from(columns) * u64::from(r),
                u64::from(rows) * u64::from(r)
            ));
        }
    }
    if set.np3d {
        let columns = (options.views as f64).sqrt().ceil().max(1.0) as u64;
        let rows = (options.views as u64).div_ceil(columns);
        if columns.max(rows) * u64::from(r) > u64::from(side) {
            return fail(format!(
                "the NP3D image sheet of {} views at {r}² would be {}×{} pixels, more than the texture limit of {side}: fewer views or a lower resolution",
                options.views,
                columns * u64::from(r),
                rows * u64::from(r)
            ));
        }
    }

    // Peak memory.
    let px = u64::from(r) * u64::from(r);
    let views = options.views as u64;
    let f = frames as u64;
    let threads = rayon::current_num_threads();
    let in_flight = views_in_flight(parts, frames, r, threads);
    // The process itself: the GPU driver (a software rasteriser's threads and buffers), the
    // character, the segmentation (about 0.3 GB measured beside a 1,000-frame bake's images).
    let mut bytes = PROCESS_BYTES;
    if set.polypostor {
        // Images of the views in flight (+1 being rendered), the key-frame images every view
        // keeps (colour + normal), and every frame's colour when debug images are asked for.
        bytes = bytes
            .saturating_add(view_image_bytes(parts, frames, r).saturating_mul((in_flight as u64 + 1).min(views)))
            .saturating_add(views.saturating_mul(parts as u64).saturating_mul(px).saturating_mul(8));
        if options.keep_frame_images {
            bytes = bytes.saturating_add(
                views
                    .saturating_mul(parts as u64)
                    .saturating_mul(f)
                    .saturating_mul(px)
                    .saturating_mul(4),
            );
        }
    }
    if set.impostor {
        // Colour + normal sheets of every view, and their PNG copies while writing.
        bytes = bytes.saturating_add(views.saturating_mul(f).saturating_mul(px).saturating_mul(8 + 4));
    }
    if set.np3d {
        bytes = bytes.saturating_add(views.saturating_mul(px).saturating_mul(8));
    }
    if !character.morphs.is_empty() {
        // Each frame's morphed vertices (positions and normals) for the part renders.
        bytes = bytes.saturating_add((character.vertices.len() as u64).saturating_mul(f).saturating_mul(24));
    }
    if set.rigid || set.np3d {
        bytes = bytes.saturating_add(
            (character.vertices.len() as u64)
                .saturating_mul(f)
                .saturating_mul(24 * 2),
        );
    }
    let budget = memory_budget();
    if bytes > budget {
        return fail(format!(
            "this bake would need about {} of memory, more than the budget of {} (the smaller of {} and three quarters of this machine's memory): lower --resolution, --views or --fps, or bake fewer representations",
            human_bytes(bytes),
            human_bytes(budget),
            human_bytes(BAKE_MEMORY_BUDGET)
        ));
    }
    Ok(BakePlan {
        views: options.views,
        frames,
        parts,
        resolution: r,
        views_in_flight: in_flight,
        estimated_bytes: bytes,
        budget_bytes: budget,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn setup() -> (Character, Segmentation) {
        let c = crate::default_character::generate();
        let seg = crate::bake::segment::auto_segment(&c);
        (c, seg)
    }

    /// A character far from the origin for its size is refused before any work, naming how
    /// far; 1,000 sizes out passes.
    #[test]
    fn a_character_far_from_the_origin_is_refused() {
        let (c, seg) = setup();
        let moved = |by: f32| {
            let mut m = c.clone();
            for n in m.skeleton.nodes.iter_mut().filter(|n| n.parent.is_none()) {
                n.rest.translation.x += by;
            }
            for clip in &mut m.clips {
                for ch in &mut clip.channels {
                    if m.skeleton.nodes[ch.node].parent.is_none()
                        && let crate::character::ChannelValues::Translation(v) = &mut ch.values
                    {
                        v.iter_mut().for_each(|t| t.x += by);
                    }
                }
            }
            m
        };
        assert!(check(&moved(1800.0), &seg, &BakeOptions::default(), RepSet::POLYPOSTOR, 16384).is_ok());
        let e = check(
            &moved(100_000.0),
            &seg,
            &BakeOptions::default(),
            RepSet::POLYPOSTOR,
            16384,
        )
        .unwrap_err();
        assert!(e.0.contains("from the origin"), "{e}");
    }

    /// A character whose every material cuts out all its fragments (alpha 0.5 under a
    /// cut-off of 1.0: baked to an empty pack reporting 99 dB) is refused before any work;
    /// one visible material is enough to pass.
    #[test]
    fn a_character_that_draws_nothing_is_refused() {
        let (mut c, seg) = setup();
        for m in &mut c.materials {
            m.alpha_cutoff = 1.0;
            m.base_color_factor[3] = 0.5;
        }
        let e = check(&c, &seg, &BakeOptions::default(), RepSet::POLYPOSTOR, 16384).unwrap_err();
        assert!(e.0.contains("nothing of the character is drawn"), "{e}");
        c.materials[0].base_color_factor[3] = 1.0;
        assert!(check(&c, &seg, &BakeOptions::default(), RepSet::POLYPOSTOR, 16384).is_ok());
    }

    /// A character too small for the pack's numbers (2e-12 units tall was baked whole, then
    /// refused as a damaged pack) is refused before any work, naming its size; a thousandth of
    /// a millimetre passes.
    #[test]
    fn a_character_too_small_is_refused_by_its_size() {
        let (c, seg) = setup();
        let scaled = |k: f32| {
            let mut m = c.clone();
            for n in m.skeleton.nodes.iter_mut().filter(|n| n.parent.is_none()) {
                n.rest.scale *= k;
                n.rest.translation *= k;
            }
            for clip in &mut m.clips {
                for ch in &mut clip.channels {
                    if m.skeleton.nodes[ch.node].parent.is_none() {
                        match &mut ch.values {
                            crate::character::ChannelValues::Scale(v) => v.iter_mut().for_each(|s| *s *= k),
                            crate::character::ChannelValues::Translation(v) => v.iter_mut().for_each(|t| *t *= k),
                            _ => {}
                        }
                    }
                }
            }
            m
        };
        assert!(check(&scaled(1e-6), &seg, &BakeOptions::default(), RepSet::POLYPOSTOR, 16384).is_ok());
        for k in [1e-10f32, 1e-12] {
            let e = check(&scaled(k), &seg, &BakeOptions::default(), RepSet::POLYPOSTOR, 16384).unwrap_err();
            assert!(e.0.contains("smallest bakeable size"), "{k}: {e}");
        }
    }

    /// A character scaled to nothing (every vertex at one point in every frame) is refused
    /// before any work; the same character at its size passes.
    #[test]
    fn a_character_with_no_size_is_refused() {
        let (mut c, seg) = setup();
        assert!(check(&c, &seg, &BakeOptions::default(), RepSet::POLYPOSTOR, 16384).is_ok());
        for n in c.skeleton.nodes.iter_mut().filter(|n| n.parent.is_none()) {
            n.rest.scale = glam::Vec3::ZERO;
        }
        for clip in &mut c.clips {
            for ch in &mut clip.channels {
                if let crate::character::ChannelValues::Scale(v) = &mut ch.values {
                    v.iter_mut().for_each(|s| *s = glam::Vec3::ZERO);
                }
            }
        }
        let e = check(&c, &seg, &BakeOptions::default(), RepSet::POLYPOSTOR, 16384).unwrap_err();
        assert!(e.0.contains("no size"), "{e}");
    }

    #[test]
    fn default_settings_pass_and_absurd_ones_are_refused_with_their_limit() {
        let (c, seg) = setup();
        let ok = check(&c, &seg, &BakeOptions::default(), RepSet::ALL, 16384).unwrap();
        assert_eq!((ok.views, ok.frames, ok.parts), (137, 10, 5));
        assert!(ok.estimated_bytes < 2 << 30, "{}", ok.estimated_bytes);
        let refused = |o: BakeOptions, set: RepSet, want: &str| {
            let e = check(&c, &seg, &o, set, 16384).unwrap_err();
            assert!(e.0.contains(want), "{e}");
        };
        let d = BakeOptions::default;
        refused(BakeOptions { views: 100_000, ..d() }, RepSet::ALL, "4096");
        refused(BakeOptions { views: 0, ..d() }, RepSet::ALL, "views");
        refused(
            BakeOptions {
                resolution: 4096,
                ..d()
            },
            RepSet::ALL,
            "2048",
        );
        refused(BakeOptions { fps: 0.0, ..d() }, RepSet::ALL, "frames per second");
        refused(BakeOptions { fps: f32::NAN, ..d() }, RepSet::ALL, "frames per second");
        refused(
            BakeOptions {
                key_frame: KeyFrame::Frame(10),
                ..d()
            },
            RepSet::ALL,
            "key frame",
        );
        // 2048² at 137 views: the key images alone pass the memory budget.
        refused(
            BakeOptions {
                resolution: 2048,
                ..d()
            },
            RepSet::POLYPOSTOR,
            "memory",
        );
        refused(
            BakeOptions {
                resolution: 2048,
                ..d()
            },
            RepSet::ALL,
            "texture limit",
        );
        // Impostor sheets past the texture limit.
        refused(
            BakeOptions {
                resolution: 2048,
                views: 1,
                fps: 100.0,
                ..d()
            },
            RepSet::parse("impostor").unwrap(),
            "texture limit",
        );
        // More parts than the visibility order takes.
        let mut many = seg.clone();
        for k in 0..20 {
            many.parts.push(crate::bake::segment::Part {
                name: format!("extra {k}"),
                color: [9, 9, 9],
            });
        }
        let e = check(&c, &many, &d(), RepSet::ALL, 16384).unwrap_err();
        assert!(e.0.contains("25 parts") && e.0.contains("20"), "{e}");
    }

    #[test]
    fn long_clips_and_absurd_positions_are_refused_before_the_work() {
        let (mut c, seg) = setup();
        let mut long = c.clone();
        long.clips[0].duration_secs = 1e30;
        let e = check(&long, &seg, &BakeOptions::default(), RepSet::ALL, 16384).unwrap_err();
        assert!(e.0.contains("10000") && e.0.contains(&long.clips[0].name), "{e}");
        for v in &mut c.vertices {
            v.position *= 3e38;
        }
        let e = check(&c, &seg, &BakeOptions::default(), RepSet::ALL, 16384).unwrap_err();
        assert!(e.0.contains("beyond the limit"), "{e}");
    }

    #[test]
    fn views_in_flight_shrink_with_their_images() {
        assert_eq!(views_in_flight(5, 10, 128, 2), 4);
        let by_memory = (VIEWS_IN_FLIGHT_BUDGET / view_image_bytes(5, 10, 128)) as usize;
        assert_eq!(views_in_flight(5, 10, 128, 64), by_memory.min(128));
        assert!(by_memory > 32);
        let big = views_in_flight(20, 100, 2048, 64);
        assert_eq!(big, 1);
        let mid = views_in_flight(5, 2, 1024, 64);
        assert!(mid < 128 && mid >= 1 && view_image_bytes(5, 2, 1024) * mid as u64 <= VIEWS_IN_FLIGHT_BUDGET);
    }
}
