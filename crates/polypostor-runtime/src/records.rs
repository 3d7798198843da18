//! Plain data the CPU crowd writes and every GPU renderer reads: the 32-byte per-character
//! [`Instance`] record with its bit layouts (frame pairs, cross-fade bits), the
//! representation [`Level`] that buckets instances, and the [`ClipTiming`] they index into.
//! Neither side owns it, so the renderers (`crate::gpu`) never import the crowd simulation
//! and the crowd never imports a renderer.

/// A representation a character can be drawn with.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize)]
pub enum Level {
    /// The character's own mesh, skinned on the GPU every frame (the nearest level).
    Skinned = 0,
    /// The full mesh pre-skinned at every baked frame (`rigid.bin`): no skinning at run time.
    Rigid = 1,
    /// The Polypostor pack: per view, each body part a 2D polygon that moves with the frames,
    /// textured from the part's key-frame images (the middle distance).
    Polypostor = 2,
    /// The classic animated impostor: one colour and one normal image per view and frame (far).
    Impostor = 3,
    /// The NP3D impostor: a simplified mesh skinned at every frame, textured from per-view
    /// key-frame images.
    Np3d = 4,
}

impl Level {
    /// Number of levels: the length of every per-level array (indexed by `level as usize`).
    pub const COUNT: usize = 5;
    /// Every level, in the order of their indices.
    pub const ALL: [Level; Level::COUNT] = [
        Level::Skinned,
        Level::Rigid,
        Level::Polypostor,
        Level::Impostor,
        Level::Np3d,
    ];

    /// Short lower-case name for statistics and logs: `skinned`, `rigid`, `polypostor`, `impostor`
    /// or `np3d`.
    pub fn name(self) -> &'static str {
        match self {
            Level::Skinned => "skinned",
            Level::Rigid => "rigid",
            Level::Polypostor => "polypostor",
            Level::Impostor => "impostor",
            Level::Np3d => "np3d",
        }
    }
}

/// One visible character, as the GPU renderers read it (32 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Instance {
    /// Position on the ground (x, z).
    pub pos: [f32; 2],
    /// `(sin h, cos h)` of the heading `h` about +Y.
    pub facing: [f32; 2],
    /// Viewpoint index (image-based representations; 0 for meshes).
    pub view: u32,
    /// Animation frames: the one drawn (bits 0..16) and the one it blends towards (bits
    /// 16..32: the next as its clip plays), see [`frame_pair`]; `blend` goes from the first
    /// to the second.
    pub frame: u32,
    /// How far (0..1) the drawn frame has blended towards the next one in `frame`.
    pub blend: f32,
    /// Appearance seed in bits 0..24 ([`VARIANT_SEED_MASK`]); bits 24..31 a cross-fade amount
    /// `q` (0: drawn whole; 1..=127: drawn where the screen's dither threshold is below
    /// `q / 128`); bit 31 flips that (the outgoing copy draws exactly the other pixels). See
    /// [`fade_bits`].
    pub variant: u32,
}

/// The bits of [`Instance::variant`] that seed a character's appearance.
pub const VARIANT_SEED_MASK: u32 = 0x00FF_FFFF;

/// The cross-fade bits of [`Instance::variant`] for progress `t` (0..1) of a fade: the
/// incoming copy (`outgoing` false) is drawn where the screen-space dither threshold is below
/// about `t`, the outgoing copy everywhere else, with the same threshold per pixel, so the
/// two together cover exactly what one would (nothing see-through, nothing twice). `t` at or
/// past 1 gives 0: drawn whole.
pub fn fade_bits(t: f32, outgoing: bool) -> u32 {
    if !(t < 1.0) {
        return 0;
    }
    let q = (t.max(0.0) * 128.0).round().clamp(1.0, 127.0) as u32;
    (q << 24) | if outgoing { 1 << 31 } else { 0 }
}

/// Whether a pixel with dither threshold `d` (0..1) is drawn for cross-fade bits `bits` (the
/// rule the crowd shaders apply; see `crowd_common.wgsl`).
pub fn fade_keeps(bits: u32, d: f32) -> bool {
    let q = (bits >> 24) & 0x7F;
    if q == 0 {
        return true;
    }
    (d < q as f32 / 128.0) != (bits >> 31 == 1)
}

/// [`Instance::frame`] for the frame drawn `f0` and the frame it blends towards `f1` (both
/// below 65,536: the frame limit is 10,000).
pub fn frame_pair(f0: u32, f1: u32) -> u32 {
    (f0 & 0xffff) | (f1 << 16)
}

/// The two frames of an [`Instance::frame`].
pub fn frame_pair_parts(packed: u32) -> (u32, u32) {
    (packed & 0xffff, packed >> 16)
}

/// [`frame_pair`] of frame `f` of one loop of `frames` and the one after it (`f` wrapped).
pub fn looping_pair(f: u32, frames: u32) -> u32 {
    let n = frames.max(1);
    frame_pair(f % n, (f % n + 1) % n)
}

/// Both frames of an [`Instance::frame`] wrapped below `frames` (what the shaders read).
pub fn wrap_frame_pair(packed: u32, frames: u32) -> u32 {
    let n = frames.max(1);
    let (a, b) = frame_pair_parts(packed);
    frame_pair(a % n, b % n)
}

/// Counting sort of `instances` by view into `out` (views clamped below `views`, frames
/// wrapped below `frames`), with each view's range of `out` in `ranges` (one per view): what
/// the Polypostor renderer uploads, one indexed draw per view. Linear time, no allocation
/// once warm.
pub fn sort_by_view(
    instances: &[Instance],
    views: u32,
    frames: u32,
    out: &mut Vec<Instance>,
    ranges: &mut Vec<std::ops::Range<u32>>,
) {
    let views = views.max(1) as usize;
    let frames = frames.max(1);
    ranges.clear();
    ranges.resize(views, 0..0);
    // Counts in `end`; then each range becomes `start..start` and `end` the write cursor.
    for i in instances {
        ranges[(i.view as usize).min(views - 1)].end += 1;
    }
    let mut at = 0u32;
    for r in ranges.iter_mut() {
        let n = r.end;
        *r = at..at;
        at += n;
    }
    out.clear();
    out.resize(instances.len(), Instance::default());
    for i in instances {
        let v = (i.view as usize).min(views - 1);
        out[ranges[v].end as usize] = Instance {
            view: v as u32,
            frame: wrap_frame_pair(i.frame, frames),
            ..*i
        };
        ranges[v].end += 1;
    }
}

/// The animation the instances index into.
#[derive(Clone, Copy, Debug)]
pub struct ClipTiming {
    /// Frames of the baked timeline, every clip back to back; without a clip table the one clip
    /// loops over all of them.
    pub frames: usize,
    /// Frames per second the timeline was baked at (agents' clocks turn into frames at it).
    pub fps: f32,
}
