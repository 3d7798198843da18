//! The default character's 512×512 texture, painted procedurally: striped shirt with a chest
//! emblem and buttons, belt, denim trousers with seams and knee patches, leather shoes with
//! laces, skin, hair and a face. Each body piece owns a rectangle ([`Region`]) of the atlas.

use crate::character::Texture;

pub const SIZE: u32 = 512;
/// Texels kept free around each region so filtering never mixes regions.
const INSET_PX: f32 = 3.0;

/// A rectangle of the texture atlas in UV space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Region {
    pub u0: f32,
    pub v0: f32,
    pub u1: f32,
    pub v1: f32,
    pub kind: Kind,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Torso,
    Head,
    Legs,
    Arms,
    Hands,
    Feet,
    Neck,
    Skin,
}

impl Region {
    pub const TORSO: Region = Region {
        u0: 0.0,
        v0: 0.0,
        u1: 0.5,
        v1: 0.5,
        kind: Kind::Torso,
    };
    pub const HEAD: Region = Region {
        u0: 0.5,
        v0: 0.0,
        u1: 1.0,
        v1: 0.5,
        kind: Kind::Head,
    };
    pub const LEGS: Region = Region {
        u0: 0.0,
        v0: 0.5,
        u1: 0.3,
        v1: 1.0,
        kind: Kind::Legs,
    };
    pub const ARMS: Region = Region {
        u0: 0.3,
        v0: 0.5,
        u1: 0.55,
        v1: 1.0,
        kind: Kind::Arms,
    };
    pub const HANDS: Region = Region {
        u0: 0.55,
        v0: 0.5,
        u1: 0.7,
        v1: 0.75,
        kind: Kind::Hands,
    };
    pub const FEET: Region = Region {
        u0: 0.55,
        v0: 0.75,
        u1: 0.7,
        v1: 1.0,
        kind: Kind::Feet,
    };
    pub const NECK: Region = Region {
        u0: 0.7,
        v0: 0.5,
        u1: 0.85,
        v1: 0.75,
        kind: Kind::Neck,
    };
    pub const SKIN: Region = Region {
        u0: 0.7,
        v0: 0.75,
        u1: 0.85,
        v1: 1.0,
        kind: Kind::Skin,
    };
    const ALL: [Region; 8] = [
        Self::TORSO,
        Self::HEAD,
        Self::LEGS,
        Self::ARMS,
        Self::HANDS,
        Self::FEET,
        Self::NECK,
        Self::SKIN,
    ];

    fn inset(&self) -> (f32, f32, f32, f32) {
        let e = INSET_PX / SIZE as f32;
        (self.u0 + e, self.v0 + e, self.u1 - e, self.v1 - e)
    }

    /// UV of the piece coordinates `s` (around, 0.5 = front) and `t` (along, 0..1).
    /// `t = 0` maps to the bottom of the rectangle (v1), so pieces built bottom-up read upright.
    pub fn uv(&self, s: f32, t: f32) -> [f32; 2] {
        let (u0, v0, u1, v1) = self.inset();
        [u0 + (u1 - u0) * s, v1 - (v1 - v0) * t]
    }

    /// Inverse of [`Region::uv`] with clamping (texels of the padding copy the edge).
    fn st(&self, u: f32, v: f32) -> (f32, f32) {
        let (u0, v0, u1, v1) = self.inset();
        (
            ((u - u0) / (u1 - u0)).clamp(0.0, 1.0),
            ((v1 - v) / (v1 - v0)).clamp(0.0, 1.0),
        )
    }
}

type Rgb = [f32; 3];

fn mix(a: Rgb, b: Rgb, k: f32) -> Rgb {
    let k = k.clamp(0.0, 1.0);
    [
        a[0] + (b[0] - a[0]) * k,
        a[1] + (b[1] - a[1]) * k,
        a[2] + (b[2] - a[2]) * k,
    ]
}

fn scale(a: Rgb, k: f32) -> Rgb {
    [a[0] * k, a[1] * k, a[2] * k]
}

/// Anti-aliased coverage of `d < 0` (a signed distance in piece units) at `px` units per texel.
fn cover(d: f32, px: f32) -> f32 {
    (0.5 - d / px).clamp(0.0, 1.0)
}

/// Integer hash to [0,1): deterministic value noise.
fn hash(x: i32, y: i32, seed: u32) -> f32 {
    let mut h =
        (x as u32).wrapping_mul(0x8da6_b343) ^ (y as u32).wrapping_mul(0xd816_3841) ^ seed.wrapping_mul(0xcb1a_b31f);
    h ^= h >> 13;
    h = h.wrapping_mul(0x5bd1_e995);
    h ^= h >> 15;
    (h & 0x00ff_ffff) as f32 / 16_777_216.0
}

