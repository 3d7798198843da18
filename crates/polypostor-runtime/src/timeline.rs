//! The frames of a bake: one or several clips sampled at one rate, one after another. A
//! whole-character pack holds every clip of the character in one frame sequence; each clip
//! loops over its own frames ([`Timeline::next`] wraps within the clip), and the key images
//! of a view are shared by every frame of every clip.
//!
//! Each clip also gets its measured **ground speed** ([`ground_speed`]), which the crowd uses
//! to play it at the rate its agent walks, so feet do not slide.

use glam::{Vec2, Vec3};
use serde::{Deserialize, Serialize};

use crate::animation::{Pose, skin_vertices};
use crate::character::Character;
use crate::limits::LimitError;

/// Most clips in one bake.
pub const MAX_CLIPS: usize = 256;

/// One clip's frames in a timeline.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ClipSpan {
    /// The clip's name (`(rest pose)` for the rest pose).
    pub name: String,
    /// Its first frame in the timeline.
    pub start: u32,
    /// How many frames it has (at least 1).
    pub frames: u32,
    /// Whether it loops: its last pose comes back to its first ([`ClipMotion::loops`]). A clip
    /// that does not (a fall, a sit) holds its last frame instead of wrapping.
    #[serde(default = "yes")]
    pub looping: bool,
    /// Ground speed when played at the timeline's rate (one frame every `1 / fps` seconds),
    /// in the character's world units per second ([`ground_speed`], scaled by
    /// `secs_per_frame × fps`); 0 for a clip standing still.
    #[serde(default)]
    pub ground_speed: f32,
    /// Seconds of the clip between two of its frames: its duration over its frame count, so
    /// a loop's frames are evenly spaced, the last one to the first included (a 1.25 s clip
    /// at 10 fps has 13 frames 0.096 s apart, not 13 at 0.1 s and a short 0.05 s wrap); for a
    /// clip that does not loop, its duration over one frame fewer (its last frame is its end
    /// pose, which it holds). 0 (packs written before this field) means `1 / fps`. The clip plays one frame per
    /// `1 / fps` seconds, so it runs at most one frame longer than its own duration.
    #[serde(default)]
    pub secs_per_frame: f32,
}

fn yes() -> bool {
    true
}

impl ClipSpan {
    /// The frames `start..start + frames`.
    pub fn range(&self) -> std::ops::Range<usize> {
        self.start as usize..(self.start + self.frames) as usize
    }

    /// Seconds into the clip of (fractional) frame `k` of the span, for a timeline at `fps`.
    pub fn clip_secs(&self, k: f32, fps: f32) -> f32 {
        k * self.step(fps)
    }

    /// Seconds of the clip between two frames ([`ClipSpan::secs_per_frame`], else `1 / fps`).
    pub fn step(&self, fps: f32) -> f32 {
        if self.secs_per_frame > 0.0 && self.secs_per_frame.is_finite() {
            self.secs_per_frame
        } else {
            1.0 / fps.max(1e-3)
        }
    }
}

/// Seconds between the frames of a clip of `duration_secs` sampled as `frames` frames at
/// `fps`: `1 / fps` where the duration holds a whole number of frames, else the duration over
/// the frames (evenly spaced round the loop).
pub fn clip_step(duration_secs: f32, frames: usize, fps: f32) -> f32 {
    let whole = 1.0 / fps.max(1e-3);
    if !(duration_secs > 0.0 && duration_secs.is_finite()) || frames == 0 {
        return whole;
    }
    if ((duration_secs * fps) - frames as f32).abs() < 1e-3 {
        whole
    } else {
        duration_secs / frames as f32
    }
}

/// Clips one after another at one frame rate.
#[derive(Clone, Debug, PartialEq)]
pub struct Timeline {
    /// Frames per second every clip is sampled at (frame `k` of a span is `k / fps` seconds
    /// into its clip).
    pub fps: f32,
    /// Each clip's frames, in bake order: consecutive from frame 0, one span per entry of
    /// `clips`.
    pub spans: Vec<ClipSpan>,
    /// The character's clip index of each span (`None`: the rest pose).
    pub clips: Vec<Option<usize>>,
}

/// The name a rest-pose span is given.
pub const REST_POSE: &str = "(rest pose)";

impl Timeline {
    /// The clips `clips` of `character` (in that order; `None` is the rest pose) at `fps`.
    /// Refuses an empty list, repeated clips, clips that do not exist and more than the
    /// frame limit in all.
    pub fn new(character: &Character, clips: &[Option<usize>], fps: f32) -> Result<Self, LimitError> {
        if clips.is_empty() {
            return Err(LimitError("no clip to bake".into()));
        }
        if clips.len() > MAX_CLIPS {
            return Err(LimitError(format!(
                "{} clips asked for, more than the limit of {MAX_CLIPS}",
                clips.len()
            )));
        }
        let mut spans = Vec::with_capacity(clips.len());
        let mut total = 0usize;
        for (n, &c) in clips.iter().enumerate() {
            if clips[..n].contains(&c) {
                return Err(LimitError(format!(
                    "clip '{}' is asked for twice",
                    name_of(character, c)
                )));
            }
            let clip =
                match c {
                    Some(i) => Some(character.clips.get(i).ok_or_else(|| {
                        LimitError(format!("clip {i} does not exist ({} clips)", character.clips.len()))
                    })?),
                    None => None,
                };
            let duration = clip.map_or(0.0, |c| c.duration_secs);
            let frames = if duration > 0.0 {
                crate::limits::frame_count(duration, fps).map_err(|e| {
                    LimitError(format!(
                        "clip '{}': {e}; bake a shorter clip or a lower --fps",
                        name_of(character, c)
                    ))
                })?
            } else {
                1
            };
            spans.push(ClipSpan {
                name: name_of(character, c),
                start: total as u32,
                frames: frames as u32,
                looping: true,
                ground_speed: 0.0,
                secs_per_frame: clip_step(duration, frames, fps),
            });
            total += frames;
            if total > crate::limits::MAX_FRAMES {
                return Err(LimitError(format!(
                    "the clips have {total} frames or more at {fps} fps together, more than the limit of {}: bake fewer clips or a lower --fps",
                    crate::limits::MAX_FRAMES
                )));
            }
        }
        Ok(Self {
            fps,
            spans,
            clips: clips.to_vec(),
        })
    }

    /// As [`Timeline::new`], with every span's [`ClipSpan::ground_speed`] and
    /// [`ClipSpan::looping`] measured ([`measure_motion`]).
    pub fn measured(character: &Character, clips: &[Option<usize>], fps: f32) -> Result<Self, LimitError> {
        let mut t = Self::new(character, clips, fps)?;
        let used: Vec<usize> = t.clips.iter().flatten().copied().collect();
        let motions = if used.is_empty() {
            Vec::new()
        } else {
            measure_some(character, &used)
        };
        for (span, &c) in t.spans.iter_mut().zip(&t.clips) {
            let m = c
                .and_then(|i| used.iter().position(|&u| u == i))
                .and_then(|k| motions.get(k).copied())
                .unwrap_or_default();
            span.looping = m.loops();
            // A clip that does not loop holds its last frame: make that its last pose (its
            // frames spread from its start to its end, both shown).
            let duration = c.and_then(|i| character.clips.get(i)).map_or(0.0, |c| c.duration_secs);
            if !span.looping && span.frames > 1 && duration > 0.0 && duration.is_finite() {
                // (A hair before the end: sampling wraps the end itself to the start.)
                span.secs_per_frame = duration * (1.0 - 1e-4) / (span.frames - 1) as f32;
            }
            // Played one frame per 1 / fps seconds, not one per secs_per_frame.
            span.ground_speed = m.ground_speed() * span.step(fps) * fps;
        }
        Ok(t)
    }

    /// Frames in all.
    pub fn frames(&self) -> usize {
        self.spans.last().map_or(0, |s| (s.start + s.frames) as usize)
    }

    /// Each frame's clip and time in it (seconds).
    pub fn samples(&self) -> Vec<(Option<usize>, f32)> {
        let mut out = Vec::with_capacity(self.frames());
        for (s, &c) in self.spans.iter().zip(&self.clips) {
            out.extend((0..s.frames).map(|k| (c, s.clip_secs(k as f32, self.fps))));
        }
        out
    }

    /// The span holding frame `f` (the last one past the end).
    pub fn span_of(&self, f: usize) -> usize {
        span_of(&self.spans, f)
    }

    /// The frame after `f` as its clip plays (a loop's last frame is followed by its first).
    pub fn next(&self, f: usize) -> usize {
        next_frame(&self.spans, f)
    }

    /// The frame before `f` as its clip plays.
    pub fn prev(&self, f: usize) -> usize {
        prev_frame(&self.spans, f)
    }

    /// A one-clip timeline for tests and single-clip callers: `frames` frames, one loop.
    pub fn single(name: &str, frames: usize, fps: f32) -> Self {
        Self {
            fps,
            spans: vec![ClipSpan {
                name: name.into(),
                start: 0,
                frames: frames.max(1) as u32,
                looping: true,
                ground_speed: 0.0,
                secs_per_frame: 0.0,
            }],
            clips: vec![None],
        }
    }
}

