//! The crowd at run time, on the CPU: agents wandering on a ground plane without collisions
//! (an occupancy grid, as in the NP3D paper), frustum culling, the level of detail of each
//! visible character from its pixel-to-texel ratio (with hysteresis so it does not pop), the
//! view it is seen from and its animation frame, written as compact per-instance records for
//! the GPU renderers. Everything here is deterministic from a seed and allocation-free per
//! frame once warm.

pub mod frustum;
pub mod grid;
pub mod lod;
pub mod rng;

pub use crate::records::{
    ClipTiming, Instance, Level, VARIANT_SEED_MASK, fade_bits, fade_keeps, frame_pair, frame_pair_parts, looping_pair,
    sort_by_view, wrap_frame_pair,
};

use std::time::Instant;

use glam::{Mat4, Vec2, Vec3};

use crate::viewpoints::ViewLookup;
use frustum::Frustum;
use grid::OccupancyGrid;
use lod::LodPolicy;
use rng::Rng;

/// How big a character is, in metres (glTF's unit, after every node transform: a model
/// authored in centimetres under a 0.01 root scale measures in metres here), over its clip.
/// The crowd's spacing, walking speeds, culling, level-of-detail sizes, cameras and ground
/// follow it, so a fox, a giant and a person each walk at their own scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CharacterSize {
    /// The lowest point over the clip: the ground the character stands on.
    pub ground_y: f32,
    /// Top minus bottom over the clip.
    pub height: f32,
    /// The longer horizontal side of the bounds (a quadruped's body length).
    pub length: f32,
    /// Centre of the bounds over the clip, in the character's own frame.
    pub centre: Vec3,
    /// Radius of the sphere about `centre` that holds the character at every frame.
    pub radius: f32,
}

impl CharacterSize {
    /// Size of the reference character the crowd's defaults are made for: a 1.8 m person.
    pub const REFERENCE_METRES: f32 = 1.8;

    /// The reference person: 1.8 m tall, 0.8 m across, standing on y = 0.
    pub fn reference() -> Self {
        Self::from_bounds(Vec3::new(-0.4, 0.0, -0.4), Vec3::new(0.4, 1.8, 0.4))
    }

    /// From bounds over the clip (an empty or non-finite box gives the reference).
    pub fn from_bounds(min: Vec3, max: Vec3) -> Self {
        let size = max - min;
        if !(min.is_finite() && max.is_finite()) || size.max_element() <= 0.0 {
            return Self::reference();
        }
        Self {
            ground_y: min.y,
            height: size.y,
            length: size.x.max(size.z),
            centre: 0.5 * (min + max),
            radius: 0.5 * size.length(),
        }
    }

    /// Measured over `clip` (`None`: the rest pose), skinned at 16 times.
    pub fn measure(character: &crate::character::Character, clip: Option<usize>) -> Self {
        Self::measure_clips(character, &[clip])
    }

    /// Measured over every clip of `clips` together (each skinned at 16 times).
    pub fn measure_clips(character: &crate::character::Character, clips: &[Option<usize>]) -> Self {
        let (min, max) = clips
            .iter()
            .map(|&c| crate::animation::clip_bounds(character, c, 16))
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), (lo, hi)| {
                (a.min(lo), b.max(hi))
            });
        Self::from_bounds(min, max)
    }

    /// The character's size against the reference person: its height or body length,
    /// whichever is larger, over 1.8 m (positive: a character without size counts as the
    /// smallest positive number, not as zero).
    pub fn scale(&self) -> f32 {
        let s = self.height.max(self.length) / Self::REFERENCE_METRES;
        if s.is_finite() { s.max(f32::MIN_POSITIVE) } else { 1.0 }
    }
}

/// How a crowd is laid out and moves.
#[derive(Clone, Debug, PartialEq)]
pub struct CrowdParams {
    /// Number of agents. Default value: 1000.
    pub count: usize,
    /// Agents per square metre of ground. Default value: 0.25.
    pub density: f32,
    /// Closest two agents may come (metres; also the occupancy cell size). Default value: 0.8.
    pub min_distance: f32,
    /// Walking speed range (m/s). Default value: 0.9..1.5.
    pub speed: (f32, f32),
    /// Ground speed (m/s) at which the clip plays at its own rate; agents' animation rate
    /// follows their speed against it. Default value: 1.2.
    pub stride_speed: f32,
    /// How much agents turn: the spread of their turning rate (rad/s), which drifts smoothly
    /// (it forgets itself over [`TURN_MEMORY_SECS`]), so headings curve instead of jittering
    /// frame to frame. Default value: 0.5.
    pub wander: f32,
    /// World length (metres) the baked images' texels span along their height: a character
    /// at distance `d` covers `height · focal_px / d` pixels of it, against the bake's
    /// resolution in texels (level of detail). Default value: 1.8.
    pub height: f32,
    /// The character's size: culling spheres, cameras and ground. Default value:
    /// [`CharacterSize::reference`].
    pub size: CharacterSize,
    /// Seconds a character takes to cross-fade (dithered) from one baked view or clip to
    /// the next, and a level of detail to the next in [`LEVEL_FADE_SCALE`] times that; 0
    /// switches with a cut. Default value: 0.25.
    pub fade_secs: f32,
    /// What agents spend their time doing, when the pack has clips to do it with
    /// ([`Crowd::set_clips`]). Default value: [`Behaviour::default`].
    pub behaviour: Behaviour,
    /// Seed of the crowd's random numbers: equal parameters and seed give the same crowd, frame
    /// for frame. Default value: 1.
    pub seed: u64,
}

/// Shares of agents walking, running and standing idle (any scale; only the ratios count).
/// A share needs a clip to play: running a moving clip clearly faster than the walk, idling
/// a clip that stands still; without one its share walks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Behaviour {
    /// Default value: 0.6.
    pub walk: f32,
    /// Default value: 0.2.
    pub run: f32,
    /// Default value: 0.2.
    pub idle: f32,
}

impl Default for Behaviour {
    fn default() -> Self {
        Self {
            walk: 0.6,
            run: 0.2,
            idle: 0.2,
        }
    }
}

/// What an agent is doing ([`Behaviour`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Gait {
    /// Moving at the walk clip's pace (at [`CrowdParams::speed`] without a clip table).
    Walk = 0,
    /// Moving at the run clip's pace.
    Run = 1,
    /// Standing in place (speed 0), playing an idle clip.
    Idle = 2,
}

impl Gait {
    /// A word for people: "walk", "run", "stand".
    pub fn name(self) -> &'static str {
        match self {
            Gait::Walk => "walk",
            Gait::Run => "run",
            Gait::Idle => "stand",
        }
    }
}

/// Seconds an agent keeps walking or running before it reconsiders (uniform in this range).
pub const MOVING_SECS: (f32, f32) = (4.0, 12.0);
/// Seconds an agent stands idle before it reconsiders.
pub const IDLE_SECS: (f32, f32) = (2.0, 6.0);
/// A level-of-detail cross-fade lasts this many times [`CrowdParams::fade_secs`]: two levels
/// differ more than two neighbouring views or clips of one level do (a Polypostor against an
/// impostor of a thin character: a third of its pixels), and the dither trades a share of the
/// pixels every frame in proportion to how fast the fade runs, so a slower fade spreads the
/// same change over more frames (temporal stability, `bench stability`).
pub const LEVEL_FADE_SCALE: f32 = 2.0;

/// Spread of a moving agent's speed about its clip's measured ground speed (its animation
/// rate follows, so its feet keep to the ground).
pub const SPEED_SPREAD: f32 = 0.1;