fn value_noise(x: f32, y: f32, seed: u32) -> f32 {
    let (xi, yi) = (x.floor() as i32, y.floor() as i32);
    let (fx, fy) = (x - x.floor(), y - y.floor());
    let (sx, sy) = (fx * fx * (3.0 - 2.0 * fx), fy * fy * (3.0 - 2.0 * fy));
    let a = hash(xi, yi, seed);
    let b = hash(xi + 1, yi, seed);
    let c = hash(xi, yi + 1, seed);
    let d = hash(xi + 1, yi + 1, seed);
    a + (b - a) * sx + (c - a) * sy + (a - b - c + d) * sx * sy
}

const SKIN: Rgb = [0.87, 0.67, 0.54];
const HAIR: Rgb = [0.28, 0.17, 0.10];
const SHIRT: Rgb = [0.13, 0.45, 0.62];
const STRIPE: Rgb = [0.93, 0.93, 0.88];
const DENIM: Rgb = [0.20, 0.26, 0.43];
const LEATHER: Rgb = [0.36, 0.20, 0.11];
const SOLE: Rgb = [0.92, 0.90, 0.85];
const BELT: Rgb = [0.30, 0.17, 0.09];
const GOLD: Rgb = [0.95, 0.75, 0.20];

fn skin(s: f32, t: f32) -> Rgb {
    let n = value_noise(s * 60.0, t * 60.0, 7) * 0.06 - 0.03;
    mix(SKIN, [0.80, 0.55, 0.45], 0.3 + n)
}

fn shirt(s: f32, t: f32, px: f32) -> Rgb {
    // Horizontal stripes with a thin accent line, plus a woven grain.
    let period = 0.085;
    let ph = (t / period).fract();
    let stripe = cover((ph - 0.5).abs() - 0.14, px / period);
    let accent = cover((ph - 0.05).abs() - 0.03, px / period);
    let grain = value_noise(s * 180.0, t * 180.0, 3) * 0.08 - 0.04;
    let c = mix(SHIRT, STRIPE, stripe * 0.85);
    let c = mix(c, [0.85, 0.25, 0.20], accent);
    scale(c, 1.0 + grain)
}

fn torso(s: f32, t: f32, px: f32) -> Rgb {
    let front = s - 0.5; // 0 at the front, ±0.5 at the back seam
    if t < 0.13 {
        return trousers(s, t * 3.0, px);
    }
    if t < 0.185 {
        // Belt with a gold buckle at the front.
        let buckle = cover(front.abs().max((t - 0.157).abs() * 1.8) - 0.028, px);
        let hole = cover(front.abs().max((t - 0.157).abs() * 1.8) - 0.016, px);
        let stitch = cover((t - 0.137).abs() - 0.002, px) + cover((t - 0.178).abs() - 0.002, px);
        let c = mix(BELT, [0.55, 0.40, 0.25], stitch * 0.6);
        return mix(mix(c, GOLD, buckle), BELT, hole * 0.9);
    }
    let mut c = shirt(s, t, px);
    // V-neck showing skin at the top front, with a darker hem.
    let neck = front.abs() - (t - 0.86) * 0.55;
    c = mix(c, skin(s, t), cover(neck, px));
    c = mix(
        c,
        [0.08, 0.28, 0.40],
        cover(neck.abs() - 0.006, px) * if t > 0.84 { 1.0 } else { 0.0 },
    );
    // Button placket down the front with buttons.
    let placket = cover(front.abs() - 0.012, px);
    c = mix(c, scale(SHIRT, 0.8), placket * 0.6);
    for k in 0..5 {
        let by = 0.3 + 0.13 * k as f32;
        let d = ((front * 1.0).powi(2) + ((t - by) * 0.5).powi(2)).sqrt() - 0.008;
        c = mix(c, [0.95, 0.95, 0.95], cover(d, px));
    }
    // Chest emblem: a five-pointed star in a circle on the left chest (viewer's right).
    let (ex, ey) = (front - 0.09, (t - 0.74) * 0.55);
    let r = (ex * ex + ey * ey).sqrt();
    c = mix(c, [0.98, 0.85, 0.25], cover((r - 0.045).abs() - 0.004, px));
    let a = ey.atan2(ex) + std::f32::consts::FRAC_PI_2;
    let k = (a / (std::f32::consts::TAU / 5.0)).rem_euclid(1.0) - 0.5;
    let star_r = 0.015 + 0.022 * (1.0 - 2.0 * k.abs());
    c = mix(c, [0.95, 0.30, 0.20], cover(r - star_r, px));
    // Back print: a large number "7" centred on the back seam.
    let bs = if s < 0.5 { s } else { s - 1.0 }; // 0 at the back centre, signed
    let (px7, py7) = (bs, t - 0.62);
    let seven = segment_distance(px7, py7, -0.06, 0.12, 0.06, 0.12)
        .min(segment_distance(px7, py7, 0.06, 0.12, -0.02, -0.12))
        - 0.016;
    c = mix(c, [0.95, 0.95, 0.90], cover(seven, px));
    c
}