/// What to say when `character` has no clip named `name`: the clips it has, or that it has
/// none.
pub fn no_clip_named(name: &str, character: &Character) -> String {
    if character.clips.is_empty() {
        return format!(
            "no clip named '{name}': the character has no clips (its rest pose is baked when none is named)"
        );
    }
    format!(
        "no clip named '{name}' (clips: {})",
        character
            .clips
            .iter()
            .map(|k| k.name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    )
}

/// The clip names of a `--clips` list: comma-separated names (each must exist, none twice),
/// or `all` for every clip of the character in file order.
pub fn parse_clip_list(list: &str, character: &Character) -> Result<Vec<String>, String> {
    let list = list.trim();
    if list.eq_ignore_ascii_case("all") {
        if character.clips.is_empty() {
            return Err("the character has no clips".into());
        }
        return Ok(character.clips.iter().map(|c| c.name.clone()).collect());
    }
    let mut out: Vec<String> = Vec::new();
    for n in list.split(',').map(str::trim) {
        if n.is_empty() {
            return Err(format!("'{list}' has an empty clip name"));
        }
        if character.find_clip(n).is_none() {
            return Err(no_clip_named(n, character));
        }
        if out.iter().any(|o| o == n) {
            return Err(format!("clip '{n}' is named twice"));
        }
        out.push(n.to_string());
    }
    if out.len() > MAX_CLIPS {
        return Err(format!("{} clips, more than the limit of {MAX_CLIPS}", out.len()));
    }
    Ok(out)
}

fn name_of(character: &Character, c: Option<usize>) -> String {
    c.and_then(|i| character.clips.get(i))
        .map_or_else(|| REST_POSE.to_string(), |c| c.name.clone())
}

/// The span holding frame `f` in a table of consecutive spans (the last one past the end;
/// 0 for an empty table).
pub fn span_of(spans: &[ClipSpan], f: usize) -> usize {
    let i = spans.partition_point(|s| (s.start as usize) <= f);
    i.saturating_sub(1).min(spans.len().saturating_sub(1))
}

/// The frame after `f` as its clip plays (a looping clip's last frame is followed by its
/// first; a clip that does not loop holds its last frame).
pub fn next_frame(spans: &[ClipSpan], f: usize) -> usize {
    let Some(s) = spans.get(span_of(spans, f)) else {
        return f;
    };
    let r = s.range();
    if f + 1 < r.end {
        f + 1
    } else if s.looping {
        r.start
    } else {
        r.end.saturating_sub(1).max(r.start)
    }
}

/// The frame before `f` as its clip plays.
pub fn prev_frame(spans: &[ClipSpan], f: usize) -> usize {
    let Some(s) = spans.get(span_of(spans, f)) else {
        return f;
    };
    let r = s.range();
    if f > r.start {
        f - 1
    } else if s.looping {
        r.end.saturating_sub(1).max(r.start)
    } else {
        r.start
    }
}

/// Control characters in clip names read from a file become spaces, as an import makes them
/// (a pack baked before imports cleaned names could hold a tab or a newline; printed raw, a
/// terminal escape took over the terminal). Loaders call it before [`validate`].
pub fn printable_names(spans: &mut [ClipSpan]) {
    for s in spans {
        if s.name.chars().any(char::is_control) {
            s.name = s.name.chars().map(|c| if c.is_control() { ' ' } else { c }).collect();
        }
    }
}

/// Checks a clip table against a frame count: consecutive spans from 0 covering exactly
/// `frames` frames, each at least one frame, speeds finite and non-negative, frame spacing
/// finite and at most an hour, names short and printable.
pub fn validate(spans: &[ClipSpan], frames: usize) -> Result<(), String> {
    if spans.is_empty() {
        return Err("the clip table is empty".into());
    }
    if spans.len() > MAX_CLIPS {
        return Err(format!("{} clips, more than the limit of {MAX_CLIPS}", spans.len()));
    }
    let mut at = 0u64;
    for (i, s) in spans.iter().enumerate() {
        // Before the name is printed in any message: control characters (a newline, a
        // terminal escape) never come from an import, which replaces them.
        if s.name.len() > 1024 {
            return Err(format!("clip {i}'s name is {} bytes long", s.name.len()));
        }
        if s.name.chars().any(char::is_control) {
            return Err(format!("clip {i}'s name {:?} holds control characters", s.name));
        }
        if s.start as u64 != at {
            return Err(format!("clip {i} ('{}') starts at frame {}, not {at}", s.name, s.start));
        }
        if s.frames == 0 {
            return Err(format!("clip {i} ('{}') has no frames", s.name));
        }
        // Ten thousand of the largest bakeable character's heights (1e12 scene units) a
        // second: beyond it a number, not a speed (1e30 was taken).
        if !(s.ground_speed.is_finite() && (0.0..=1e16).contains(&s.ground_speed)) {
            return Err(format!("clip {i} ('{}') has ground speed {}", s.name, s.ground_speed));
        }
        if !(s.secs_per_frame.is_finite() && (0.0..=3600.0).contains(&s.secs_per_frame)) {
            return Err(format!(
                "clip {i} ('{}') has {} seconds between frames",
                s.name, s.secs_per_frame
            ));
        }
        at += s.frames as u64;
    }
    if at != frames as u64 {
        return Err(format!("the clips hold {at} frames but the bake has {frames}"));
    }
    Ok(())
}

/// Samples per clip used to measure its ground speed.
pub const SPEED_SAMPLES: usize = 48;

/// How a clip moves, measured on the skinned mesh at [`SPEED_SAMPLES`] times over one loop.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ClipMotion {
    /// Horizontal velocity (x, z) of the mesh's mean position from one loop to the next.
    pub root: Vec2,
    /// Horizontal velocity of the contact point: per sample on the ground, the lowest vertex's
    /// velocity to the next sample; the median of those along their main direction.
    pub feet: Vec2,
    /// How far the last pose is from the first once the root motion is taken out: mean
    /// vertex distance over the clip's height (about 0 for a clip that loops).
    pub closure: f32,
    /// Share of the samples on the ground (lowest vertex within 3 % of the height of the
    /// ground, the fifth-lowest of the samples' lowest points) whose contact point moves
    /// within half the ground speed of `feet` (the ground speed taken as at least
    /// [`LOCOMOTION_MIN_SPEED`] heights a second, so a clip standing still with planted feet
    /// reads about 1; 0 when under a fifth of the samples are on the ground).
    pub contact: f32,
    /// Mean distance of each sample's contact velocity from `feet`, over the ground speed
    /// (at least [`LOCOMOTION_MIN_SPEED`] heights a second, as for `contact`; small: the
    /// feet slide back evenly, as in a walk, or stay planted; large for a jump or a punch).
    pub spread: f32,
    /// Top minus bottom of the mesh over the clip.
    pub height: f32,
    /// The clip's length in seconds.
    pub duration: f32,
    /// How fast the feet sweep back under the body while they push ([`leg_sweep`]): scene
    /// units a second, 0 when the legs do not stride (fewer than two legs found, a clip that
    /// does not loop, legs that do not alternate, swing less than a fifth of the height, or
    /// one that never reaches the ground).
    pub sweep: f32,
    /// Share of the time with every foot on the ground (within [`STRIDE_GROUND`] of the
    /// lowest they get; 1 when the legs do not stride).
    pub all_down: f32,
    /// Ground speed estimated from [`ClipMotion::sweep`] for a clip whose contact point
    /// cannot measure it (a cartoon run whose feet slide along the floor both ways: no speed
    /// keeps them planted), scaled by how the sweep compares with the contact speed on the
    /// character's clips that have both ([`measure_clips`]); 0 for every other clip.
    pub stride: f32,
    /// The most the contact point rises off the ground over the clip (the lowest vertex's
    /// height above the ground, over `height`): a run's flight phases lift it a little, a
    /// leap or a somersault far ([`LOCOMOTION_MAX_LIFT`]).
    pub lift: f32,
}

/// Least ground speed of locomotion, in heights per second (9 cm/s for a 1.8 m person):
/// slower, a clip stands (a dance that drifts, a sway).
pub const LOCOMOTION_MIN_SPEED: f32 = 0.05;

/// Shortest locomotion clip, in seconds: a gait cycle takes longer (a sprint's stride about a
/// third of a second), and a clip of a frame or two has no cycle to measure (a 0.01 s clip read
/// 178 m/s and became the crowd's run).
pub const LOCOMOTION_MIN_SECS: f32 = 0.2;

/// Largest [`ClipMotion::closure`] of a clip that loops.
pub const LOOP_CLOSURE: f32 = 0.1;
/// Least [`ClipMotion::contact`] and largest [`ClipMotion::spread`] of locomotion (a run's
/// flight phases keep its contact point steady only about half the time).
pub const LOCOMOTION_CONTACT: f32 = 0.4;
/// Largest [`ClipMotion::spread`] of locomotion, a ratio to the ground speed: above it the
/// contact point moves too unevenly for a walk or a run.
pub const LOCOMOTION_SPREAD: f32 = 1.0;

