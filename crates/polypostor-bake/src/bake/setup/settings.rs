//! The bake's settings as one struct: what the project stores (`project.json`'s `bake`),
//! what the command line starts from (its flags override single fields), and what the
//! editor's bake (Ctrl+B) and export dialog use and write back. [`BakeSettings::options`]
//! turns them into the pipeline's [`BakeOptions`]; the clips, key frame and the artist's
//! corrections come from the project and the caller.

use serde::{Deserialize, Serialize};

use crate::bake::keys::KeyOptions;
use crate::bake::pipeline::{BakeOptions, PngCompression, TextureEncoding};
use crate::bake::viewpoints::Coverage;
use crate::limits::{MAX_FPS, MAX_RESOLUTION, MAX_VIEWS, MIN_FPS, MIN_RESOLUTION};

/// Every setting of a bake a user chooses (defaults: the documented ones).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct BakeSettings {
    /// Number of viewpoints.
    pub views: usize,
    /// Part image resolution (pixels, square).
    pub resolution: u32,
    /// Clip sampling rate (frames per second).
    pub fps: f32,
    /// Views over the whole sphere instead of the upper hemisphere.
    pub full_sphere: bool,
    /// What to bake: `polypostor`, `impostor`, `np3d`, `rigid` or `all`, comma-separated.
    pub representations: String,
    /// How the textures are stored.
    pub textures: TextureEncoding,
    /// PNG level where textures are PNG.
    pub png: PngCompression,
    /// Most key images per part and view.
    pub max_keys: usize,
    /// Least cut (dB) an added key image must buy.
    pub key_gain_db: f64,
    /// Bytes of added key images a view may spend, as a fraction of its first key images'.
    pub key_budget: f64,
    /// Most views, as a share of all, that the key budget other views left unspent goes to.
    pub key_share: f64,
    /// A view may spend on added key images whatever keeps it this many times smaller than
    /// classic impostors of one clip (up to as many bytes as its first key images); 0: off.
    pub key_ratio: f64,
    /// The exact dynamic programme instead of the fast mode.
    pub exhaustive: bool,
    /// Let fitted triangles fold over.
    pub allow_folds: bool,
    /// The paper's objective (no charge for missed target coverage).
    pub paper_objective: bool,
    /// The fast mode without restarts.
    pub no_restarts: bool,
    /// Vertices stay on the traced outlines' vertices (no sub-pixel placement).
    pub no_subpixel: bool,
    /// Vertices of each part's polygon in the pack (3 to the fitted polygon's 40; fewer are
    /// chosen by deformation-aware simplification).
    pub polygon_vertices: usize,
    /// Most vertices added inside each part's polygon, moved at every frame to where they
    /// lower the drawn error (0 to [`MAX_INTERIOR_VERTICES`]).
    pub interior_vertices: usize,
}

/// The most interior vertices a part's polygon may get.
pub const MAX_INTERIOR_VERTICES: usize = 24;

impl Default for BakeSettings {
    fn default() -> Self {
        let keys = KeyOptions::default();
        Self {
            views: crate::bake::viewpoints::DEFAULT_VIEW_COUNT,
            resolution: crate::bake::renders::DEFAULT_RESOLUTION,
            fps: crate::bake::renders::DEFAULT_FPS,
            full_sphere: false,
            representations: "polypostor".into(),
            textures: TextureEncoding::default(),
            png: PngCompression::default(),
            max_keys: keys.max_keys,
            key_gain_db: keys.min_gain_db,
            key_budget: keys.budget,
            key_share: keys.share,
            key_ratio: keys.ratio,
            exhaustive: false,
            allow_folds: false,
            paper_objective: false,
            no_restarts: false,
            no_subpixel: false,
            polygon_vertices: crate::bake::part_fit::DEFAULT_POLYGON_VERTICES,
            interior_vertices: crate::bake::part_fit::DEFAULT_INTERIOR_VERTICES,
        }
    }
}

/// A setting out of range: which one (its command-line flag without `--`) and why.
#[derive(Clone, Debug, PartialEq)]
pub struct SettingError {
    /// The setting's name as the command line spells it (`views`, `fps`, …).
    pub setting: &'static str,
    /// What is wrong and what to choose.
    pub message: String,
}

impl std::fmt::Display for SettingError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "--{} {}", self.setting, self.message)
    }
}