/// The pack's clips sorted by what they do: moving ones (walk, run) by measured ground
/// speed, and the ones standing still (idle).
#[derive(Clone, Debug, PartialEq)]
pub struct Gaits {
    /// The pack's clip table, as given: `walk`, `run` and `idle` index into it.
    pub clips: Vec<crate::timeline::ClipSpan>,
    /// Their frame rate.
    pub fps: f32,
    /// The clip walked (the slowest moving one), if any clip moves.
    pub walk: Option<usize>,
    /// The clip run (the fastest moving one, at least [`RUN_OVER_WALK`] × the walk's speed).
    pub run: Option<usize>,
    /// Clips standing still.
    pub idle: Vec<usize>,
}

/// How much faster than the walk a clip must move to be run.
pub const RUN_OVER_WALK: f32 = 1.3;

impl Gaits {
    /// Sorts `clips` by ground speed: a clip moving less than a tenth of the fastest (or not
    /// at all) stands still.
    pub fn new(clips: &[crate::timeline::ClipSpan], fps: f32) -> Self {
        let fastest = clips.iter().map(|c| c.ground_speed).fold(0.0f32, f32::max);
        let moving: Vec<usize> = (0..clips.len())
            .filter(|&i| fastest > 0.0 && clips[i].ground_speed > 0.1 * fastest)
            .collect();
        // Standing: still clips that loop (an idle, a wave), not a fall or a sit that ends
        // elsewhere; those only when nothing else stands.
        let still: Vec<usize> = (0..clips.len()).filter(|i| !moving.contains(i)).collect();
        let looping: Vec<usize> = still.iter().copied().filter(|&i| clips[i].looping).collect();
        let idle = if looping.is_empty() { still } else { looping };
        let by_speed = |a: &usize, b: &usize| clips[*a].ground_speed.total_cmp(&clips[*b].ground_speed);
        let walk = moving.iter().copied().min_by(by_speed);
        let run = moving
            .iter()
            .copied()
            .max_by(by_speed)
            .filter(|&r| walk.is_some_and(|w| clips[r].ground_speed >= RUN_OVER_WALK * clips[w].ground_speed));
        Self {
            clips: clips.to_vec(),
            fps: if fps.is_finite() && fps > 0.0 { fps } else { 10.0 },
            walk,
            run,
            idle,
        }
    }

    /// What clip `i` is used for: the gait it is played in, or `None` (a clip that neither
    /// moves nor loops: not played).
    pub fn role(&self, i: usize) -> Option<Gait> {
        if self.walk == Some(i) {
            Some(Gait::Walk)
        } else if self.run == Some(i) {
            Some(Gait::Run)
        } else if self.idle.contains(&i) {
            Some(Gait::Idle)
        } else {
            None
        }
    }

    /// The clip for `gait`, if the pack has one (`pick` chooses among idle clips).
    pub fn clip_for(&self, gait: Gait, pick: f32) -> Option<usize> {
        match gait {
            Gait::Walk => self.walk,
            Gait::Run => self.run,
            Gait::Idle if self.idle.is_empty() => None,
            Gait::Idle => {
                let k = ((pick.clamp(0.0, 0.999_999) * self.idle.len() as f32) as usize).min(self.idle.len() - 1);
                Some(self.idle[k])
            }
        }
    }
}

/// Most characters (packs) one crowd mixes: the first and up to seven others.
pub const MAX_SPECIES: usize = 8;

/// A character sharing the crowd with the first one (another pack): its size, the world
/// length its images span, its clips and baked views. Agents of it walk at its own clips'
/// speeds and are drawn by its own renderers ([`Crowd::instances`]`[kind]`).
#[derive(Clone, Debug)]
pub struct Species {
    /// Its size over its clips (its culling sphere).
    pub size: CharacterSize,
    /// World length the baked images' texels span along their height ([`CrowdParams::height`]).
    pub height: f32,
    /// [`CrowdParams::stride_speed`] for it (used when it has no clip table).
    pub stride_speed: f32,
    /// Its clips by gait; `None`: one clip, played at the rate its agents walk against
    /// `stride_speed`.
    pub gaits: Option<Gaits>,
    /// Its baked view directions, to choose each of its agents' view from.
    pub views: ViewLookup,
    /// Frames and frame rate of its baked animation.
    pub timing: ClipTiming,
    /// Texels of its baked images along its height (its bake's resolution): the mix's switch
    /// points are ratios of screen pixels to these, whatever resolution the policy was set
    /// for (0: the policy's own).
    pub texels: f32,
}

impl Species {
    /// A character of `size` (framing as in [`CrowdParams::for_character`]) with its clip
    /// table (`clips` empty: one clip of `timing`), baked view directions and timing.
    pub fn new(
        size: CharacterSize,
        framing: Option<f32>,
        clips: &[crate::timeline::ClipSpan],
        views: &[Vec3],
        timing: ClipTiming,
    ) -> Self {
        let p = CrowdParams::for_character(1, size, framing);
        Self {
            size,
            height: p.height,
            stride_speed: p.stride_speed,
            gaits: (!clips.is_empty()).then(|| Gaits::new(clips, timing.fps)),
            views: ViewLookup::new(views),
            timing,
            texels: 0.0,
        }
    }
}

impl Default for CrowdParams {
    fn default() -> Self {
        Self {
            count: 1000,
            density: 0.25,
            min_distance: 0.8,
            speed: (0.9, 1.5),
            stride_speed: 1.2,
            wander: 0.5,
            height: 1.8,
            size: CharacterSize::reference(),
            fade_secs: 0.25,
            behaviour: Behaviour::default(),
            seed: 1,
        }
    }
}

impl CrowdParams {
    /// `count` agents of a character of `size`, laid out and moving as the defaults do for
    /// the reference person, every length and speed scaled by [`CharacterSize::scale`] (a
    /// character twice as big keeps twice the distance, walks twice as fast and covers four
    /// times the ground, so the crowd looks the same at any size). `framing`: the world length
    /// the baked images span (default: the character's bounding diameter).
    pub fn for_character(count: usize, size: CharacterSize, framing: Option<f32>) -> Self {
        let d = Self::default();
        let s = size.scale();
        Self {
            count,
            density: d.density / (s * s),
            min_distance: d.min_distance * s,
            speed: (d.speed.0 * s, d.speed.1 * s),
            stride_speed: d.stride_speed * s,
            height: framing
                .filter(|f| f.is_finite() && *f > 0.0)
                .unwrap_or(2.0 * size.radius),
            size,
            ..d
        }
    }

    /// [`CharacterSize::scale`] of the character.
    pub fn scale(&self) -> f32 {
        self.size.scale()
    }

    /// Widens the spacing (minimum distance, ground per agent) to what a character of `size`
    /// needs, when it is bigger: a crowd mixing characters spaces everyone for the largest.
    pub fn spaced_for(&mut self, size: &CharacterSize) {
        let d = Self::default();
        let s = size.scale();
        self.min_distance = self.min_distance.max(d.min_distance * s);
        self.density = self.density.min(d.density / (s * s));
    }

    /// Spacing for a crowd that mixes its own character with characters of `sizes` in
    /// `shares` (its own first; only the ratios count): the minimum distance, which is the
    /// occupancy grid's cell, widened for the largest as [`CrowdParams::spaced_for`] does,
    /// and the ground sized for the shares — each character's agents take the ground their
    /// own size asks (in proportion to its [`CharacterSize::scale`] squared), so a few big
    /// animals among many people do not spread the people out. [`Crowd::mix`] then keeps
    /// each pair of agents the mean of their own spacings apart. Shares that do not match
    /// `sizes` or are not a valid mix: the ground of the largest, as `spaced_for` gives.
    pub fn spaced_for_shares(&mut self, sizes: &[CharacterSize], shares: &[f32]) {
        let (own, s0) = (self.density, self.scale());
        for s in sizes {
            self.spaced_for(s);
        }
        if check_shares(shares, sizes.len() + 1).is_err() || !(own > 0.0 && own.is_finite()) {
            return;
        }
        let total: f64 = shares.iter().map(|&s| s as f64).sum();
        // Ground per agent: its own character's, 1 / own, times (its scale / the own scale)².
        let per_agent: f64 = std::iter::once(s0)
            .chain(sizes.iter().map(|s| s.scale()))
            .zip(shares)
            .map(|(s, &w)| w as f64 / total * (s as f64 / s0 as f64).powi(2) / own as f64)
            .sum();
        let density = (1.0 / per_agent) as f32;
        if density.is_finite() && density > 0.0 {
            self.density = density;
        }
    }
}