/// Most a loop's contact point may rise off the ground ([`ClipMotion::lift`], in heights) and
/// be locomotion: the walks, runs and trots tried lift it 0.00–0.10 of their height
/// (RobotExpressive's bouncing cartoon run 0.18), a running leap 0.42 (Mixamo's soldier's
/// "jump", measured as a walk at 2.7 m/s: the crowd's walkers leapt about).
pub const LOCOMOTION_MAX_LIFT: f32 = 0.25;

impl ClipMotion {
    /// Whether the clip's last pose comes back to its first (so the crowd may loop it).
    pub fn loops(&self) -> bool {
        self.closure <= LOOP_CLOSURE
    }

    /// Whether it is steady locomotion: it loops, its contact point moves evenly and stays near
    /// the ground (a walk, a run, a trot; not a jump, a leap, a fall or a sit).
    pub fn is_locomotion(&self) -> bool {
        self.loops()
            && self.duration >= LOCOMOTION_MIN_SECS
            && self.contact >= LOCOMOTION_CONTACT
            && self.spread <= LOCOMOTION_SPREAD
            && self.lift <= LOCOMOTION_MAX_LIFT
            && (self.root - self.feet).length() >= LOCOMOTION_MIN_SPEED * self.height
    }

    /// The ground speed: root motion minus planted-feet velocity for locomotion, else the
    /// stride estimate ([`ClipMotion::stride`], 0 for a clip that does not stride).
    pub fn ground_speed(&self) -> f32 {
        let v = (self.root - self.feet).length();
        if self.is_locomotion() && v.is_finite() {
            v
        } else if self.stride.is_finite() {
            self.stride
        } else {
            0.0
        }
    }

    /// Whether the speed is the stride estimate (the contact point could not measure it).
    pub fn is_stride_estimate(&self) -> bool {
        !self.is_locomotion() && self.ground_speed() > 0.0
    }

    /// Whether [`ClipMotion::sweep`] may stand in for the contact speed: the legs stride, in
    /// place (no root motion), for a gait cycle's length, with flight phases (a run), and the
    /// contact point failed.
    fn may_stride(&self) -> bool {
        self.sweep >= LOCOMOTION_MIN_SPEED * self.height
            && self.sweep.is_finite()
            && !self.is_locomotion()
            && self.loops()
            && self.duration >= LOCOMOTION_MIN_SECS
            && self.root.length() < LOCOMOTION_MIN_SPEED * self.height
            && self.all_down <= STRIDE_MAX_ALL_DOWN
            && self.lift <= LOCOMOTION_MAX_LIFT
    }
}

/// Least fore-aft swing of every leg's foot, relative to the body, for [`leg_sweep`] to call
/// it a stride (a fifth of the height: the walks and runs tried swing 0.3–0.6).
pub const STRIDE_MIN_SWING: f32 = 0.2;

/// How close to the clip's lowest point every foot must come at some time (a share of the
/// height) for [`leg_sweep`]: each leg takes its turn on the ground (a jump off one foot does
/// not).
pub const STRIDE_GROUND: f32 = 0.05;

/// Largest share of the time with every foot down ([`ClipMotion::all_down`]) of a clip whose
/// speed the sweep may give: it stands in for runs, whose flight phases leave the contact point nothing to follow;
/// a walk or a stand has every foot down longer (RobotExpressive's standing leap, WalkJump,
/// half its time).
pub const STRIDE_MAX_ALL_DOWN: f32 = 0.25;

/// Most the correlation of two legs' fore-aft swings may be, for some pair, in a stride: they
/// alternate (a jump swings them together).
pub const STRIDE_ANTIPHASE: f32 = -0.5;

/// Bounds of the factor that turns a character's leg sweep into ground speed
/// ([`measure_clips`]).
pub const STRIDE_SCALE: (f32, f32) = (0.5, 2.0);

/// Measures every clip of `character` ([`measure_motion`]) and fills in [`ClipMotion::stride`]
/// for in-place clips whose legs stride but whose contact point does not give a speed: the
/// leg sweep times the median ratio of contact speed to sweep over the character's clips that
/// measure both (each rig rolls its feet and swings its legs its own way: the sweep read 0.7
/// to 1.0 of the contact speed on the walks and trots tried), 1 when none does, within
/// [`STRIDE_SCALE`].
pub fn measure_clips(character: &Character) -> Vec<ClipMotion> {
    let all: Vec<usize> = (0..character.clips.len()).collect();
    measure_some(character, &all)
}

/// [`measure_clips`] for the clips `wanted` (indices into the character's clips, in the order
/// given; an index out of range measures as no clip). The others are measured only when one
/// of these needs the stride scale (a character with a hundred clips baked one at a time does
/// not measure all hundred).
pub fn measure_some(character: &Character, wanted: &[usize]) -> Vec<ClipMotion> {
    let legs = crate::segment::leg_vertices(character);
    let mut out: Vec<ClipMotion> = wanted
        .iter()
        .map(|&i| measure_with_legs(character, Some(i).filter(|&i| i < character.clips.len()), &legs))
        .collect();
    if !out.iter().any(ClipMotion::may_stride) {
        return out;
    }
    let others: Vec<ClipMotion> = (0..character.clips.len())
        .filter(|i| !wanted.contains(i))
        .map(|i| measure_with_legs(character, Some(i), &legs))
        .collect();
    let mut ratios: Vec<f32> = out
        .iter()
        .chain(&others)
        .filter(|m| m.is_locomotion() && m.sweep > 0.0)
        .map(|m| (m.root - m.feet).length() / m.sweep)
        .filter(|r| r.is_finite())
        .collect();
    ratios.sort_by(f32::total_cmp);
    let scale = ratios
        .get(ratios.len() / 2)
        .map_or(1.0, |r| r.clamp(STRIDE_SCALE.0, STRIDE_SCALE.1));
    for m in &mut out {
        m.stride = if m.may_stride() { m.sweep * scale } else { 0.0 };
    }
    out
}

/// A clip whose feet slide both ways gets the stride estimate ([`measure_clips`]).
pub fn ground_speed(character: &Character, clip: Option<usize>) -> f32 {
    clip.filter(|&i| i < character.clips.len())
        .map_or(0.0, |i| measure_some(character, &[i])[0].ground_speed())
}

/// Makes every locomotion clip with root motion play in place: its measured root velocity
/// goes into [`Clip::in_place_velocity`](crate::character::Clip::in_place_velocity), which
/// sampling takes out, so bakes, comparisons and crowd meshes see the character walk on the
/// spot while the crowd carries it at the same ground speed (which stays as measured: the
/// planted feet now slide back at it). A clip that is not steady locomotion (a jump forward,
/// a fall, a one-shot) keeps its travel, as authored. Returns the names of the clips changed
/// with their speed.
pub fn play_in_place(character: &mut Character) -> Vec<(String, f32)> {
    let motions = root_motions(character);
    apply_in_place(character, &motions)
}

/// What an import does with the clips' motion: turns a character whose locomotion faces
/// away from +z to face +z ([`facing_turn`]; glTF's front is +z and the crowd walks its
/// characters that way), then plays its root motion in place ([`play_in_place`]). Returns
/// the turn in radians about +y (if any) and the clips played in place with their speed.
pub fn face_forward_and_play_in_place(character: &mut Character) -> (Option<f32>, Vec<(String, f32)>) {
    let mut motions = root_motions(character);
    let turn = facing_turn(&motions);
    if let Some(a) = turn {
        character.turn_about_vertical(a);
        let r = glam::Quat::from_rotation_y(a);
        let turn2 = |v: Vec2| {
            let w = r * Vec3::new(v.x, 0.0, v.y);
            Vec2::new(w.x, w.z)
        };
        for m in &mut motions {
            m.root = turn2(m.root);
            m.feet = turn2(m.feet);
        }
    }
    (turn, apply_in_place(character, &motions))
}

/// The horizontal move that brings a character standing off its own origin back over it:
/// `Some(-c)` (c the middle of its footprint, y kept) when the origin lies outside the
/// footprint by more than half the footprint's longer side, `None` otherwise. The footprint
/// is the horizontal bounds of every clip's first pose (the rest pose without clips). A
/// character modelled where it stood in a scene would otherwise be drawn that far from each
/// crowd agent, and swing round it as the agent turns.
pub fn off_origin(character: &Character) -> Option<Vec3> {
    let poses: Vec<Pose> = if character.clips.is_empty() {
        vec![Pose::rest(character)]
    } else {
        character
            .clips
            .iter()
            .map(|c| Pose::sample(character, c, 0.0))
            .collect()
    };
    let (lo, hi) = crate::character::bounds(poses.iter().flat_map(|p| skin_vertices(character, p).0));
    if !(lo.is_finite() && hi.is_finite()) {
        return None;
    }
    let (centre, half) = (0.5 * (lo + hi), 0.5 * (hi - lo));
    let gap = Vec2::new((centre.x.abs() - half.x).max(0.0), (centre.z.abs() - half.z).max(0.0)).length();
    let side = 2.0 * half.x.max(half.z);
    (side > 0.0 && gap > 0.5 * side).then(|| Vec3::new(-centre.x, 0.0, -centre.z))
}

