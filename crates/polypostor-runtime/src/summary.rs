//! The character summary shown by `polypostor inspect` and the editor's side panel.

use serde::Serialize;

use crate::character::Character;

/// One clip as the summary lists it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ClipSummary {
    /// The clip's name.
    pub name: String,
    /// Length in seconds (time of its last key).
    pub duration_secs: f32,
    /// Number of animated node properties the import kept.
    pub channels: usize,
    /// Number of morph weight channels the import kept (each moves one mesh's targets).
    pub morph_channels: usize,
}

/// One texture as the summary lists it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TextureSummary {
    /// The texture's name (image name, else its URI, else `image {i}`).
    pub name: String,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

/// Counts and names that describe a character at a glance.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Summary {
    /// The character's name ([`Character::name`]).
    pub name: String,
    /// Vertices of the merged mesh.
    pub vertices: usize,
    /// Triangles of the merged mesh.
    pub triangles: usize,
    /// Number of skin joints.
    pub joints: usize,
    /// Names of the skin joints, in skeleton order.
    pub joint_names: Vec<String>,
    /// Skeleton nodes including helper nodes (parents of the skeleton, prop carriers).
    pub nodes: usize,
    /// Number of materials.
    pub materials: usize,
    /// Every clip, in the character's order.
    pub clips: Vec<ClipSummary>,
    /// Every texture, in the character's order.
    pub textures: Vec<TextureSummary>,
    /// Rest-pose bounds in scene units: `[min, max]`.
    pub bounds_min: [f32; 3],
    /// Upper corner of the rest-pose bounds (see `bounds_min`).
    pub bounds_max: [f32; 3],
    /// Problems the import worked around ([`Character::warnings`]).
    pub warnings: Vec<String>,
    /// Which of the file's axes was read as up ([`Character::up_axis`]; `+y` is glTF's).
    pub up_axis: crate::character::UpAxis,
}

impl Summary {
    /// The summary of `c` (skins its rest pose once, for the bounds).
    pub fn of(c: &Character) -> Self {
        // Bounds of the rest pose as it stands in the scene (bind-space coordinates can be
        // in any unit, scaled by the skeleton).
        let pose = crate::animation::Pose::rest(c);
        let (min, max) = crate::character::bounds(crate::animation::skin_vertices(c, &pose).0);
        Self {
            name: c.name.clone(),
            vertices: c.vertices.len(),
            triangles: c.triangle_count(),
            joints: c.skeleton.joint_count(),
            joint_names: c
                .skeleton
                .nodes
                .iter()
                .filter(|n| n.is_joint)
                .map(|n| n.name.clone())
                .collect(),
            nodes: c.skeleton.nodes.len(),
            materials: c.materials.len(),
            clips: c
                .clips
                .iter()
                .map(|k| ClipSummary {
                    name: k.name.clone(),
                    duration_secs: k.duration_secs,
                    channels: k.channels.len(),
                    morph_channels: k.morph_channels.len(),
                })
                .collect(),
            textures: c
                .textures
                .iter()
                .map(|t| TextureSummary {
                    name: t.name.clone(),
                    width: t.width,
                    height: t.height,
                })
                .collect(),
            bounds_min: min.to_array(),
            bounds_max: max.to_array(),
            warnings: c.warnings.clone(),
            up_axis: c.up_axis,
        }
    }

    /// Human-readable multi-line text (what `inspect` prints without `--json`).
    pub fn to_text(&self) -> String {
        use std::fmt::Write;
        let mut s = String::new();
        let _ = writeln!(s, "character   {}", self.name);
        let _ = writeln!(s, "vertices    {}", self.vertices);
        let _ = writeln!(s, "triangles   {}", self.triangles);
        let _ = writeln!(s, "joints      {} ({} skeleton nodes)", self.joints, self.nodes);
        let _ = writeln!(s, "materials   {}", self.materials);
        if !self.up_axis.is_default() {
            let _ = writeln!(s, "up axis     {} (stood up)", self.up_axis);
        }
        let _ = writeln!(
            s,
            "bounds      [{:.3}, {:.3}, {:.3}] .. [{:.3}, {:.3}, {:.3}]",
            self.bounds_min[0],
            self.bounds_min[1],
            self.bounds_min[2],
            self.bounds_max[0],
            self.bounds_max[1],
            self.bounds_max[2]
        );
        let _ = writeln!(s, "clips       {}", self.clips.len());
        for c in &self.clips {
            let morphs = match c.morph_channels {
                0 => String::new(),
                1 => ", 1 morph weights channel".to_string(),
                n => format!(", {n} morph weights channels"),
            };
            let _ = writeln!(
                s,
                "  {:<24} {:>8.3} s  {} channels{morphs}",
                c.name, c.duration_secs, c.channels
            );
        }
        let _ = writeln!(s, "textures    {}", self.textures.len());
        for t in &self.textures {
            let _ = writeln!(s, "  {:<24} {}x{}", t.name, t.width, t.height);
        }
        let _ = writeln!(s, "warnings    {}", self.warnings.len());
        for w in &self.warnings {
            let _ = writeln!(s, "  - {w}");
        }
        s
    }
}