/// How far (as a ratio of densities) the ground new shares of a mix ask for may be from the
/// one laid out before [`CrowdParams::respaced_for_shares`] asks for a new one.
pub const RELAY_GROUND: f32 = 0.1;

impl CrowdParams {
    /// For new `shares` of a mix laid out by [`CrowdParams::spaced_for_shares`] (these are the
    /// params it gave; `own`, the params before it): the params of a new layout when the ground
    /// the new shares ask for differs from this one by more than [`RELAY_GROUND`] (a mix
    /// tipping towards its big characters needs more ground; one tipping towards the small,
    /// less), `None` while this ground still fits. Everything but the spacing is kept.
    pub fn respaced_for_shares(&self, own: &CrowdParams, sizes: &[CharacterSize], shares: &[f32]) -> Option<Self> {
        let mut p = self.clone();
        p.density = own.density;
        p.min_distance = own.min_distance;
        p.spaced_for_shares(sizes, shares);
        let ratio = p.density / self.density;
        (!(ratio.is_finite() && (ratio - 1.0).abs() <= RELAY_GROUND)).then_some(p)
    }
}

/// Checks the shares of a crowd mixing `characters` characters (its own first): one share
/// per character, each finite and ≥ 0, not all 0 (only the ratios count).
fn check_shares(shares: &[f32], characters: usize) -> Result<(), String> {
    if shares.len() != characters {
        return Err(format!("{} shares for {characters} characters", shares.len()));
    }
    if shares.iter().any(|s| !s.is_finite() || *s < 0.0) || !(shares.iter().sum::<f32>() > 0.0) {
        return Err(format!(
            "shares {shares:?}: each must be a finite number ≥ 0, not all 0"
        ));
    }
    Ok(())
}

/// Agents, one entry per agent in each vector (structure of arrays: the per-frame passes
/// touch only what they need).
#[derive(Clone, Debug, Default)]
pub struct Agents {
    /// Position on the ground (x, z).
    pub pos: Vec<Vec2>,
    /// Facing as a unit vector `(sin h, cos h)` for the heading `h` about +Y (0 faces +Z).
    pub facing: Vec<Vec2>,
    /// Ground speed in metres per second (0 while standing idle).
    pub speed: Vec<f32>,
    /// Animation clock (seconds into the clip, before wrapping).
    pub clock: Vec<f32>,
    /// Animation rate (1 = the clip's own speed).
    pub rate: Vec<f32>,
    /// Turning rate (rad/s, positive turns from +Z towards +X).
    pub turn_rate: Vec<f32>,
    /// Appearance variation seed (the renderers derive per-part tints from it).
    pub variant: Vec<u32>,
    /// Level chosen last frame (for hysteresis).
    pub level: Vec<Level>,
    /// View chosen last frame (0 for meshes).
    pub view: Vec<u32>,
    /// Which character the agent is: 0 the crowd's own ([`Crowd::params`]), `k` the
    /// species `k - 1` of [`Crowd::mix`].
    pub kind: Vec<u8>,
    /// The clip playing (an index into [`Gaits::clips`]; 0 without a clip table).
    pub clip: Vec<u16>,
    /// What the agent is doing.
    pub gait: Vec<Gait>,
    /// Seconds until the agent reconsiders its gait.
    pub gait_timer: Vec<f32>,
    /// The clip being faded out, and its clock, while `clip_fade < 1`.
    pub clip_from: Vec<(u16, f32)>,
    /// Progress of the agent's clip cross-fade (1 or more: none).
    pub clip_fade: Vec<f32>,
    /// The level and view being faded out while `fade < 1`.
    pub fade_from: Vec<(Level, u32)>,
    /// Progress of the agent's cross-fade (0 just switched, 1 or more: none).
    pub fade: Vec<f32>,
    /// The selection (count of [`Crowd::select_over`] calls) that last saw the agent: only an
    /// agent seen in the one before has a level and view to fade from.
    pub seen: Vec<u32>,
}

/// Angle (radians, 3°) by which a character's previous baked view may be further from the
/// camera direction than the nearest view and still be kept (views are about 12° apart at
/// 137 on the hemisphere).
pub const VIEW_HYSTERESIS_RAD: f32 = 0.052;
const VIEW_HYSTERESIS_COS: f32 = 0.998_648_4; // cos(0.052)
const VIEW_HYSTERESIS_SIN: f32 = 0.051_976_6; // sin(0.052)

/// Seconds over which an agent's turning rate forgets itself (an Ornstein–Uhlenbeck drift):
/// agents hold a curve for about this long.
pub const TURN_MEMORY_SECS: f32 = 1.5;

/// Views further apart than this (cosine of 40°) switch with a cut: a cross-fade between them
/// would show two ghosts of the character.
pub const FADE_VIEWS_COS: f32 = 0.766;

/// What the camera sees this frame: where, how big a pixel is.
#[derive(Clone, Copy, Debug)]
pub struct CrowdCamera {
    /// Camera position in world space (metres).
    pub eye: Vec3,
    /// View-projection matrix (wgpu's 0..1 depth): the culling frustum comes from it.
    pub clip_from_world: Mat4,
    /// Viewport height in pixels divided by `2·tan(fov_y / 2)`: a thing of height `h` at
    /// distance `d` covers `h · focal_px / d` pixels.
    pub focal_px: f32,
}

/// CPU seconds of each per-frame pass, and what came out.
#[derive(Clone, Copy, Debug, Default)]
pub struct FrameStats {
    /// The agents' motion ([`Crowd::simulate`]). Both timings stay 0 except from [`Crowd::frame`].
    pub simulate_secs: f64,
    /// Culling, level of detail, view and frame choice, instance records.
    pub select_secs: f64,
    /// Agents inside the view frustum (each counted once, cross-fading or not).
    pub visible: usize,
    /// Instance records written per level (index `level as usize`), every kind of character
    /// together: a character in a cross-fade is drawn twice and counts twice.
    pub per_level: [usize; Level::COUNT],
}

impl FrameStats {
    /// CPU seconds of the whole frame: simulation plus selection.
    pub fn cpu_secs(&self) -> f64 {
        self.simulate_secs + self.select_secs
    }
}