/// Every clip's root and contact motion (no legs: those need the segmentation), with the
/// in-place velocities cleared first.
fn root_motions(character: &mut Character) -> Vec<ClipMotion> {
    (0..character.clips.len())
        .map(|i| {
            character.clips[i].in_place_velocity = Vec3::ZERO;
            measure_with_legs(character, Some(i), &[])
        })
        .collect()
}

/// Travel over one play of a clip, in the character's heights, beyond which a clip that is
/// not locomotion is played in place too: the bake frames the clip's whole path, so a clip
/// carrying the character 15 heights away baked it a few pixels tall (and 1,000 heights away,
/// to nothing). A jump forward (a height or two) keeps its travel, as authored.
pub const FAR_TRAVEL_HEIGHTS: f32 = 3.0;

/// Travel over one play, in the character's heights, beyond which a clip that comes back to
/// its first pose (it loops) but does not walk is played in place too: looped as authored, a
/// crowd sees it jump back by that much at every loop, and the bake frames its path (a walk
/// whose feet slide, carried 1.2 heights, drew the character at 60 % of its size). A jump,
/// which does not loop, keeps its travel up to [`FAR_TRAVEL_HEIGHTS`].
pub const LOOP_TRAVEL_HEIGHTS: f32 = 1.0;

fn apply_in_place(character: &mut Character, motions: &[ClipMotion]) -> Vec<(String, f32)> {
    let mut changed = Vec::new();
    let mut notes = Vec::new();
    for (clip, m) in character.clips.iter_mut().zip(motions) {
        if !m.root.is_finite() {
            continue;
        }
        let travel = m.root.length() * m.duration;
        let walks = m.is_locomotion() && m.root.length() >= LOCOMOTION_MIN_SPEED * m.height;
        let far = m.height > 0.0
            && (travel > FAR_TRAVEL_HEIGHTS * m.height || (m.loops() && travel > LOOP_TRAVEL_HEIGHTS * m.height));
        if walks || far {
            clip.in_place_velocity = Vec3::new(m.root.x, 0.0, m.root.y);
            changed.push((clip.name.clone(), m.root.length()));
            if !walks {
                notes.push(format!(
                    "clip '{}' carries the character {travel:.3} units ({:.1} times its height) without walking: played in place, so that bakes frame the character rather than its path",
                    clip.name,
                    travel / m.height
                ));
            }
        }
    }
    character.warnings.extend(notes);
    changed
}

/// Largest difference, in degrees, between a measured heading and a quarter turn for the
/// turn to be snapped to that quarter turn (a character modelled along another axis).
pub const FACING_SNAP_DEGREES: f32 = 10.0;

/// The turn about +y (radians) that makes a character walk towards +z, from its locomotion
/// clips' ground velocity (root motion minus planted feet: the way the body goes over its
/// feet, root motion or not). Each locomotion clip votes for the quarter (+z, +x, -z, -x)
/// its heading is nearest; the turn is made only when one quarter other than +z has more
/// votes than every other (so a character with a walk, a walk back and side steps keeps
/// its heading unless most of them agree, and one without locomotion is never turned). The
/// turn is to that quarter exactly when the quarter's mean heading is within
/// [`FACING_SNAP_DEGREES`] of it, else to the mean heading.
pub fn facing_turn(motions: &[ClipMotion]) -> Option<f32> {
    let mut votes = [0usize; 4];
    let mut sums = [Vec2::ZERO; 4];
    for m in motions.iter().filter(|m| m.is_locomotion()) {
        let v = m.root - m.feet;
        if !v.is_finite() || v == Vec2::ZERO {
            continue;
        }
        // Heading from +z towards +x.
        let heading = v.x.atan2(v.y);
        let q = ((heading / std::f32::consts::FRAC_PI_2).round() as i32).rem_euclid(4) as usize;
        votes[q] += 1;
        sums[q] += v.normalize();
    }
    let best = (0..4).max_by_key(|&q| votes[q])?;
    if best == 0 || votes[best] == 0 || (0..4).any(|q| q != best && votes[q] >= votes[best]) {
        return None;
    }
    let mean = sums[best].x.atan2(sums[best].y);
    let quarter = best as f32 * std::f32::consts::FRAC_PI_2;
    let off = (mean - quarter + std::f32::consts::PI).rem_euclid(std::f32::consts::TAU) - std::f32::consts::PI;
    let heading = if off.abs() <= FACING_SNAP_DEGREES.to_radians() {
        quarter
    } else {
        mean
    };
    // Within (-π, π].
    let turn = -heading;
    Some(std::f32::consts::PI - (std::f32::consts::PI - turn).rem_euclid(std::f32::consts::TAU))
}

/// The horizontal velocities (x, z) behind [`ground_speed`]: the root motion's and the
/// planted feet's (zero vectors for the rest pose, an empty clip or an empty mesh).
pub fn ground_velocities(character: &Character, clip: Option<usize>) -> (Vec2, Vec2) {
    // Root and contact only: no legs (the segmentation) needed.
    let m = measure_with_legs(character, clip, &[]);
    (m.root, m.feet)
}

/// Measures how `clip` moves ([`ClipMotion`]); the rest pose, an empty clip or an empty mesh
/// gives a still clip that loops. [`ClipMotion::stride`] is the uncalibrated sweep where the
/// clip may stride; [`measure_clips`] calibrates it against the character's other clips.
pub fn measure_motion(character: &Character, clip: Option<usize>) -> ClipMotion {
    let legs = crate::segment::leg_vertices(character);
    let mut m = measure_with_legs(character, clip, &legs);
    m.stride = if m.may_stride() { m.sweep } else { 0.0 };
    m
}

fn measure_with_legs(character: &Character, clip: Option<usize>, legs: &[Option<usize>]) -> ClipMotion {
    let none = ClipMotion::default();
    let Some(c) = clip.and_then(|i| character.clips.get(i)) else {
        return none;
    };
    let d = c.duration_secs;
    if !(d > 0.0) || character.vertices.is_empty() {
        return none;
    }
    let n = SPEED_SAMPLES;
    let dt = d / n as f32;
    let end = d * (1.0 - 1e-4);
    // Sample n + 1 times: the last one is the first of the next loop (root motion shows there).
    let pos: Vec<Vec<Vec3>> = (0..=n)
        .map(|k| {
            // Just before the end for the last sample: the clip wraps at its duration.
            let t = if k == n { end } else { k as f32 * dt };
            skin_vertices(character, &Pose::sample(character, c, t)).0
        })
        .collect();
    let (lo, hi) = pos
        .iter()
        .flatten()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.y), hi.max(p.y))
        });
    if !(hi > lo) {
        return none;
    }
    let height = hi - lo;
    // Root motion: the mean position's horizontal travel over the loop.
    let mean = |ps: &[Vec3]| ps.iter().copied().sum::<Vec3>() / ps.len() as f32;
    let travel = {
        let a = mean(&pos[0]);
        let b = mean(&pos[n]);
        Vec3::new(b.x - a.x, 0.0, b.z - a.z)
    };
    let root = Vec2::new(travel.x, travel.z) / end;
    let closure = pos[0]
        .iter()
        .zip(&pos[n])
        .map(|(a, b)| (*b - travel - *a).length())
        .sum::<f32>()
        / (pos[0].len() as f32 * height);
    // The contact point: per pair of consecutive samples, the horizontal velocity of the
    // sample's lowest vertex (the foot on the ground). Feet: the median of those on the ground
    // along their main direction, so foot changes (a minority of samples) do not move it.
    let mut samples: Vec<(Vec2, f32)> = Vec::with_capacity(n);
    for k in 0..n {
        let (a, b) = (&pos[k], &pos[k + 1]);
        let step_dt = if k + 1 == n { end - k as f32 * dt } else { dt };
        let low = (0..a.len()).min_by(|&x, &y| a[x].y.total_cmp(&a[y].y)).unwrap_or(0);
        if step_dt > 0.0 {
            samples.push((Vec2::new(b[low].x - a[low].x, b[low].z - a[low].z) / step_dt, a[low].y));
        }
    }
    // Only samples on the ground (the lowest vertex within 3 % of the height of the ground:
    // the lowest fifth of the samples' lowest points, so a single deep landing does not set
    // it): a run's flight phases are left out.
    let ground = {
        let mut lows: Vec<f32> = samples.iter().map(|s| s.1).collect();
        lows.sort_by(f32::total_cmp);
        lows.get(lows.len() / 5).copied().unwrap_or(lo)
    };
    let velocities: Vec<Vec2> = samples
        .iter()
        .filter(|s| s.1 <= ground + 0.03 * height)
        .map(|s| s.0)
        .collect();
    let grounded = velocities.len() as f32 / n as f32;
    let lift = samples.iter().map(|s| s.1 - ground).fold(0.0f32, f32::max) / height;
    let sum: Vec2 = velocities.iter().copied().sum();
    let dir = sum.normalize_or_zero();
    let feet = if dir == Vec2::ZERO {
        Vec2::ZERO
    } else {
        let mut along: Vec<f32> = velocities.iter().map(|v| v.dot(dir)).collect();
        along.sort_by(f32::total_cmp);
        dir * along[along.len() / 2]
    };
    // How steadily the contact point moves at the feet's velocity: the share of samples within
    // half the ground speed of it. The speed is taken as at least the slowest locomotion's
    // ([`LOCOMOTION_MIN_SPEED`]): a clip that stands measures its feet against a walk's pace,
    // not against the drift of a sway (an idle's or a jump's spread read in the thousands).
    let speed = (root - feet).length().max(LOCOMOTION_MIN_SPEED * height);
    let contact = if velocities.is_empty() {
        1.0
    } else {
        velocities
            .iter()
            .filter(|v| (**v - feet).length() <= 0.5 * speed)
            .count() as f32
            / velocities.len() as f32
    };
    let spread = if velocities.is_empty() {
        0.0
    } else {
        velocities.iter().map(|v| (*v - feet).length()).sum::<f32>() / (velocities.len() as f32 * speed)
    };
    let (sweep, all_down) = if closure <= LOOP_CLOSURE {
        leg_sweep(&pos, end, legs, height)
    } else {
        (0.0, 1.0)
    };
    ClipMotion {
        root,
        feet,
        closure: if closure.is_finite() { closure } else { f32::INFINITY },
        // Steady on the ground, and on the ground a fifth of the time at least.
        contact: if grounded >= 0.2 { contact } else { 0.0 },
        spread: if spread.is_finite() { spread } else { f32::INFINITY },
        height,
        duration: d,
        sweep,
        all_down,
        stride: 0.0,
        lift: if lift.is_finite() { lift } else { f32::INFINITY },
    }
}