/// Distance from (x, y) to the segment (ax, ay)-(bx, by).
fn segment_distance(x: f32, y: f32, ax: f32, ay: f32, bx: f32, by: f32) -> f32 {
    let (dx, dy) = (bx - ax, by - ay);
    let k = (((x - ax) * dx + (y - ay) * dy) / (dx * dx + dy * dy)).clamp(0.0, 1.0);
    ((x - ax - k * dx).powi(2) + (y - ay - k * dy).powi(2)).sqrt()
}

fn trousers(s: f32, t: f32, px: f32) -> Rgb {
    // Denim: diagonal twill, noise, seams, stitched knee patches and darker cuffs.
    let twill = ((s * 300.0 + t * 300.0) * 0.5).fract();
    let n = value_noise(s * 40.0, t * 90.0, 11) * 0.18 - 0.09;
    let mut c = scale(DENIM, 1.0 + n + (twill - 0.5) * 0.08);
    for seam in [0.25f32, 0.75] {
        let d = (s - seam).abs();
        c = mix(c, scale(DENIM, 0.65), cover(d - 0.004, px));
        c = mix(c, [0.85, 0.62, 0.25], cover((d - 0.012).abs() - 0.002, px) * 0.8);
    }
    // Knee patch at the front.
    let pd = ((s - 0.5).abs() - 0.12).max((t - 0.52).abs() - 0.06);
    c = mix(c, scale(DENIM, 1.35), cover(pd, px));
    let stitch = cover(pd.abs() - 0.0025, px) * if ((s + t) * 160.0).fract() < 0.5 { 1.0 } else { 0.0 };
    c = mix(c, [0.85, 0.62, 0.25], stitch);
    // Cuffs.
    if t > 0.92 {
        c = scale(c, 0.75);
    }
    c
}

fn head(s: f32, t: f32, px: f32) -> Rgb {
    let mut c = skin(s, t);
    let front = s - 0.5;
    // Cheeks.
    for side in [-1.0f32, 1.0] {
        let d = ((front - side * 0.1).powi(2) + ((t - 0.42) * 1.1).powi(2)).sqrt();
        c = mix(c, [0.90, 0.52, 0.48], (1.0 - d / 0.05).clamp(0.0, 1.0) * 0.35);
    }
    // Eyes: white, iris, pupil, upper lid line; eyebrows.
    for side in [-1.0f32, 1.0] {
        let (ex, ey) = (front - side * 0.065, (t - 0.53) * 1.6);
        let eye = ((ex / 0.032).powi(2) + (ey / 0.028).powi(2)).sqrt() - 1.0;
        c = mix(c, [0.97, 0.97, 0.95], cover(eye * 0.03, px));
        let iris = (ex * ex + ey * ey).sqrt() - 0.016;
        c = mix(c, [0.20, 0.45, 0.70], cover(iris, px));
        let pupil = (ex * ex + ey * ey).sqrt() - 0.008;
        c = mix(c, [0.03, 0.03, 0.05], cover(pupil, px));
        let glint = ((ex + 0.005).powi(2) + (ey - 0.006).powi(2)).sqrt() - 0.003;
        c = mix(c, [1.0, 1.0, 1.0], cover(glint, px));
        let lid = ((ex / 0.034).powi(2) + ((ey - 0.004) / 0.03).powi(2)).sqrt() - 1.0;
        c = mix(
            c,
            [0.25, 0.15, 0.10],
            cover(lid.abs() * 0.03 - 0.0025, px) * if ey > 0.0 { 1.0 } else { 0.0 },
        );
        let brow =
            ((ex / 0.04).powi(2) + ((t - 0.605 - 0.01 * (1.0 - (ex / 0.04).powi(2))) / 0.009).powi(2)).sqrt() - 1.0;
        c = mix(c, HAIR, cover(brow * 0.01, px));
    }
    // Nose shadow and mouth.
    let nose = ((front / 0.02).powi(2) + ((t - 0.45) / 0.05).powi(2)).sqrt() - 1.0;
    c = mix(c, scale(SKIN, 0.85), (-nose).clamp(0.0, 1.0) * 0.5);
    let mx = front / 0.05;
    let mouth_curve = 0.36 - 0.012 * (1.0 - mx * mx);
    let mouth = (t - mouth_curve).abs() - 0.006 * (1.0 - mx * mx).max(0.0);
    c = mix(c, [0.70, 0.25, 0.25], cover(mouth.max(mx.abs() - 1.0), px));
    // Hair: a crown everywhere, down to the neck at the back, with a fringe and strands.
    let back = 1.0 - (front.abs() * 2.0); // 1 at the front, 0 at the back seam
    let hairline = 0.69 - 0.36 * (1.0 - back).powf(1.3) + 0.02 * (front * 40.0).sin();
    let strands = value_noise(s * 120.0, t * 12.0, 5) * 0.25;
    let hair_c = scale(HAIR, 0.85 + strands);
    mix(c, hair_c, cover(hairline - t, px))
}