/// A crowd of agents on a square ground centred on the origin: their simulation on the CPU
/// and, each frame, the per-instance records the renderers draw ([`Crowd::instances`]).
pub struct Crowd {
    /// Its parameters, for its own character (kind 0). The ground and the occupancy grid are
    /// laid out once by [`Crowd::new`]: later changes to `count`, `density` or `min_distance`
    /// do not move them.
    pub params: CrowdParams,
    /// Half the side of the square ground the agents walk on (centred on the origin).
    pub half_extent: f32,
    /// Every agent's state.
    pub agents: Agents,
    grid: OccupancyGrid,
    /// Each agent's grid cell.
    cell_of: Vec<u32>,
    rng: Rng,
    paused: bool,
    /// Selections made so far (the first fades nothing).
    selections: u32,
    /// The pack's clips by gait ([`Crowd::set_clips`]); `None`: one clip, played at the rate
    /// the agent walks against [`CrowdParams::stride_speed`].
    gaits: Option<Gaits>,
    /// The other characters sharing the crowd ([`Crowd::mix`]): kind `k` is `species[k - 1]`.
    species: Vec<Species>,
    /// Instances per kind of character (0: the crowd's own; `k`: species `k - 1`) and per
    /// level, rebuilt by [`Crowd::select`].
    pub instances: Vec<[Vec<Instance>; Level::COUNT]>,
    /// Agents per run of [`Crowd::select_over`] (runs go to the rayon pool).
    select_run: usize,
    /// Squared least distance between two agents by their kinds (`[mine][theirs]`), when
    /// the crowd mixes characters of different sizes ([`Crowd::mix`]); `None`: everyone
    /// keeps the grid's cell width apart.
    pair_min2: Option<Box<[[f32; MAX_SPECIES]; MAX_SPECIES]>>,
}

/// Agents a selection hands to one task: large enough that a task outweighs its scheduling
/// (about 0.1 ms of work), small enough that a 100,000 crowd keeps 12 cores busy.
pub const SELECT_RUN: usize = 8192;

impl Crowd {
    /// Places `params.count` agents at the centres of distinct random cells of a square ground
    /// sized for `params.density` (at least two cells per agent), facing random ways, all of the
    /// crowd's own character and walking; deterministic from `params.seed`. No clip table until
    /// [`Crowd::set_clips`].
    pub fn new(params: CrowdParams) -> Self {
        // Lengths are the character's own (a mouse keeps millimetres apart): only a positive
        // floor, no absolute one.
        let c = if params.min_distance > 0.0 {
            params.min_distance.min(1e15)
        } else {
            1e-6
        };
        let n = params.count.max(1) as f32;
        // The ground holds `count / density` square metres, and at least twice as many cells
        // as agents so everyone can move.
        let density = if params.density > 0.0 { params.density } else { 1e-20 };
        let area = (n / density).max(2.0 * n * c * c).min(f32::MAX / 4.0);
        // A sparse crowd gets cells wider than the minimum distance (at most 64 per agent, so
        // the grid stays in proportion to the crowd whatever the arguments); they are still
        // far apart.
        let c = c.max((area / (64.0 * n)).sqrt());
        let dim = ((area.sqrt() / c).ceil() as usize).max(2);
        let half_extent = 0.5 * dim as f32 * c;
        let mut grid = OccupancyGrid::new(dim, c, half_extent);
        let mut rng = Rng::new(params.seed);
        // Distinct random cells (partial Fisher–Yates), agents at their centres: neighbours
        // are exactly one cell apart, so the minimum distance holds from the start.
        let mut cells: Vec<u32> = (0..(dim * dim) as u32).collect();
        let count = params.count.min(cells.len()).min(grid::MAX_AGENTS);
        for i in 0..count {
            let j = i + rng.below(cells.len() - i);
            cells.swap(i, j);
        }
        // Agents numbered row by row: neighbours on the ground are near in memory, which
        // keeps the per-frame passes in cache.
        cells.truncate(count);
        cells.sort_unstable();
        let mut agents = Agents::default();
        let mut cell_of = Vec::with_capacity(count);
        for (i, &k) in cells.iter().enumerate() {
            let cell = grid.inner(k as usize);
            cell_of.push(cell as u32);
            let pos = grid.centre(cell);
            grid.set(cell, i as u32);
            agents.pos.push(pos);
            let (s, c) = rng.range(0.0, std::f32::consts::TAU).sin_cos();
            agents.facing.push(Vec2::new(s, c));
            agents
                .speed
                .push(rng.range(params.speed.0, params.speed.1.max(params.speed.0)));
            agents.clock.push(rng.range(0.0, 10.0));
            agents.rate.push(rng.range(0.85, 1.15));
            agents.turn_rate.push(0.0);
            agents.variant.push(rng.next_u64() as u32 & VARIANT_SEED_MASK);
            agents.level.push(Level::Polypostor);
            agents.view.push(0);
            agents.kind.push(0);
            agents.clip.push(0);
            agents.gait.push(Gait::Walk);
            agents.gait_timer.push(rng.range(0.0, MOVING_SECS.1));
            agents.clip_from.push((0, 0.0));
            agents.clip_fade.push(1.0);
            agents.fade_from.push((Level::Polypostor, 0));
            agents.fade.push(1.0);
            agents.seen.push(0);
        }
        Self {
            params,
            half_extent,
            agents,
            grid,
            cell_of,
            rng,
            paused: false,
            selections: 0,
            gaits: None,
            species: Vec::new(),
            instances: vec![Default::default()],
            select_run: SELECT_RUN,
            pair_min2: None,
        }
    }

    /// Gives the crowd the pack's clip table ([`crate::timeline::ClipSpan`], with measured
    /// ground speeds) and frame rate: agents then walk, run and stand idle in the [`CrowdParams::behaviour`]
    /// shares, each moving at about its clip's ground speed with the clip played at the rate
    /// that keeps its feet on the ground, changing gait every few seconds with a clip
    /// cross-fade. Where no clip moves (a prop, an idle), agents stand and play them. Every
    /// agent starts afresh (a random gait, a random phase). An empty table: one clip, played
    /// at the rate agents walk against [`CrowdParams::stride_speed`].
    pub fn set_clips(&mut self, clips: &[crate::timeline::ClipSpan], fps: f32) {
        self.gaits = (!clips.is_empty()).then(|| Gaits::new(clips, fps));
        for i in 0..self.agents.pos.len() {
            if self.agents.kind[i] == 0 {
                self.restart(i);
            }
        }
    }

    /// Mixes other characters into the crowd: `species[k]` becomes kind `k + 1`, and the
    /// agents are dealt out in proportion to `shares` (the crowd's own character first, then
    /// each species; any scale, only the ratios count), at random places on the ground; every
    /// agent starts afresh. Each character keeps its own spacing: two agents stay the mean of
    /// their characters' least distances apart, the largest character's being the grid's
    /// cell (the ground and the cell are laid out by [`Crowd::new`]: use
    /// [`CrowdParams::spaced_for_shares`] before it), the others' in proportion to their
    /// [`CharacterSize::scale`]. Agents dealt out again where they stand may start closer
    /// than their new spacing: such a pair may only move apart. Errors: more than
    /// [`MAX_SPECIES`] characters, a share count that does not match, or shares that are
    /// negative, not finite or all zero.
    pub fn mix(&mut self, species: Vec<Species>, shares: &[f32]) -> Result<(), String> {
        if species.len() + 1 > MAX_SPECIES {
            return Err(format!(
                "{} characters in one crowd: at most {MAX_SPECIES}",
                species.len() + 1
            ));
        }
        check_shares(shares, species.len() + 1)?;
        let n = self.agents.pos.len();
        // Exact counts (cumulative rounding), dealt to a random order of the agents.
        let total: f64 = shares.iter().map(|&s| s as f64).sum();
        let mut order: Vec<u32> = (0..n as u32).collect();
        for i in 0..n {
            let j = i + self.rng.below(n - i);
            order.swap(i, j);
        }
        let mut so_far = 0.0f64;
        let mut from = 0usize;
        for (k, &share) in shares.iter().enumerate() {
            so_far += share as f64;
            let to = if k + 1 == shares.len() {
                n
            } else {
                ((so_far / total * n as f64).round() as usize).min(n)
            };
            for &i in &order[from..to.max(from)] {
                self.agents.kind[i as usize] = k as u8;
            }
            from = to.max(from);
        }
        self.species = species;
        self.instances = vec![Default::default(); self.species.len() + 1];
        self.pair_min2 = self.pair_distances();
        for (&cell, &k) in self.cell_of.iter().zip(&self.agents.kind) {
            self.grid.set_kind(cell as usize, k);
        }
        for i in 0..n {
            self.restart(i);
        }
        Ok(())
    }