/// How fast the feet sweep back under the body as they push, from skinned samples `pos` of one
/// loop (the last one the next loop's first, `end` seconds after the first) and each vertex's
/// leg ([`crate::segment::leg_vertices`]): per leg, the foot (the tenth of the leg's vertices
/// lowest on average over the clip) followed relative to the body's mean along the axis the
/// feet swing on; the phase of its swing spent lower (the stance) is the backward one, and the
/// sweep is its travel over its time, averaged over the legs. This is the foot travel of a
/// clip that runs in place: in a physical gait the stance foot moves back against the body at
/// the ground speed. 0 unless the legs stride ([`ClipMotion::sweep`]). Also returns the
/// share of the time with every foot down (1 when they do not stride).
pub fn leg_sweep(pos: &[Vec<Vec3>], end: f32, legs: &[Option<usize>], height: f32) -> (f32, f32) {
    let count = legs.iter().flatten().max().map_or(0, |m| m + 1);
    let n = pos.len().saturating_sub(1);
    if count < 2 || n < 4 || !(height > 0.0) || !(end > 0.0) || pos.iter().any(|p| p.len() != legs.len()) {
        return (0.0, 1.0);
    }
    let dt = end / n as f32;
    // Each leg's foot: the tenth of its vertices lowest on average over the clip.
    let mut feet: Vec<Vec<usize>> = vec![Vec::new(); count];
    for (v, l) in legs.iter().enumerate() {
        if let Some(l) = l {
            feet[*l].push(v);
        }
    }
    for f in &mut feet {
        let mean_y: Vec<f32> = f.iter().map(|&v| pos.iter().map(|p| p[v].y).sum::<f32>()).collect();
        let mut order: Vec<usize> = (0..f.len()).collect();
        order.sort_by(|&a, &b| mean_y[a].total_cmp(&mean_y[b]));
        *f = order.iter().take((f.len() / 10).max(1)).map(|&k| f[k]).collect();
    }
    let body: Vec<Vec3> = pos
        .iter()
        .map(|p| p.iter().copied().sum::<Vec3>() / p.len().max(1) as f32)
        .collect();
    // Foot relative to the body horizontally, at its own height.
    let rel: Vec<Vec<Vec3>> = feet
        .iter()
        .map(|f| {
            (0..=n)
                .map(|k| {
                    let p = f.iter().map(|&v| pos[k][v]).sum::<Vec3>() / f.len() as f32;
                    Vec3::new(p.x - body[k].x, p.y, p.z - body[k].z)
                })
                .collect()
        })
        .collect();
    // Every foot comes down to the ground (the lowest any foot gets) at some time.
    let lowest: Vec<f32> = feet
        .iter()
        .map(|f| {
            pos.iter()
                .flat_map(|p| f.iter().map(move |&v| p[v].y))
                .fold(f32::INFINITY, f32::min)
        })
        .collect();
    let floor = lowest.iter().copied().fold(f32::INFINITY, f32::min);
    if lowest.iter().any(|&l| l > floor + STRIDE_GROUND * height) || !floor.is_finite() {
        return (0.0, 1.0);
    }
    // How long they are all down at once (a run has flight phases instead).
    let all_down = (0..n)
        .filter(|&k| {
            feet.iter()
                .all(|f| f.iter().any(|&v| pos[k][v].y <= floor + STRIDE_GROUND * height))
        })
        .count();
    let all_down = all_down as f32 / n as f32;
    // The swing axis: the main horizontal direction of the feet's motion against the body.
    let (mut xx, mut xz, mut zz) = (0.0f32, 0.0f32, 0.0f32);
    for r in &rel {
        let m = r.iter().sum::<Vec3>() / r.len() as f32;
        for p in r {
            let q = *p - m;
            xx += q.x * q.x;
            xz += q.x * q.z;
            zz += q.z * q.z;
        }
    }
    let angle = 0.5 * (2.0 * xz).atan2(xx - zz);
    let axis = Vec3::new(angle.cos(), 0.0, angle.sin());
    let along: Vec<Vec<f32>> = rel.iter().map(|r| r.iter().map(|p| p.dot(axis)).collect()).collect();
    // The legs alternate: some pair swings against each other.
    let centred: Vec<Vec<f32>> = along
        .iter()
        .map(|x| {
            let m = x[..n].iter().sum::<f32>() / n as f32;
            x[..n].iter().map(|v| v - m).collect()
        })
        .collect();
    let mut least = 1.0f32;
    for a in 0..count {
        for b in a + 1..count {
            let (ab, aa, bb) = centred[a]
                .iter()
                .zip(&centred[b])
                .fold((0.0, 0.0, 0.0), |(ab, aa, bb), (p, q)| {
                    (ab + p * q, aa + p * p, bb + q * q)
                });
            if aa > 0.0 && bb > 0.0 {
                least = least.min(ab / (aa * bb).sqrt());
            }
        }
    }
    if least > STRIDE_ANTIPHASE {
        return (0.0, 1.0);
    }
    let mut sum = 0.0f32;
    for (x, r) in along.iter().zip(&rel) {
        let swing =
            x.iter().copied().fold(f32::NEG_INFINITY, f32::max) - x.iter().copied().fold(f32::INFINITY, f32::min);
        if !(swing >= STRIDE_MIN_SWING * height) {
            return (0.0, 1.0);
        }
        // Time, travel and mean height of the foot's backward and forward phases.
        let (mut back, mut fore) = ([0.0f32; 3], [0.0f32; 3]);
        for k in 0..n {
            let d = x[k + 1] - x[k];
            let y = 0.5 * (r[k].y + r[k + 1].y);
            let phase = if d < 0.0 { &mut back } else { &mut fore };
            phase[0] += dt;
            phase[1] += d.abs();
            phase[2] += y * dt;
        }
        // The stance is the phase spent lower.
        let lower = |p: &[f32; 3]| if p[0] > 0.0 { p[2] / p[0] } else { f32::INFINITY };
        let stance = if lower(&back) <= lower(&fore) { back } else { fore };
        if !(stance[0] > 0.0) {
            return (0.0, 1.0);
        }
        sum += stance[1] / stance[0];
    }
    let v = sum / count as f32;
    if v.is_finite() { (v, all_down) } else { (0.0, 1.0) }
}