impl BakeSettings {
    /// Whether these are the defaults (a project file then leaves them out).
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }

    /// The first setting out of its documented range, before any work starts (a number too
    /// large or small to read is shown in scientific notation, not as 301 digits).
    pub fn validate(&self) -> Result<(), SettingError> {
        let bad = |setting, message: String| Err(SettingError { setting, message });
        if self.views == 0 || self.views > MAX_VIEWS {
            return bad("views", format!("{}: choose 1 to {MAX_VIEWS}", self.views));
        }
        if !(MIN_RESOLUTION..=MAX_RESOLUTION).contains(&self.resolution) {
            return bad(
                "resolution",
                format!("{}: choose {MIN_RESOLUTION} to {MAX_RESOLUTION}", self.resolution),
            );
        }
        if !(self.fps.is_finite() && self.fps >= MIN_FPS && self.fps <= MAX_FPS) {
            return bad("fps", format!("{}: choose {MIN_FPS} to {MAX_FPS}", shown(self.fps)));
        }
        if self.max_keys == 0 || self.max_keys > crate::bake::keys::MAX_KEYS {
            return bad(
                "max-keys",
                format!("{}: choose 1 to {}", self.max_keys, crate::bake::keys::MAX_KEYS),
            );
        }
        if !(self.key_gain_db.is_finite() && (0.0..=100.0).contains(&self.key_gain_db)) {
            return bad("key-gain-db", format!("{}: choose 0 to 100", shown(self.key_gain_db)));
        }
        if !(self.key_budget.is_finite() && (0.0..=16.0).contains(&self.key_budget)) {
            return bad("key-budget", format!("{}: choose 0 to 16", shown(self.key_budget)));
        }
        if !(self.key_share.is_finite() && (0.0..=1.0).contains(&self.key_share)) {
            return bad("key-share", format!("{}: choose 0 to 1", shown(self.key_share)));
        }
        if !(self.key_ratio.is_finite() && (self.key_ratio == 0.0 || (1.0..=10_000.0).contains(&self.key_ratio))) {
            return bad(
                "key-ratio",
                format!("{}: choose 0 (off) or 1 to 10000", shown(self.key_ratio)),
            );
        }
        if let Err(e) = polypostor_runtime::reps::RepSet::parse(&self.representations) {
            return bad("representation", format!("'{}': {e}", self.representations));
        }
        let most = crate::bake::part_fit::PartFitOptions::default().key_vertices;
        if !(3..=most).contains(&self.polygon_vertices) {
            return bad(
                "polygon-vertices",
                format!("{}: choose 3 to {most}", self.polygon_vertices),
            );
        }
        if self.interior_vertices > MAX_INTERIOR_VERTICES {
            return bad(
                "interior-vertices",
                format!("{}: choose 0 to {MAX_INTERIOR_VERTICES}", self.interior_vertices),
            );
        }
        if self.exhaustive && self.no_restarts {
            return bad("no-restarts", "applies to the fast mode, not with --exhaustive".into());
        }
        Ok(())
    }

    /// These settings with every one out of its range put back to its default, and what was
    /// wrong with each (a project file written by hand or by another version: the editor
    /// opened resolution 7 and views 0 without a word, and its export then failed).
    pub fn repaired(&self) -> (BakeSettings, Vec<SettingError>) {
        let mut s = self.clone();
        let d = BakeSettings::default();
        let mut errors = Vec::new();
        // One setting a round; at most every setting once.
        for _ in 0..16 {
            let Err(e) = s.validate() else { break };
            match e.setting {
                "views" => s.views = d.views,
                "resolution" => s.resolution = d.resolution,
                "fps" => s.fps = d.fps,
                "max-keys" => s.max_keys = d.max_keys,
                "key-gain-db" => s.key_gain_db = d.key_gain_db,
                "key-budget" => s.key_budget = d.key_budget,
                "key-share" => s.key_share = d.key_share,
                "key-ratio" => s.key_ratio = d.key_ratio,
                "representation" => s.representations = d.representations.clone(),
                "polygon-vertices" => s.polygon_vertices = d.polygon_vertices,
                "interior-vertices" => s.interior_vertices = d.interior_vertices,
                "no-restarts" => s.no_restarts = false,
                _ => {
                    errors.push(e);
                    return (d, errors);
                }
            }
            errors.push(e);
        }
        (s, errors)
    }

    /// The representations to bake (checked by [`BakeSettings::validate`]; all of them if
    /// the list does not parse).
    pub fn representation_set(&self) -> polypostor_runtime::reps::RepSet {
        polypostor_runtime::reps::RepSet::parse(&self.representations).unwrap_or(polypostor_runtime::reps::RepSet::ALL)
    }

    /// The pipeline's options for these settings (clips, key frame and corrections left at
    /// their defaults for the caller to fill in).
    pub fn options(&self) -> BakeOptions {
        BakeOptions {
            views: self.views,
            coverage: if self.full_sphere {
                Coverage::FullSphere
            } else {
                Coverage::UpperHemisphere
            },
            resolution: self.resolution,
            fps: self.fps,
            fit: crate::bake::part_fit::PartFitOptions {
                exhaustive: self.exhaustive,
                final_vertices: self.polygon_vertices,
                fold_free: !self.allow_folds,
                charge_missed_coverage: !self.paper_objective,
                restart_threshold: if self.no_restarts {
                    f64::INFINITY
                } else {
                    crate::bake::part_fit::DEFAULT_RESTART_THRESHOLD
                },
                subpixel: !self.no_subpixel,
                interior_vertices: self.interior_vertices,
                ..Default::default()
            },
            keys: KeyOptions {
                max_keys: self.max_keys,
                min_gain_db: self.key_gain_db,
                budget: self.key_budget,
                share: self.key_share,
                ratio: self.key_ratio,
            },
            textures: self.textures,
            png: self.png,
            ..Default::default()
        }
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn numbers_in_messages_read_short() {
        assert_eq!(super::shown(1e300), "1e300");
        assert_eq!(super::shown(-3e-9), "-3e-9");
        assert_eq!(super::shown(2.5), "2.5");
        assert_eq!(super::shown(10_000.0), "10000");
        assert_eq!(super::shown(0.0), "0");
        assert_eq!(super::shown(f64::NAN), "NaN");
        assert_eq!(super::shown(0.005f32), "0.005");
        assert_eq!(super::shown(1e30f32), "1e30");
        let e = BakeSettings {
            key_ratio: 1e300,
            ..Default::default()
        }
        .validate()
        .unwrap_err();
        assert!(e.message.starts_with("1e300: "), "{}", e.message);
    }

    /// Settings out of range (a project file edited by hand) come back at their defaults,
    /// each named; the others are kept.
    #[test]
    fn settings_out_of_range_are_repaired_to_their_defaults_and_named() {
        let d = BakeSettings::default();
        let bad = BakeSettings {
            views: 0,
            resolution: 7,
            fps: 0.0,
            polygon_vertices: 24,
            ..d.clone()
        };
        let (fixed, errors) = bad.repaired();
        fixed.validate().unwrap();
        let named: Vec<&str> = errors.iter().map(|e| e.setting).collect();
        assert_eq!(named, ["views", "resolution", "fps"]);
        assert_eq!(
            (fixed.views, fixed.resolution, fixed.fps),
            (d.views, d.resolution, d.fps)
        );
        assert_eq!(fixed.polygon_vertices, 24);
        let (same, none) = d.repaired();
        assert!(none.is_empty() && same == d);
    }

    use super::*;

    #[test]
    fn defaults_are_the_pipelines_and_survive_a_round_trip() {
        let s = BakeSettings::default();
        assert_eq!(s.validate(), Ok(()));
        assert_eq!(s.options(), BakeOptions::default());
        let json = serde_json::to_string(&s).unwrap();
        assert_eq!(serde_json::from_str::<BakeSettings>(&json).unwrap(), s);
        // A partial object keeps the defaults of what it leaves out.
        let p: BakeSettings = serde_json::from_str(r#"{"views": 24}"#).unwrap();
        assert_eq!(p, BakeSettings { views: 24, ..s });
        // Texture settings written as the command line and the README spell them.
        for (text, textures) in [
            ("bc7", TextureEncoding::Bc7),
            ("BC7", TextureEncoding::Bc7),
            ("Bc7", TextureEncoding::Bc7),
            ("png", TextureEncoding::Png),
        ] {
            let p: BakeSettings = serde_json::from_str(&format!(r#"{{"textures": "{text}", "png": "best"}}"#)).unwrap();
            assert_eq!((p.textures, p.png), (textures, PngCompression::Best), "{text}");
        }
    }

    #[test]
    fn every_setting_out_of_range_is_named() {
        let d = BakeSettings::default;
        let cases = [
            (BakeSettings { views: 0, ..d() }, "views"),
            (
                BakeSettings {
                    views: MAX_VIEWS + 1,
                    ..d()
                },
                "views",
            ),
            (BakeSettings { resolution: 2, ..d() }, "resolution"),
            (BakeSettings { fps: f32::NAN, ..d() }, "fps"),
            (BakeSettings { max_keys: 0, ..d() }, "max-keys"),
            (
                BakeSettings {
                    key_gain_db: -1.0,
                    ..d()
                },
                "key-gain-db",
            ),
            (
                BakeSettings {
                    key_budget: f64::INFINITY,
                    ..d()
                },
                "key-budget",
            ),
            (BakeSettings { key_share: 1.5, ..d() }, "key-share"),
            (BakeSettings { key_ratio: 0.5, ..d() }, "key-ratio"),
            (
                BakeSettings {
                    key_ratio: f64::NAN,
                    ..d()
                },
                "key-ratio",
            ),
            (
                BakeSettings {
                    polygon_vertices: 2,
                    ..d()
                },
                "polygon-vertices",
            ),
            (
                BakeSettings {
                    polygon_vertices: 41,
                    ..d()
                },
                "polygon-vertices",
            ),
            (
                BakeSettings {
                    representations: "sprites".into(),
                    ..d()
                },
                "representation",
            ),
        ];
        for (s, name) in cases {
            let e = s.validate().unwrap_err();
            assert_eq!(e.setting, name, "{e}");
            assert!(e.to_string().starts_with(&format!("--{name} ")), "{e}");
        }
    }
}

/// A number as a message shows it: as written where it reads well, else in scientific
/// notation (`1e300`, `1e-300`), never hundreds of digits.
pub fn shown<T: Into<f64> + std::fmt::Display + std::fmt::LowerExp + Copy>(x: T) -> String {
    // Judged as f64, written in its own type (an f32 widened prints 0.004999999888241291).
    let v: f64 = x.into();
    if v != 0.0 && v.is_finite() && !(1e-4..1e7).contains(&v.abs()) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}