    /// Squared least distances by pair of kinds for [`Crowd::mix`]: each character's spacing
    /// is the grid's cell times its scale over the largest's, a pair's the mean of theirs.
    /// `None` when every character has the same scale (everyone keeps the cell apart).
    fn pair_distances(&self) -> Option<Box<[[f32; MAX_SPECIES]; MAX_SPECIES]>> {
        let scales: Vec<f32> = std::iter::once(self.params.size.scale())
            .chain(self.species.iter().map(|s| s.size.scale()))
            .collect();
        let largest = scales.iter().copied().fold(0.0f32, f32::max);
        if scales.iter().all(|&s| s == largest) || !(largest > 0.0) {
            return None;
        }
        let spacing: Vec<f32> = scales.iter().map(|&s| self.grid.cell * s / largest).collect();
        let mut min2 = Box::new([[0.0f32; MAX_SPECIES]; MAX_SPECIES]);
        for (a, &sa) in spacing.iter().enumerate() {
            for (b, &sb) in spacing.iter().enumerate() {
                let d = 0.5 * (sa + sb);
                min2[a][b] = d * d;
            }
        }
        Some(min2)
    }

    /// The characters mixed in by [`Crowd::mix`] (kind `k` is `species()[k - 1]`).
    pub fn species(&self) -> &[Species] {
        &self.species
    }

    /// Agents of each kind (the crowd's own character first).
    pub fn kind_counts(&self) -> Vec<usize> {
        let mut n = vec![0; self.species.len() + 1];
        for &k in &self.agents.kind {
            n[(k as usize).min(self.species.len())] += 1;
        }
        n
    }

    /// Agent `i` starts afresh with its kind's clips: a random gait and phase (or, without a
    /// clip table, clip 0 at a speed in proportion to its character's stride).
    fn restart(&mut self, i: usize) {
        let k = self.agents.kind[i] as usize;
        let (gaits, stride) = match k {
            0 => (self.gaits.as_ref(), self.params.stride_speed),
            _ => (self.species[k - 1].gaits.as_ref(), self.species[k - 1].stride_speed),
        };
        let a = &mut self.agents;
        a.clip_fade[i] = 1.0;
        // Nothing to fade from: its last level and view may be another character's.
        a.fade[i] = 1.0;
        a.seen[i] = 0;
        a.view[i] = 0;
        match gaits {
            Some(g) => {
                let gait = choose_gait(&mut self.rng, &self.params.behaviour, g, false);
                start_gait(a, &mut self.rng, g, i, gait, None);
                let span = &g.clips[a.clip[i] as usize];
                a.clock[i] = self.rng.range(0.0, span.frames as f32 / g.fps);
            }
            None => {
                a.clip[i] = 0;
                a.gait[i] = Gait::Walk;
                if k != 0 {
                    let (lo, hi) = self.params.speed;
                    let ratio = stride / self.params.stride_speed.max(1e-12);
                    a.speed[i] = self.rng.range(lo, hi.max(lo)) * ratio;
                }
            }
        }
    }

    /// The clip table by gait, when the crowd has one ([`Crowd::set_clips`]).
    pub fn gaits(&self) -> Option<&Gaits> {
        self.gaits.as_ref()
    }

    /// Agents per gait (walking, running, idle).
    pub fn gait_counts(&self) -> [usize; 3] {
        let mut n = [0; 3];
        for &g in &self.agents.gait {
            n[g as usize] += 1;
        }
        n
    }

    /// [`Crowd::gait_counts`] of the agents of one kind (0 the crowd's own character, `k` its
    /// `k`-th guest; [`Crowd::kind_counts`]).
    pub fn gait_counts_of(&self, kind: usize) -> [usize; 3] {
        let mut n = [0; 3];
        for (&g, &k) in self.agents.gait.iter().zip(&self.agents.kind) {
            if k as usize == kind {
                n[g as usize] += 1;
            }
        }
        n
    }

    /// Number of agents.
    pub fn len(&self) -> usize {
        self.agents.pos.len()
    }

    /// Whether the crowd has no agents.
    pub fn is_empty(&self) -> bool {
        self.agents.pos.is_empty()
    }

    /// Pauses or resumes the crowd: while paused, [`Crowd::simulate`] does nothing (agents
    /// neither move nor animate).
    pub fn set_paused(&mut self, paused: bool) {
        self.paused = paused;
    }

    /// Whether the crowd is paused ([`Crowd::set_paused`]).
    pub fn paused(&self) -> bool {
        self.paused
    }

    /// Advances every agent by `dt` seconds: a random walk in heading; a step is taken only
    /// if it stays on the ground, lands in a free cell (or the agent's own) and keeps
    /// `min_distance` from everyone in the 3×3 cells around (in a mix of characters, each
    /// pair the distance [`Crowd::mix`] gives it); otherwise the agent turns away and waits.
    /// Paused crowds do not move.
    pub fn simulate(&mut self, dt: f32) {
        if self.paused || dt <= 0.0 {
            return;
        }
        // One loop compiled per spacing rule: the uniform one keeps the plain test.
        match self.pair_min2.take() {
            None => self.step(dt, Uniform(self.grid.cell * self.grid.cell)),
            Some(pairs) => {
                self.step(dt, ByKind(&pairs));
                self.pair_min2 = Some(pairs);
            }
        }
    }

    fn step<S: Spacing>(&mut self, dt: f32, spacing: S) {
        let dt = dt.min(0.25);
        let limit = self.half_extent - 0.5 * self.grid.cell;
        // The turning rate's drift over `dt` (exact for the Ornstein–Uhlenbeck process): it
        // keeps `keep` of itself and gains uniform noise of the matching spread, so its
        // spread stays `wander` (uniform on ±√3 has unit variance).
        let keep = (-dt / TURN_MEMORY_SECS).exp();
        let kick = self.params.wander * (1.0 - keep * keep).max(0.0).sqrt() * 3f32.sqrt();
        let fade_step = if self.params.fade_secs > 0.0 {
            dt / self.params.fade_secs
        } else {
            f32::INFINITY
        };
        let a = &mut self.agents;
        for i in 0..a.pos.len() {
            let k = a.kind[i] as usize;
            let (gaits, stride) = match k {
                0 => (self.gaits.as_ref(), self.params.stride_speed),
                _ => (self.species[k - 1].gaits.as_ref(), self.species[k - 1].stride_speed),
            };
            // Gait: reconsidered every few seconds; the clip it plays sets the pace.
            let mut clock_rate = a.rate[i] * a.speed[i] / stride.max(1e-6);
            if let Some(g) = gaits {
                a.gait_timer[i] -= dt;
                if a.gait_timer[i] <= 0.0 {
                    let gait = choose_gait(&mut self.rng, &self.params.behaviour, g, true);
                    start_gait(a, &mut self.rng, g, i, gait, Some(&self.params));
                }
                if a.clip_fade[i] < 1.0 {
                    a.clip_fade[i] += fade_step;
                    a.clip_from[i].1 += dt;
                }
                let span = &g.clips[a.clip[i] as usize];
                clock_rate = if span.ground_speed > 0.0 {
                    a.speed[i] / span.ground_speed
                } else {
                    a.rate[i]
                };
                if a.speed[i] <= 0.0 {
                    // Standing: no step, the turning drift settles.
                    a.turn_rate[i] *= keep;
                    a.clock[i] += dt * clock_rate;
                    continue;
                }
            }
            // Turn by a small random angle (a rotation with the small-angle sine and cosine,
            // then one Newton step back to unit length: no trigonometry per agent).
            a.turn_rate[i] = a.turn_rate[i] * keep + kick * self.rng.range(-1.0, 1.0);
            let t = a.turn_rate[i] * dt;
            let (s, c) = (t - t * t * t / 6.0, 1.0 - 0.5 * t * t);
            let d = a.facing[i];
            let d = Vec2::new(d.x * c + d.y * s, d.y * c - d.x * s);
            let d = d * (1.5 - 0.5 * d.length_squared());
            let to = a.pos[i] + d * (a.speed[i] * dt);
            let from_cell = self.cell_of[i] as usize;
            let cell = self.grid.cell_of(to);
            let ok = to.x.abs() < limit
                && to.y.abs() < limit
                && (cell == from_cell || self.grid.get(cell).is_none())
                && !spacing.crowded(&self.grid, cell, to, i, k, a);
            if ok {
                if cell != from_cell {
                    self.grid.move_agent(from_cell, cell);
                    self.cell_of[i] = cell as u32;
                }
                a.pos[i] = to;
                a.facing[i] = d;
                a.clock[i] += dt * clock_rate;
            } else {
                // Turn away (a quarter to a half turn, either side) and try again next frame.
                let turn = self.rng.range(0.5, 1.0) * std::f32::consts::PI;
                let (s, c) = (if self.rng.unit() < 0.5 { turn } else { -turn }).sin_cos();
                a.facing[i] = Vec2::new(d.x * c + d.y * s, d.y * c - d.x * s).normalize_or(Vec2::Y);
            }
        }
    }