/// Sample times of a looping clip at `fps`: as many frames as `1/fps` steps start before the
/// end ([`crate::limits::frame_count`]), spread evenly over the loop ([`clip_step`]), so the
/// wrap from the last frame to the first is as long as every other step. At least one frame.
pub fn frame_times(duration_secs: f32, fps: f32) -> Vec<f32> {
    if !(duration_secs > 0.0) || !(fps > 0.0) {
        return vec![0.0];
    }
    // Callers check the count first ([`crate::limits::frame_count`]); never more than the limit.
    let n = crate::limits::frame_count(duration_secs, fps).unwrap_or(crate::limits::MAX_FRAMES);
    let step = clip_step(duration_secs, n, fps);
    (0..n).map(|k| k as f32 * step).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `clip`'s translation of `node` replaced by linear keys `values` at `times`.
    fn root_keys(clip: &mut crate::character::Clip, node: usize, times: Vec<f32>, values: Vec<Vec3>) {
        use crate::character::{Channel, ChannelValues, Interpolation};
        clip.channels
            .retain(|ch| !(ch.node == node && matches!(ch.values, ChannelValues::Translation(_))));
        clip.channels.push(Channel {
            node,
            interpolation: Interpolation::Linear,
            times,
            values: ChannelValues::Translation(values),
        });
    }

    #[test]
    fn a_clip_of_a_fractional_frame_count_is_sampled_evenly_round_its_loop() {
        let mut c = crate::default_character::generate();
        let walk = c.find_clip("Walk").unwrap();
        let whole = Timeline::measured(&c, &[Some(walk)], 10.0).unwrap();
        // The Walk lasts 1 s: ten frames 0.1 s apart, as before this field.
        assert_eq!(whole.spans[0].frames, 10);
        assert_eq!(whole.spans[0].step(10.0), 0.1);
        // Stretched to 1.25 s (12.5 frames' worth at 10 fps): 13 frames, 1.25 / 13 apart, so
        // the last frame is one step before the loop's end, not half a step.
        c.clips[walk].duration_secs = 1.25;
        for ch in &mut c.clips[walk].channels {
            for t in &mut ch.times {
                *t *= 1.25;
            }
        }
        c.clips[walk].in_place_velocity /= 1.25;
        let t = Timeline::measured(&c, &[Some(walk)], 10.0).unwrap();
        let s = &t.spans[0];
        assert_eq!(s.frames, 13);
        let step = 1.25 / 13.0;
        assert!((s.step(10.0) - step).abs() < 1e-6);
        for (k, &(clip, secs)) in t.samples().iter().enumerate() {
            assert_eq!(clip, Some(walk));
            assert!((secs - k as f32 * step).abs() < 1e-5);
        }
        assert!((s.clip_secs(13.0, 10.0) - 1.25).abs() < 1e-5);
        // Played one frame every 0.1 s, the stretched walk covers its loop's distance in 1.3 s:
        // its ground speed at that rate is the measured one × 1.25 / 1.3.
        let measured = ground_speed(&c, Some(walk));
        assert!(measured > 0.5);
        assert!(
            (s.ground_speed - measured * 1.25 / 1.3).abs() < 1e-4 * measured,
            "{} {measured}",
            s.ground_speed
        );
        // A damaged spacing is named.
        let mut bad = t.spans.clone();
        bad[0].secs_per_frame = f32::NAN;
        assert!(validate(&bad, 13).unwrap_err().contains("between frames"));
        // So is a ground speed no character has (1e30 was taken).
        let mut bad = t.spans.clone();
        bad[0].ground_speed = 1e30;
        assert!(validate(&bad, 13).unwrap_err().contains("ground speed"));
        bad[0].ground_speed = 1e6;
        validate(&bad, 13).unwrap();
        // A name with a terminal escape or a newline (never from an import) is refused, and
        // the message shows it escaped.
        for name in ["Walk\nDeath", "\u{1b}[31mred"] {
            let mut bad = t.spans.clone();
            bad[0].name = name.into();
            let e = validate(&bad, 13).unwrap_err();
            assert!(
                e.contains("control characters") && !e.chars().any(char::is_control),
                "{e}"
            );
            // A loader makes it printable first.
            printable_names(&mut bad);
            validate(&bad, 13).unwrap();
            assert_eq!(bad[0].name.chars().count(), name.chars().count());
        }
    }

    #[test]
    fn clips_follow_each_other_and_loop_on_their_own() {
        let c = crate::default_character::generate();
        let all: Vec<Option<usize>> = (0..c.clips.len()).map(Some).collect();
        let t = Timeline::new(&c, &all, 10.0).unwrap();
        let mut at = 0;
        for (s, clip) in t.spans.iter().zip(&c.clips) {
            assert_eq!(s.start as usize, at);
            assert_eq!(
                s.frames as usize,
                crate::limits::frame_count(clip.duration_secs, 10.0).unwrap()
            );
            at += s.frames as usize;
        }
        assert_eq!(t.frames(), at);
        assert_eq!(t.samples().len(), at);
        validate(&t.spans, at).unwrap();
        // Brute force: next and prev against the clip each frame is in.
        for f in 0..at {
            let s = t.spans.iter().find(|s| s.range().contains(&f)).unwrap();
            let r = s.range();
            let local = f - r.start;
            assert_eq!(t.next(f), r.start + (local + 1) % r.len());
            assert_eq!(t.prev(f), r.start + (local + r.len() - 1) % r.len());
            assert_eq!(t.prev(t.next(f)), f);
            assert_eq!(&t.spans[t.span_of(f)], s);
        }
        // A repeated clip, a missing one and an empty list are refused.
        assert!(Timeline::new(&c, &[Some(0), Some(0)], 10.0).is_err());
        assert!(Timeline::new(&c, &[Some(99)], 10.0).is_err());
        assert!(Timeline::new(&c, &[], 10.0).is_err());
        // A damaged table is named.
        let mut bad = t.spans.clone();
        bad[1].start += 1;
        assert!(validate(&bad, at).unwrap_err().contains("starts at frame"));
        assert!(validate(&t.spans, at + 1).unwrap_err().contains("hold"));
    }

    #[test]
    fn ground_speed_of_walking_in_place_and_of_standing_still() {
        let c = crate::default_character::generate();
        let walk = ground_speed(&c, c.find_clip("Walk"));
        let run = ground_speed(&c, c.find_clip("Run"));
        let idle = ground_speed(&c, c.find_clip("Idle"));
        // A 1.8 m person walks at about 1–2 m/s and runs faster; idling goes nowhere.
        assert!((0.6..2.5).contains(&walk), "walk {walk}");
        assert!(run > walk * 1.2, "run {run} walk {walk}");
        assert!(idle < 0.1 * walk, "idle {idle}");
        assert_eq!(ground_speed(&c, None), 0.0);
    }

    /// A walk squeezed into a hundredth of a second (a clip of a frame or two) has no gait
    /// cycle to measure: it is not locomotion (it read 178 m/s and became the crowd's run).
    #[test]
    fn a_clip_too_short_for_a_stride_does_not_walk() {
        let mut c = crate::default_character::generate();
        let walk = c.find_clip("Walk").unwrap();
        assert!(ground_speed(&c, Some(walk)) > 0.5);
        let d = c.clips[walk].duration_secs;
        for ch in &mut c.clips[walk].channels {
            for t in &mut ch.times {
                *t *= 0.01 / d;
            }
        }
        c.clips[walk].duration_secs = 0.01;
        assert_eq!(ground_speed(&c, Some(walk)), 0.0);
        assert!(!measure_motion(&c, Some(walk)).is_locomotion());
    }

    #[test]
    fn root_motion_and_foot_travel_give_the_same_speed_at_any_scale() {
        use crate::character::{Channel, ChannelValues, Interpolation};
        let mut c = crate::default_character::generate();
        let walk = c.find_clip("Walk").unwrap();
        let (root, feet) = ground_velocities(&c, Some(walk));
        // The generated Walk walks in place: no root motion, feet sliding back.
        assert!(root.length() < 0.05 * feet.length(), "root {root} feet {feet}");
        let in_place = ground_speed(&c, Some(walk));
        // The same walk carried forward by its root at the speed its feet slid back: the feet
        // now stay planted, and the speed is the root's.
        let r = c.skeleton.nodes.iter().position(|n| n.parent.is_none()).unwrap();
        let rest = c.skeleton.nodes[r].rest;
        let d = c.clips[walk].duration_secs;
        let v = -feet;
        // The root has no parent: its translation is in world space. Its keys are linear, so
        // adding the travel at each key time is exact.
        let step = |t: f32| Vec3::new(v.x, 0.0, v.y) * t;
        let clip = &mut c.clips[walk];
        match clip
            .channels
            .iter_mut()
            .find(|ch| ch.node == r && matches!(ch.values, ChannelValues::Translation(_)))
        {
            Some(ch) => {
                assert_eq!(ch.interpolation, Interpolation::Linear);
                let times = ch.times.clone();
                if let ChannelValues::Translation(vals) = &mut ch.values {
                    for (x, t) in vals.iter_mut().zip(times) {
                        *x += step(t);
                    }
                }
            }
            None => clip.channels.push(Channel {
                node: r,
                interpolation: Interpolation::Linear,
                times: vec![0.0, d],
                values: ChannelValues::Translation(vec![rest.translation, rest.translation + step(d)]),
            }),
        }
        let (root2, feet2) = ground_velocities(&c, Some(walk));
        assert!(feet2.length() < 0.1 * in_place, "feet {feet2}");
        assert!((root2 - v).length() < 0.1 * in_place, "root {root2} against {v}");
        let moving = ground_speed(&c, Some(walk));
        assert!(
            (moving - in_place).abs() < 0.1 * in_place,
            "{moving} against {in_place}"
        );
        // Played in place: the root motion is found and taken out, so every pose is the
        // generated in-place walk's again (an independent answer: the clip before the root
        // motion was added), and the ground speed stays what it was.
        let changed = play_in_place(&mut c);
        assert_eq!(changed.len(), 1, "{changed:?}");
        assert_eq!(changed[0].0, "Walk");
        let original = crate::default_character::generate();
        let height = measure_motion(&original, Some(walk)).height;
        for k in 0..8 {
            let t = d * k as f32 / 8.0;
            let a = skin_vertices(&c, &Pose::sample(&c, &c.clips[walk], t)).0;
            let b = skin_vertices(&original, &Pose::sample(&original, &original.clips[walk], t)).0;
            let off = a.iter().zip(&b).map(|(x, y)| (*x - *y).length()).sum::<f32>() / a.len() as f32;
            assert!(off < 0.01 * height, "frame at {t} s is {off} off the in-place walk");
        }
        let (root3, _) = ground_velocities(&c, Some(walk));
        assert!(root3.length() < 0.05 * in_place, "root {root3} left");
        let again = ground_speed(&c, Some(walk));
        assert!((again - in_place).abs() < 0.1 * in_place, "{again} against {in_place}");
        // A hundred times larger: a hundred times faster.
        let mut big = crate::default_character::generate();
        let r = big.skeleton.nodes.iter().position(|n| n.parent.is_none()).unwrap();
        big.skeleton.nodes[r].rest.scale *= 100.0;
        big.skeleton.nodes[r].rest.translation *= 100.0;
        // The root's animated translation is in world units too.
        for clip in &mut big.clips {
            for ch in clip.channels.iter_mut().filter(|ch| ch.node == r) {
                if let ChannelValues::Translation(vals) = &mut ch.values {
                    vals.iter_mut().for_each(|x| *x *= 100.0);
                }
            }
        }
        let scaled = ground_speed(&big, Some(walk));
        assert!((scaled / in_place - 100.0).abs() < 1.0, "{scaled} against {in_place}");
    }

    /// Mean distance between two characters' skinned vertices at eight times of `clip`.
    fn pose_distance(a: &Character, b: &Character, clip: usize) -> f32 {
        let d = a.clips[clip].duration_secs;
        (0..8)
            .map(|k| {
                let t = d * k as f32 / 8.0;
                let p = skin_vertices(a, &Pose::sample(a, &a.clips[clip], t)).0;
                let q = skin_vertices(b, &Pose::sample(b, &b.clips[clip], t)).0;
                p.iter().zip(&q).map(|(x, y)| (*x - *y).length()).sum::<f32>() / p.len() as f32
            })
            .fold(0.0, f32::max)
    }

    /// A character modelled facing another way walks sideways in a crowd (which carries every
    /// character towards its +z): the import turns it back. Independent answer: the default
    /// character (which faces +z), turned by a known angle, comes back to its own poses.
    #[test]
    fn a_character_facing_another_way_is_turned_to_face_its_walk() {
        let original = crate::default_character::generate();
        let walk = original.find_clip("Walk").unwrap();
        let height = measure_motion(&original, Some(walk)).height;
        let mut same = original.clone();
        let (turn, _) = face_forward_and_play_in_place(&mut same);
        assert_eq!(turn, None, "the default character already faces +z");
        assert_eq!(same, original);
        for degrees in [90.0f32, -90.0, 180.0, 60.0, -130.0] {
            let mut c = original.clone();
            c.turn_about_vertical(degrees.to_radians());
            // Turned, it is not the original (the test can fail).
            assert!(pose_distance(&c, &original, walk) > 0.05 * height, "{degrees}°");
            let (turn, _) = face_forward_and_play_in_place(&mut c);
            let turn = turn.unwrap_or_else(|| panic!("{degrees}° not turned back"));
            // Quarter turns come back exactly; other headings to within the measure's error.
            let back = (turn.to_degrees() + degrees + 540.0).rem_euclid(360.0) - 180.0;
            if degrees % 90.0 == 0.0 {
                assert!(back.abs() < 1e-3, "{degrees}°: turned {}°", turn.to_degrees());
                assert!(pose_distance(&c, &original, walk) < 1e-4 * height, "{degrees}°");
            } else {
                assert!(back.abs() < 3.0, "{degrees}°: turned {}°", turn.to_degrees());
            }
            let (root, feet) = ground_velocities(&c, Some(walk));
            let v = root - feet;
            assert!(v.x.atan2(v.y).to_degrees().abs() < 3.0, "{degrees}°: heads {v}");
        }
        // Within the +z quarter: left as modelled.
        let mut c = original.clone();
        c.turn_about_vertical(30f32.to_radians());
        let before = c.clone();
        assert_eq!(face_forward_and_play_in_place(&mut c).0, None);
        assert_eq!(c, before);
    }

    /// A character modelled where it stood in a scene (30 m east, 20 m north of its origin)
    /// is moved back over its origin; one a little off its origin, or one whose origin lies
    /// within its footprint, is left as modelled. Independent answer: the original, moved
    /// rigidly; cubic-spline tangents of a moved root channel stay rates.
    #[test]
    fn a_character_standing_off_its_origin_is_moved_back_over_it() {
        let original = crate::default_character::generate();
        assert_eq!(off_origin(&original), None);
        let height = measure_motion(&original, original.find_clip("Walk")).height;
        let far = Vec3::new(30.0, 0.0, -20.0);
        let mut c = original.clone();
        c.move_rigidly(glam::Quat::IDENTITY, far);
        let shift = off_origin(&c).expect("30 m off is moved");
        c.move_rigidly(glam::Quat::IDENTITY, shift);
        let left = far + shift;
        assert!(left.length() < 0.05 * height && left.y == 0.0, "{left}");
        for clip in 0..c.clips.len() {
            let d = c.clips[clip].duration_secs;
            for k in 0..6 {
                let t = d * k as f32 / 6.0;
                let p = skin_vertices(&c, &Pose::sample(&c, &c.clips[clip], t)).0;
                let q = skin_vertices(&original, &Pose::sample(&original, &original.clips[clip], t)).0;
                let off = p
                    .iter()
                    .zip(&q)
                    .map(|(a, b)| (*a - *b - left).length())
                    .fold(0.0, f32::max);
                assert!(off < 1e-3, "clip {clip} at {t}: {off}");
            }
        }
        // A third of a footprint off: left alone.
        let mut near = original.clone();
        near.move_rigidly(glam::Quat::IDENTITY, Vec3::new(0.3, 0.0, 0.0));
        assert_eq!(off_origin(&near), None);
        // Cubic-spline translation on a root: values move, tangents do not.
        let mut cubic = original.clone();
        let root = cubic.skeleton.nodes.iter().position(|n| n.parent.is_none()).unwrap();
        cubic.clips[0].channels.push(crate::character::Channel {
            node: root,
            interpolation: crate::character::Interpolation::CubicSpline,
            times: vec![0.0, 1.0],
            values: crate::character::ChannelValues::Translation(vec![
                Vec3::X,
                Vec3::ZERO,
                Vec3::X,
                Vec3::X,
                Vec3::Y,
                Vec3::X,
            ]),
        });
        cubic.move_rigidly(glam::Quat::IDENTITY, far);
        let crate::character::ChannelValues::Translation(v) = &cubic.clips[0].channels.last().unwrap().values else {
            unreachable!()
        };
        assert_eq!(v, &[Vec3::X, far, Vec3::X, Vec3::X, Vec3::Y + far, Vec3::X]);
    }

    /// The votes: no locomotion, no turn; a tie with +z, no turn; most clips one way, that way.
    #[test]
    fn the_facing_turn_follows_most_locomotion_clips() {
        let clip = |x: f32, z: f32| ClipMotion {
            root: Vec2::new(x, z),
            contact: 1.0,
            height: 1.0,
            duration: 1.0,
            ..Default::default()
        };
        assert!(clip(0.0, 1.0).is_locomotion());
        let still = ClipMotion {
            height: 1.0,
            duration: 1.0,
            contact: 1.0,
            ..Default::default()
        };
        assert_eq!(facing_turn(&[]), None);
        assert_eq!(facing_turn(&[still]), None);
        assert_eq!(facing_turn(&[clip(0.0, 1.0), clip(0.0, -1.0)]), None);
        // Walk and run towards +x, a walk back, side steps: +x has the most.
        let t = facing_turn(&[
            clip(1.0, 0.0),
            clip(2.0, 0.1),
            clip(-1.0, 0.0),
            clip(0.0, 1.0),
            clip(0.0, -1.0),
        ]);
        assert!((t.unwrap() + std::f32::consts::FRAC_PI_2).abs() < 1e-6, "{t:?}");
        // A walk, a walk back and side steps with +z's walk: +z ties or leads, no turn.
        assert_eq!(
            facing_turn(&[clip(0.0, 1.0), clip(0.0, -1.0), clip(1.0, 0.0), clip(-1.0, 0.0)]),
            None
        );
        // Feet sliding back under a character walking in place towards -x.
        let in_place = ClipMotion {
            feet: Vec2::new(1.5, 0.0),
            ..clip(0.0, 0.0)
        };
        let t = facing_turn(&[in_place]).unwrap();
        assert!((t - std::f32::consts::FRAC_PI_2).abs() < 1e-6, "{t}");
    }

    #[test]
    fn a_clip_that_does_not_come_back_neither_loops_nor_walks() {
        use crate::character::ChannelValues;
        let mut c = crate::default_character::generate();
        let walk = c.find_clip("Walk").unwrap();
        let idle = c.find_clip("Idle").unwrap();
        let m = measure_motion(&c, Some(walk));
        assert!(m.loops() && m.is_locomotion(), "{m:?}");
        let m = measure_motion(&c, Some(idle));
        assert!(m.loops() && !m.is_locomotion() && m.ground_speed() == 0.0, "{m:?}");
        // The Run made a running leap (the body thrown 0.4 of its height up in the middle of
        // the loop, the legs striding as before): the contact point still moves evenly while
        // it is down, but it is no gait for a crowd to walk or run with.
        let run = c.find_clip("Run").unwrap();
        let m = measure_motion(&c, Some(run));
        assert!(m.is_locomotion() && m.lift < 0.1, "{m:?}");
        let mut leap = c.clone();
        let r = leap.skeleton.nodes.iter().position(|n| n.parent.is_none()).unwrap();
        let rest = leap.skeleton.nodes[r].rest.translation;
        let (d, h) = (leap.clips[run].duration_secs, m.height);
        let clip = &mut leap.clips[run];
        let up = |y: f32| rest + Vec3::new(0.0, y * h, 0.0);
        root_keys(
            clip,
            r,
            vec![0.0, 0.3 * d, 0.5 * d, 0.7 * d, d],
            vec![up(0.0), up(0.0), up(0.4), up(0.0), up(0.0)],
        );
        let m = measure_motion(&leap, Some(run));
        assert!(m.loops() && m.lift > LOCOMOTION_MAX_LIFT, "{m:?}");
        // (What rules it out is the lift: on the ground its contact point is a run's.)
        assert!(
            m.contact >= LOCOMOTION_CONTACT && m.spread <= LOCOMOTION_SPREAD && (m.root - m.feet).length() > 0.0,
            "{m:?}"
        );
        assert!(!m.is_locomotion() && !m.is_stride_estimate(), "{m:?}");
        // A hop of a tenth of the height (a bouncy run) still runs.
        if let Some(ch) = leap.clips[run].channels.last_mut()
            && let ChannelValues::Translation(v) = &mut ch.values
        {
            v[2] = up(0.1);
        }
        let m = measure_motion(&leap, Some(run));
        assert!(m.is_locomotion(), "{m:?}");
        // Standing (its feet shuffle at about 6 cm/s): measured against the slowest walk's
        // pace, a spread of the order of 1; against the sway's own drift it read 41.
        assert!(m.spread < 1.5 && m.contact > 0.3, "{m:?}");
        // The walk sinking by a third of its height over the clip (a fall, a sit): its last
        // pose is not its first.
        let r = c.skeleton.nodes.iter().position(|n| n.parent.is_none()).unwrap();
        let rest = c.skeleton.nodes[r].rest.translation;
        let d = c.clips[walk].duration_secs;
        let clip = &mut c.clips[walk];
        root_keys(clip, r, vec![0.0, d], vec![rest, rest - Vec3::new(0.0, 0.6, 0.0)]);
        let m = measure_motion(&c, Some(walk));
        assert!(!m.loops() && !m.is_locomotion() && m.ground_speed() == 0.0, "{m:?}");
        // Nor is it played in place: what is not steady locomotion keeps its travel.
        let mut forward = c.clone();
        if let Some(ch) = forward.clips[walk].channels.last_mut()
            && let ChannelValues::Translation(vals) = &mut ch.values
        {
            vals[1].z += 2.0;
        }
        assert!(play_in_place(&mut forward).is_empty());
        assert_eq!(forward.clips[walk].in_place_velocity, Vec3::ZERO);
        // Unless it carries the character far (ten heights, more than the bake can frame):
        // then it is played in place too, and the import says so.
        let mut far = c.clone();
        if let Some(ch) = far.clips[walk].channels.last_mut()
            && let ChannelValues::Translation(vals) = &mut ch.values
        {
            vals[1].z += 10.0 * m.height;
        }
        let changed = play_in_place(&mut far);
        assert_eq!(changed.len(), 1, "{changed:?}");
        let v = far.clips[walk].in_place_velocity;
        assert!(
            (v.z * d - 10.0 * m.height).abs() < 0.01 * m.height && v.x.abs() < 1e-3,
            "{v}"
        );
        assert!(
            far.warnings.iter().any(|w| w.contains("without walking")),
            "{:?}",
            far.warnings
        );
        // A clip that comes back to its first pose but carries the character more than its
        // height (the Idle, its root slid 1.5 heights forward over the loop, feet and all): it
        // would jump back at every loop, and is played in place; the same clip carried half
        // a height keeps its travel.
        for (heights, in_place) in [(1.5f32, true), (0.5, false)] {
            let mut slid = c.clone();
            let d = slid.clips[idle].duration_secs;
            let clip = &mut slid.clips[idle];
            root_keys(
                clip,
                r,
                vec![0.0, d],
                vec![rest, rest + Vec3::new(0.0, 0.0, heights * m.height)],
            );
            let sm = measure_motion(&slid, Some(idle));
            assert!(sm.loops(), "{sm:?}");
            play_in_place(&mut slid);
            let v = slid.clips[idle].in_place_velocity;
            if in_place {
                assert!((v.z * d - heights * m.height).abs() < 0.02 * m.height, "{heights}: {v}");
            } else if !sm.is_locomotion() {
                assert_eq!(v, Vec3::ZERO, "{heights}: {sm:?}");
            }
        }
        let t = Timeline::measured(&c, &[Some(walk), Some(idle)], 10.0).unwrap();
        assert!(!t.spans[0].looping && t.spans[1].looping);
        // A clip that does not loop holds its last frame, and that frame is its end pose.
        assert_eq!(t.next(9), 9);
        assert_eq!(t.prev(0), 0);
        let (clip, secs) = t.samples()[9];
        assert_eq!(clip, Some(walk));
        assert!(secs < d && secs > d * 0.999, "{secs} of {d}");
        let end = Pose::sample(&c, &c.clips[walk], secs).locals[r].translation;
        assert!((end.y - (rest.y - 0.6)).abs() < 1e-3, "{end} {rest}");
        // The loop after it keeps its even frames.
        assert_eq!(t.spans[1].step(10.0), 0.1);
    }

    /// The leg sweep against an independent answer, the contact speed: calibrated on the Walk,
    /// it predicts the Run's contact speed; shaking the whole body back and forth (six times a
    /// loop) spoils the contact point's speed but not the feet's sweep under the body, and the
    /// shaken Run then gets the stride estimate near its true speed.
    #[test]
    fn the_leg_sweep_stands_in_for_the_contact_speed_of_a_run_whose_feet_slide() {
        let mut c = crate::default_character::generate();
        let (walk, run) = (c.find_clip("Walk").unwrap(), c.find_clip("Run").unwrap());
        let m = measure_clips(&c);
        let (w, r) = (m[walk], m[run]);
        assert!(w.is_locomotion() && r.is_locomotion() && !r.is_stride_estimate());
        assert!(w.sweep > 0.0 && r.sweep > 0.0, "{w:?} {r:?}");
        let truth = r.ground_speed();
        let predicted = r.sweep * w.ground_speed() / w.sweep;
        assert!((predicted / truth - 1.0).abs() < 0.25, "{predicted} against {truth}");
        // Standing clips do not stride.
        for name in ["Idle", "Wave"] {
            let s = m[c.find_clip(name).unwrap()];
            assert_eq!(s.sweep, 0.0, "{name} {s:?}");
            assert_eq!(s.ground_speed(), 0.0);
        }
        // The shake: the root's translation plus a fore-aft oscillation, six periods a loop.
        let root = c.skeleton.nodes.iter().position(|n| n.parent.is_none()).unwrap();
        let d = c.clips[run].duration_secs;
        let amplitude = 0.15 * w.height;
        let keys = 97;
        let times: Vec<f32> = (0..keys).map(|k| d * k as f32 / (keys - 1) as f32).collect();
        let clip = &c.clips[run];
        let base: Vec<Vec3> = times
            .iter()
            .map(|&t| Pose::sample(&c, clip, t.min(d * (1.0 - 1e-4))).locals[root].translation)
            .collect();
        let values = times
            .iter()
            .zip(&base)
            .map(|(&t, b)| *b + Vec3::new(0.0, 0.0, amplitude * (std::f32::consts::TAU * 6.0 * t / d).sin()))
            .collect();
        let clip = &mut c.clips[run];
        root_keys(clip, root, times, values);
        let shaken = measure_clips(&c);
        let s = shaken[run];
        assert!(!s.is_locomotion(), "the shake should spoil the contact point: {s:?}");
        assert!(s.is_stride_estimate(), "{s:?}");
        assert!(
            (s.sweep / r.sweep - 1.0).abs() < 0.05,
            "sweep {} against {}",
            s.sweep,
            r.sweep
        );
        assert!(
            (s.ground_speed() / truth - 1.0).abs() < 0.25,
            "{} against {truth}",
            s.ground_speed()
        );
        assert_eq!(ground_speed(&c, Some(run)), s.ground_speed());
        // Measured alone, a clip reads as measured with all (the scale comes from the others).
        assert_eq!(measure_some(&c, &[run])[0], s);
        assert_eq!(measure_some(&c, &[run, walk]), vec![s, w]);
        // The Walk is untouched, and the timeline carries the estimate.
        assert_eq!(shaken[walk], w);
        let t = Timeline::measured(&c, &[Some(walk), Some(run)], 10.0).unwrap();
        assert!(t.spans[1].ground_speed > 1.3 * t.spans[0].ground_speed, "{:?}", t.spans);
    }
}
