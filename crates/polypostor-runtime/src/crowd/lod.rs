//! Levels of detail: the skinned mesh near, the Polypostor in the middle, the classic
//! impostor far. A character's level follows its pixel-to-texel ratio: how many screen pixels
//! it covers against how many texels its baked images have along the same height.

pub use crate::records::Level;

/// Which representation each visible character gets.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LodPolicy {
    /// Every character the same way.
    Only(Level),
    /// Skinned mesh / Polypostor / classic impostor by pixel-to-texel ratio.
    Mixed(LodDistances),
}

/// Switch points of the three-level mix, as pixel-to-texel ratios (screen pixels the
/// character covers ÷ texels of its baked image over the same height).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LodDistances {
    /// Texels of the baked images along the character's height (the bake's resolution).
    pub texels: f32,
    /// Above this ratio the images would be magnified: the skinned mesh. Default value: 1.0
    /// (one texel per pixel).
    pub mesh_above: f32,
    /// Below this ratio the Polypostor's vertex work no longer pays: the impostor. Default
    /// value: 0.25.
    pub impostor_below: f32,
    /// Relative band around each switch point inside which a character keeps its previous
    /// level (no popping back and forth). Default value: 0.1.
    pub hysteresis: f32,
}

impl Default for LodDistances {
    fn default() -> Self {
        Self {
            texels: 128.0,
            mesh_above: 1.0,
            impostor_below: 0.25,
            hysteresis: 0.1,
        }
    }
}

impl LodDistances {
    /// The camera distance at which a character of `height` covering `focal_px·height/d`
    /// pixels reaches `ratio` (for drawing the switch rings and the UI).
    pub fn distance_for_ratio(&self, ratio: f32, height: f32, focal_px: f32) -> f32 {
        height * focal_px / (ratio * self.texels).max(1e-6)
    }
}

impl LodPolicy {
    /// The level for a character covering `pixels` screen pixels in height that had level
    /// `previous` last frame.
    pub fn choose(&self, pixels: f32, previous: Level) -> Level {
        let d = match self {
            LodPolicy::Only(level) => return *level,
            LodPolicy::Mixed(d) => d,
        };
        let ratio = pixels / d.texels.max(1.0);
        let rank = |l: Level| match l {
            Level::Skinned | Level::Rigid => 0,
            Level::Polypostor | Level::Np3d => 1,
            Level::Impostor => 2,
        };
        let plain = if ratio > d.mesh_above {
            Level::Skinned
        } else if ratio > d.impostor_below {
            Level::Polypostor
        } else {
            Level::Impostor
        };
        // Inside the band around a switch point between the previous level and the plain
        // choice, keep the previous level.
        let (lo, hi) = (1.0 - d.hysteresis, 1.0 + d.hysteresis);
        let keep = match (rank(previous), rank(plain)) {
            (0, 1) => ratio > d.mesh_above * lo,
            (1, 0) => ratio <= d.mesh_above * hi,
            (1, 2) => ratio > d.impostor_below * lo,
            (2, 1) => ratio <= d.impostor_below * hi,
            _ => false,
        };
        if keep {
            match rank(previous) {
                0 => Level::Skinned,
                1 => Level::Polypostor,
                _ => Level::Impostor,
            }
        } else {
            plain
        }
    }
}