fn arms(s: f32, t: f32, px: f32) -> Rgb {
    // The arm tube runs from the shoulder (t = 0) to the wrist (t = 1); flip so t = 1 is the
    // shoulder: a short sleeve ending above the elbow.
    let t = 1.0 - t;
    let sleeve_end = 0.55;
    if t > sleeve_end + 0.03 {
        shirt(s, t, px)
    } else if t > sleeve_end {
        [0.85, 0.25, 0.20] // sleeve cuff band
    } else {
        let mut c = skin(s, t);
        // A wristwatch on the lower arm.
        let band = cover((t - 0.08).abs() - 0.025, px);
        c = mix(c, [0.12, 0.12, 0.14], band);
        let face = ((s - 0.5).powi(2) + ((t - 0.08) * 1.2).powi(2)).sqrt() - 0.05;
        c = mix(c, [0.80, 0.80, 0.85], cover(face, px));
        c
    }
}

fn hands(s: f32, t: f32, px: f32) -> Rgb {
    let mut c = skin(s, t);
    // Finger separations near the tip.
    if t > 0.55 {
        for k in [0.25f32, 0.5, 0.75] {
            c = mix(
                c,
                scale(SKIN, 0.75),
                cover((s.fract() - k).abs() - 0.006, px) * ((t - 0.55) * 4.0).min(1.0),
            );
        }
    }
    c
}

fn feet(s: f32, t: f32, px: f32) -> Rgb {
    // s = 0.5 is the top of the shoe, t from heel (0) to toe (1).
    let top = (s - 0.5).abs();
    let n = value_noise(s * 50.0, t * 50.0, 13) * 0.1;
    let mut c = scale(LEATHER, 0.95 + n);
    // White sole around the bottom.
    c = mix(c, SOLE, cover(0.36 - top, px));
    c = mix(c, scale(SOLE, 0.7), cover((top - 0.36).abs() - 0.005, px));
    // Laces criss-crossing on top.
    if (0.25..0.62).contains(&t) {
        let ph = ((t - 0.25) * 22.0).fract() - 0.5;
        let x1 = (s - 0.5 - ph * 0.08).abs() - 0.008;
        let x2 = (s - 0.5 + ph * 0.08).abs() - 0.008;
        c = mix(c, [0.92, 0.92, 0.88], cover(x1.min(x2).max(top - 0.06), px));
    }
    // Toe cap stitching.
    c = mix(
        c,
        [0.6, 0.45, 0.3],
        cover((t - 0.8).abs() - 0.006, px) * if top < 0.3 { 1.0 } else { 0.0 },
    );
    c
}

fn paint_texel(region: &Region, s: f32, t: f32, px: f32) -> Rgb {
    match region.kind {
        Kind::Torso => torso(s, t, px),
        Kind::Head => head(s, t, px),
        Kind::Legs => trousers(s, 1.0 - t, px),
        Kind::Arms => arms(s, t, px),
        Kind::Hands => hands(s, t, px),
        Kind::Feet => feet(s, t, px),
        Kind::Neck => skin(s, t),
        Kind::Skin => skin(s, t),
    }
}

fn to_srgb8(x: f32) -> u8 {
    (x.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
}

/// Paints the whole atlas.
pub fn paint() -> Texture {
    let mut rgba8 = vec![0u8; (SIZE * SIZE * 4) as usize];
    for y in 0..SIZE {
        for x in 0..SIZE {
            let (u, v) = ((x as f32 + 0.5) / SIZE as f32, (y as f32 + 0.5) / SIZE as f32);
            let region = Region::ALL
                .iter()
                .find(|r| u >= r.u0 && u < r.u1 && v >= r.v0 && v < r.v1)
                .copied()
                .unwrap_or(Region::SKIN);
            let (s, t) = region.st(u, v);
            // Size of one texel in piece units (for anti-aliasing).
            let px = 1.0 / ((region.u1 - region.u0).min(region.v1 - region.v0) * SIZE as f32);
            let c = paint_texel(&region, s, t, px);
            let i = ((y * SIZE + x) * 4) as usize;
            rgba8[i..i + 4].copy_from_slice(&[to_srgb8(c[0]), to_srgb8(c[1]), to_srgb8(c[2]), 255]);
        }
    }
    Texture {
        name: "default_humanoid_albedo".into(),
        width: SIZE,
        height: SIZE,
        rgba8,
    }
}