    /// Culls, chooses each visible character's level, view and frame, and rebuilds
    /// [`Crowd::instances`]. `views`: the baked viewpoints (directions from the character
    /// towards the camera, in the character's frame).
    pub fn select(
        &mut self,
        camera: &CrowdCamera,
        policy: &LodPolicy,
        views: &ViewLookup,
        clip: ClipTiming,
    ) -> FrameStats {
        self.select_over(camera, policy, views, clip, f32::INFINITY)
    }

    /// [`Crowd::select`] (which cuts: no fades) `dt` seconds after the last selection (an
    /// infinite `dt` ends every fade): a character whose level or
    /// (image-based levels) view changes is drawn twice for [`CrowdParams::fade_secs`], the
    /// new copy dithered in and the old one out with the same per-pixel threshold
    /// ([`fade_bits`]); `dt` advances the fades in progress.
    pub fn select_over(
        &mut self,
        camera: &CrowdCamera,
        policy: &LodPolicy,
        views: &ViewLookup,
        clip: ClipTiming,
        dt: f32,
    ) -> FrameStats {
        let fade_step = if self.params.fade_secs > 0.0 {
            dt.max(0.0) / self.params.fade_secs
        } else {
            f32::INFINITY
        };
        let fading = self.selections > 0 && self.params.fade_secs > 0.0 && dt.is_finite();
        let previous_selection = self.selections;
        self.selections = self.selections.wrapping_add(1).max(1);
        let now = self.selections;
        for list in self.instances.iter_mut().flatten() {
            list.clear();
        }
        let frustum = Frustum::from_clip_from_world(&camera.clip_from_world);
        // Each kind of character's bounding sphere over its clips (about its centre, turned
        // with the agent: the horizontal offset is added to the radius instead).
        let mut radii = [0.0f32; MAX_SPECIES];
        for (k, r) in radii.iter_mut().enumerate().take(self.species.len() + 1) {
            let size = if k == 0 {
                &self.params.size
            } else {
                &self.species[k - 1].size
            };
            let offset = Vec2::new(size.centre.x, size.centre.z).length();
            *r = size.radius + offset + 0.5 * self.params.min_distance;
        }
        // Screen pixels of each kind scaled to the policy's texels (a pack baked at half the
        // resolution switches to its Polypostor at half the distance).
        let mut texel_scale = [1.0f32; MAX_SPECIES];
        if let LodPolicy::Mixed(d) = policy {
            for (k, s) in self.species.iter().enumerate() {
                if s.texels > 0.0 && s.texels.is_finite() {
                    texel_scale[k + 1] = d.texels / s.texels;
                }
            }
        }
        let mut stats = FrameStats::default();
        let a = &mut self.agents;
        let n = a.pos.len();
        let cx = SelectContext {
            camera,
            policy,
            frustum,
            radii,
            texel_scale,
            views,
            clip,
            params: &self.params,
            species: &self.species,
            gaits: self.gaits.as_ref(),
            fading,
            fade_step,
            previous_selection,
            now,
            pos: &a.pos,
            kind: &a.kind,
            facing: &a.facing,
            variant: &a.variant,
            clip_playing: &a.clip,
            clip_fade: &a.clip_fade,
        };
        let state = SelectState {
            level: &mut a.level,
            view: &mut a.view,
            clock: &mut a.clock,
            fade: &mut a.fade,
            fade_from: &mut a.fade_from,
            seen: &mut a.seen,
            clip_from: &mut a.clip_from,
        };
        // Runs of agents selected on the rayon pool (each agent's choice reads and writes
        // only its own state), their records then appended in agent order: the same lists as
        // one pass over every agent, on as many cores as there are.
        let run = self.select_run.max(1);
        let mut runs: Vec<(usize, SelectState<'_>)> = Vec::with_capacity(n.div_ceil(run));
        let mut rest = state;
        let mut first = 0;
        while n - first > run {
            let (head, tail) = rest.split_at(run);
            runs.push((first, head));
            rest = tail;
            first += run;
        }
        runs.push((first, rest));
        let outs: Vec<RunOutput> = if runs.len() > 1 {
            use rayon::prelude::*;
            runs.into_par_iter()
                .map(|(first, st)| cx.select_run(first, st))
                .collect()
        } else {
            runs.into_iter().map(|(first, st)| cx.select_run(first, st)).collect()
        };
        for out in outs {
            stats.visible += out.visible;
            for (k, level, record) in out.records {
                self.instances[k as usize][level as usize].push(record);
            }
        }
        for lists in &self.instances {
            for (n, list) in stats.per_level.iter_mut().zip(lists) {
                *n += list.len();
            }
        }
        stats
    }

    /// Whether [`Crowd::select_over`] spreads its agents over rayon's pool (the default) or
    /// runs on the calling thread (where that pool is busy with other work, as the studio's
    /// bakes: a selection waiting for their threads would stall the caller). The same
    /// records either way.
    pub fn set_parallel(&mut self, parallel: bool) {
        self.select_run = if parallel { SELECT_RUN } else { usize::MAX };
    }

    /// See [`Crowd::set_parallel`].
    pub fn parallel(&self) -> bool {
        self.select_run != usize::MAX
    }

    /// One frame: simulate then select, timed.
    pub fn frame(
        &mut self,
        dt: f32,
        camera: &CrowdCamera,
        policy: &LodPolicy,
        views: &ViewLookup,
        clip: ClipTiming,
    ) -> FrameStats {
        let t0 = Instant::now();
        self.simulate(dt);
        let t1 = Instant::now();
        let mut stats = self.select_over(camera, policy, views, clip, dt);
        stats.simulate_secs = (t1 - t0).as_secs_f64();
        stats.select_secs = t1.elapsed().as_secs_f64();
        stats
    }
}

/// What one selection reads, shared by its runs of agents.
struct SelectContext<'a> {
    camera: &'a CrowdCamera,
    policy: &'a LodPolicy,
    frustum: Frustum,
    radii: [f32; MAX_SPECIES],
    texel_scale: [f32; MAX_SPECIES],
    views: &'a ViewLookup,
    clip: ClipTiming,
    params: &'a CrowdParams,
    species: &'a [Species],
    gaits: Option<&'a Gaits>,
    fading: bool,
    fade_step: f32,
    previous_selection: u32,
    now: u32,
    pos: &'a [Vec2],
    kind: &'a [u8],
    facing: &'a [Vec2],
    variant: &'a [u32],
    clip_playing: &'a [u16],
    clip_fade: &'a [f32],
}

/// The state a selection writes, for one run of agents.
struct SelectState<'a> {
    level: &'a mut [Level],
    view: &'a mut [u32],
    clock: &'a mut [f32],
    fade: &'a mut [f32],
    fade_from: &'a mut [(Level, u32)],
    seen: &'a mut [u32],
    clip_from: &'a mut [(u16, f32)],
}

impl<'a> SelectState<'a> {
    /// The first `mid` agents, and the rest.
    fn split_at(self, mid: usize) -> (Self, Self) {
        let (level, level2) = self.level.split_at_mut(mid);
        let (view, view2) = self.view.split_at_mut(mid);
        let (clock, clock2) = self.clock.split_at_mut(mid);
        let (fade, fade2) = self.fade.split_at_mut(mid);
        let (fade_from, fade_from2) = self.fade_from.split_at_mut(mid);
        let (seen, seen2) = self.seen.split_at_mut(mid);
        let (clip_from, clip_from2) = self.clip_from.split_at_mut(mid);
        (
            Self {
                level,
                view,
                clock,
                fade,
                fade_from,
                seen,
                clip_from,
            },
            Self {
                level: level2,
                view: view2,
                clock: clock2,
                fade: fade2,
                fade_from: fade_from2,
                seen: seen2,
                clip_from: clip_from2,
            },
        )
    }
}

/// One run's records (kind, level, record), in agent order, and its visible agents.
#[derive(Default)]
struct RunOutput {
    records: Vec<(u8, Level, Instance)>,
    visible: usize,
}

impl SelectContext<'_> {
    /// Culls and chooses level, view and frame for the agents `first..` that `st` holds.
    fn select_run(&self, first: usize, st: SelectState<'_>) -> RunOutput {
        let mut out = RunOutput::default();
        let fade_step = self.fade_step;
        for j in 0..st.level.len() {
            let i = first + j;
            let k = self.kind[i] as usize;
            let (size, h, views, timing, gaits) = match k {
                0 => (&self.params.size, self.params.height, self.views, self.clip, self.gaits),
                _ => {
                    let s = &self.species[k - 1];
                    (&s.size, s.height, &s.views, s.timing, s.gaits.as_ref())
                }
            };
            let radius = self.radii[k];
            let frames = timing.frames.max(1);
            let p = self.pos[i];
            let centre = Vec3::new(p.x, size.centre.y, p.y);
            if !self.frustum.sphere_visible(centre, radius) {
                continue;
            }
            let to_eye = self.camera.eye - centre;
            let distance = to_eye.length().max(f32::MIN_POSITIVE);
            let pixels = h * self.camera.focal_px / distance * self.texel_scale[k];
            let previous = st.level[j];
            let level = self.policy.choose(pixels, previous);
            st.level[j] = level;
            // The camera direction in the character's own frame (undo its heading).
            let Vec2 { x: s, y: c } = self.facing[i];
            let local = Vec3::new(c * to_eye.x - s * to_eye.z, to_eye.y, s * to_eye.x + c * to_eye.z);
            // Meshes need no view. An image-based level keeps its view while that is within
            // VIEW_HYSTERESIS_RAD of the nearest one (a character turning about a view
            // boundary would otherwise switch, and fade, back and forth).
            let view = match level {
                Level::Skinned | Level::Rigid => 0,
                _ => {
                    let nearest = views.nearest(local).unwrap_or(0) as u32;
                    let kept = st.view[j];
                    if level == previous && kept != nearest {
                        let dir = local.normalize_or_zero();
                        match (views.direction(kept as usize), views.direction(nearest as usize)) {
                            (Some(k), Some(n)) => {
                                let c = n.dot(dir).clamp(-1.0, 1.0);
                                // cos(angle to the nearest + the margin).
                                let limit = c * VIEW_HYSTERESIS_COS - (1.0 - c * c).sqrt() * VIEW_HYSTERESIS_SIN;
                                if k.dot(dir) >= limit { kept } else { nearest }
                            }
                            _ => nearest,
                        }
                    } else {
                        nearest
                    }
                }
            };
            // Clocks start non-negative and only grow; wrap them every 64 loops so the
            // blend keeps its precision however long the crowd runs.
            let (start, n) = match gaits {
                Some(g) => {
                    let s = &g.clips[(self.clip_playing[i] as usize).min(g.clips.len() - 1)];
                    (s.start, s.frames)
                }
                None => (0, frames as u32),
            };
            let (frame, blend) = clip_frame(&mut st.clock[j], timing.fps, start, n);
            // A new level, or a new baked view of the same image-based level: fade.
            // The mix's far impostors (under a quarter of a pixel per texel: a few dozen pixels
            // tall) switch views with a cut: there a view change is hardly visible, and they are
            // most of a crowd.
            let image = !matches!(level, Level::Skinned | Level::Rigid)
                && !(level == Level::Impostor && matches!(self.policy, LodPolicy::Mixed(_)));
            // Only an agent drawn in the last selection has something on screen to fade from
            // (one coming into view, or back, starts clean); and views far apart (a coarse
            // bake) would show as two ghosts: those cut.
            let was_drawn = st.seen[j] == self.previous_selection;
            let close = |u: u32, w: u32| match (views.direction(u as usize), views.direction(w as usize)) {
                (Some(x), Some(y)) => x.dot(y) >= FADE_VIEWS_COS,
                _ => false,
            };
            if !was_drawn {
                st.fade[j] = 1.0;
            } else if self.fading && (level != previous || (image && view != st.view[j] && close(view, st.view[j]))) {
                st.fade_from[j] = (previous, st.view[j]);
                st.fade[j] = 0.0;
            }
            st.view[j] = view;
            st.seen[j] = self.now;
            let record = Instance {
                pos: [p.x, p.y],
                facing: [s, c],
                view,
                frame,
                blend,
                variant: self.variant[i] & VARIANT_SEED_MASK,
            };
            let kind = k as u8;
            // An infinite step (`select`) ends every fade: a cut.
            let f = if fade_step.is_finite() { st.fade[j] } else { 1.0 };
            if f < 1.0 {
                let (from, from_view) = st.fade_from[j];
                out.records.push((
                    kind,
                    from,
                    Instance {
                        view: from_view,
                        variant: record.variant | fade_bits(f, true),
                        ..record
                    },
                ));
                out.records.push((
                    kind,
                    level,
                    Instance {
                        variant: record.variant | fade_bits(f, false),
                        ..record
                    },
                ));
                st.fade[j] = f + if from != level {
                    fade_step / LEVEL_FADE_SCALE
                } else {
                    fade_step
                };
            } else if let Some(g) = gaits
                && self.clip_fade[i] < 1.0
                && fade_step.is_finite()
                && was_drawn
            {
                // A clip change: the clip left keeps playing under the dither while the new one
                // comes in (meshes and images alike).
                let (old, old_clock) = &mut st.clip_from[j];
                let s = &g.clips[(*old as usize).min(g.clips.len() - 1)];
                let (frame, blend) = clip_frame(old_clock, timing.fps, s.start, s.frames);
                let c = self.clip_fade[i];
                out.records.push((
                    kind,
                    level,
                    Instance {
                        frame,
                        blend,
                        variant: record.variant | fade_bits(c, true),
                        ..record
                    },
                ));
                out.records.push((
                    kind,
                    level,
                    Instance {
                        variant: record.variant | fade_bits(c, false),
                        ..record
                    },
                ));
            } else {
                out.records.push((kind, level, record));
            }
            out.visible += 1;
        }
        out
    }
}

/// Who is too close to a step's landing point ([`Crowd::simulate`]).
trait Spacing {
    /// Whether agent `i` (of kind `k`) may not step to `to` in `cell`.
    fn crowded(&self, grid: &OccupancyGrid, cell: usize, to: Vec2, i: usize, k: usize, a: &Agents) -> bool;
}

/// Everyone keeps the same distance (its square) from everyone.
struct Uniform(f32);

impl Spacing for Uniform {
    #[inline(always)]
    fn crowded(&self, grid: &OccupancyGrid, cell: usize, to: Vec2, i: usize, _: usize, a: &Agents) -> bool {
        grid.crowded(cell, to, self.0, i as u32, &a.pos)
    }
}

/// Squared distances by pair of kinds ([`Crowd::pair_distances`]).
struct ByKind<'a>(&'a [[f32; MAX_SPECIES]; MAX_SPECIES]);

impl Spacing for ByKind<'_> {
    #[inline(always)]
    fn crowded(&self, grid: &OccupancyGrid, cell: usize, to: Vec2, i: usize, k: usize, a: &Agents) -> bool {
        let mine = &self.0[k % MAX_SPECIES];
        grid.crowded_by_kind(cell, to, a.pos[i], mine, i as u32, &a.pos)
    }
}

/// The frames (a [`frame_pair`] in the clip `start..start + n`, looping) and blend at
/// `clock` seconds into the clip at `fps`. Clocks start non-negative and only grow; this
/// wraps them every 64 loops so the blend keeps its precision however long the crowd runs.
pub fn clip_frame(clock: &mut f32, fps: f32, start: u32, n: u32) -> (u32, f32) {
    let n = n.max(1);
    let mut t = *clock * fps;
    let wrap = 64.0 * n as f32;
    if t >= wrap && fps > 0.0 {
        *clock %= wrap / fps;
        t = *clock * fps;
    }
    let t = t.max(0.0);
    let whole = t as u32;
    let f = whole % n;
    (
        frame_pair(start + f, start + (f + 1) % n),
        (t - whole as f32).clamp(0.0, 1.0),
    )
}

/// A gait drawn from the behaviour's shares among those the pack has clips for (walking when
/// none has). `steady`: for an agent changing gait, each share divided by how long that gait
/// lasts, so that at any moment the shares of agents walking, running and standing are the
/// behaviour's (standing spells are shorter than walks).
fn choose_gait(rng: &mut Rng, b: &Behaviour, g: &Gaits, steady: bool) -> Gait {
    let w = |x: f32, ok: bool, (lo, hi): (f32, f32)| {
        let x = if ok && x.is_finite() { x.max(0.0) } else { 0.0 };
        if steady { x / (0.5 * (lo + hi)) } else { x }
    };
    let weights = [
        w(b.walk, g.walk.is_some(), MOVING_SECS),
        w(b.run, g.run.is_some(), MOVING_SECS),
        w(b.idle, !g.idle.is_empty(), IDLE_SECS),
    ];
    let total: f32 = weights.iter().sum();
    if !(total > 0.0) {
        return Gait::Walk;
    }
    let mut x = rng.range(0.0, total);
    for (k, gait) in [Gait::Walk, Gait::Run, Gait::Idle].into_iter().enumerate() {
        if x < weights[k] {
            return gait;
        }
        x -= weights[k];
    }
    Gait::Walk
}

/// Puts agent `i` in `gait`: its clip (phase-matched to the one it leaves, which cross-fades
/// out over [`CrowdParams::fade_secs`] when `params` is given), its speed about the clip's
/// ground speed, and how long it keeps it.
fn start_gait(a: &mut Agents, rng: &mut Rng, g: &Gaits, i: usize, gait: Gait, params: Option<&CrowdParams>) {
    let clip = g.clip_for(gait, rng.unit()).or(g.walk).unwrap_or(0);
    let gait = if g.clip_for(gait, 0.0).is_some() {
        gait
    } else if g.walk.is_some() {
        Gait::Walk
    } else {
        Gait::Idle
    };
    a.gait[i] = gait;
    let (lo, hi) = if gait == Gait::Idle { IDLE_SECS } else { MOVING_SECS };
    a.gait_timer[i] = rng.range(lo, hi);
    let span = &g.clips[clip];
    // Standing still plays its clip in place (an idle that sways is not a walk).
    a.speed[i] = if gait == Gait::Idle || g.walk.is_none() {
        0.0
    } else {
        span.ground_speed * rng.range(1.0 - SPEED_SPREAD, 1.0 + SPEED_SPREAD)
    };
    let old = a.clip[i] as usize;
    if old == clip {
        return;
    }
    if let Some(p) = params
        && p.fade_secs > 0.0
    {
        a.clip_from[i] = (old as u16, a.clock[i]);
        a.clip_fade[i] = 0.0;
    } else {
        a.clip_fade[i] = 1.0;
    }
    // The same phase in the new clip: a walk turning into a run keeps its stride.
    let from = &g.clips[old.min(g.clips.len() - 1)];
    let phase = (a.clock[i] * g.fps / from.frames.max(1) as f32).fract();
    a.clock[i] = phase * span.frames.max(1) as f32 / g.fps;
    a.clip[i] = clip as u16;
}

#[cfg(test)]
mod tests;

/// A length for people to read: µm, mm, cm, m or km as its size asks (a character 1.95 mm
/// tall is "1.9 mm", not "0.00 m").
pub fn metres(x: f32) -> String {
    let a = x.abs();
    if a < 1e-4 {
        format!("{:.1} µm", x * 1e6)
    } else if a < 0.01 {
        format!("{:.1} mm", x * 1000.0)
    } else if a < 1.0 {
        format!("{:.1} cm", x * 100.0)
    } else if a < 1000.0 {
        format!("{x:.2} m")
    } else {
        format!("{:.2} km", x / 1000.0)
    }
}

/// Ratio of heights above which characters sharing one crowd are said to differ in size by
/// more than a crowd can show at once ([`size_spread_note`]).
pub const SIZE_SPREAD_NOTE: f32 = 20.0;

/// What to say when characters of `heights` (metres) share one crowd and the tallest is more
/// than [`SIZE_SPREAD_NOTE`] times the shortest: the view is framed for the largest, so the
/// smallest shrink to specks (a model in millimetres among people). `None` otherwise.
pub fn size_spread_note(heights: &[f32]) -> Option<String> {
    let finite = heights.iter().copied().filter(|h| h.is_finite() && *h > 0.0);
    let lo = finite.clone().fold(f32::INFINITY, f32::min);
    let hi = finite.fold(0.0f32, f32::max);
    (lo.is_finite() && hi / lo > SIZE_SPREAD_NOTE).then(|| {
        format!(
            "the characters in this crowd range from {} to {} tall ({:.0}×): the view is framed for the largest and the smallest are specks; a character made in other units needs its unit scale (see the import's warning)",
            metres(lo),
            metres(hi),
            hi / lo
        )
    })
}

#[cfg(test)]
mod size_spread_tests {
    #[test]
    fn only_sizes_far_apart_are_said() {
        assert!(super::size_spread_note(&[1.8, 1.2, 0.4]).is_none());
        assert!(super::size_spread_note(&[1.8]).is_none());
        let n = super::size_spread_note(&[1.95, 0.00195, 1950.0]).unwrap();
        assert!(
            n.contains("1.9 mm") && n.contains("1.95 km") && n.contains("1000000×"),
            "{n}"
        );
        assert!(super::size_spread_note(&[1.8, 0.05]).is_some());
    }
}
