//! The built-in default character: a textured humanoid generated entirely by this code.
//!
//! [`generate`] builds the mesh (about 5k triangles of generalised cylinders and ellipsoids),
//! a 21-joint skeleton with conventional names, four looping clips (Walk, Run, Idle, Wave)
//! and a 512×512 texture with clothing, a face and patterns, then [`generate_glb`] writes it
//! as `.glb`. Everything is deterministic: the same code always writes the same bytes, which
//! a test checks against the stored [`DEFAULT_CHARACTER_PATH`].

mod anim;
mod mesh;
mod texture;

use glam::{Mat4, Vec3};

use crate::character::{Bone, Character, Material, Node, Skeleton, Submesh, Transform};

/// Where the generated character is stored, relative to the repository root.
pub const DEFAULT_CHARACTER_PATH: &str = "assets/characters/default_humanoid.glb";

/// Display name of the generated character.
pub const NAME: &str = "Default Humanoid";

/// Joint names, parents and bind-pose head positions (metres, Y up, facing +Z; the
/// character's left is +X).
pub(crate) const JOINTS: &[(&str, Option<usize>, [f32; 3])] = &[
    ("Hips", None, [0.0, 0.95, 0.0]),                 // 0
    ("Spine", Some(0), [0.0, 1.06, 0.0]),             // 1
    ("Chest", Some(1), [0.0, 1.22, 0.0]),             // 2
    ("Neck", Some(2), [0.0, 1.46, 0.0]),              // 3
    ("Head", Some(3), [0.0, 1.57, 0.0]),              // 4
    ("LeftShoulder", Some(2), [0.05, 1.40, 0.0]),     // 5
    ("LeftUpperArm", Some(5), [0.19, 1.40, 0.0]),     // 6
    ("LeftLowerArm", Some(6), [0.245, 1.13, 0.0]),    // 7
    ("LeftHand", Some(7), [0.29, 0.89, 0.0]),         // 8
    ("RightShoulder", Some(2), [-0.05, 1.40, 0.0]),   // 9
    ("RightUpperArm", Some(9), [-0.19, 1.40, 0.0]),   // 10
    ("RightLowerArm", Some(10), [-0.245, 1.13, 0.0]), // 11
    ("RightHand", Some(11), [-0.29, 0.89, 0.0]),      // 12
    ("LeftUpperLeg", Some(0), [0.095, 0.92, 0.0]),    // 13
    ("LeftLowerLeg", Some(13), [0.10, 0.50, 0.0]),    // 14
    ("LeftFoot", Some(14), [0.10, 0.09, -0.01]),      // 15
    ("LeftToes", Some(15), [0.10, 0.03, 0.115]),      // 16
    ("RightUpperLeg", Some(0), [-0.095, 0.92, 0.0]),  // 17
    ("RightLowerLeg", Some(17), [-0.10, 0.50, 0.0]),  // 18
    ("RightFoot", Some(18), [-0.10, 0.09, -0.01]),    // 19
    ("RightToes", Some(19), [-0.10, 0.03, 0.115]),    // 20
];

pub(crate) fn joint(name: &str) -> u16 {
    JOINTS
        .iter()
        .position(|j| j.0 == name)
        .unwrap_or_else(|| panic!("unknown joint {name}")) as u16
}

pub(crate) fn joint_head(index: u16) -> Vec3 {
    Vec3::from_array(JOINTS[index as usize].2)
}

/// Builds the default character.
pub fn generate() -> Character {
    let nodes: Vec<Node> = JOINTS
        .iter()
        .map(|&(name, parent, head)| {
            let head = Vec3::from_array(head);
            let parent_head = parent.map_or(Vec3::ZERO, |p| Vec3::from_array(JOINTS[p].2));
            Node {
                name: name.to_string(),
                parent,
                rest: Transform {
                    translation: head - parent_head,
                    ..Transform::IDENTITY
                },
                is_joint: true,
            }
        })
        .collect();
    let bones: Vec<Bone> = JOINTS
        .iter()
        .enumerate()
        .map(|(i, &(_, _, head))| Bone {
            node: i,
            inverse_bind: Mat4::from_translation(-Vec3::from_array(head)),
        })
        .collect();
    let (vertices, indices) = mesh::build();
    let texture = texture::paint();
    Character {
        name: NAME.to_string(),
        submeshes: vec![Submesh {
            first_index: 0,
            index_count: indices.len() as u32,
            material: 0,
        }],
        vertices,
        indices,
        materials: vec![Material {
            name: "Clothes".into(),
            base_color_factor: [1.0; 4],
            base_color_texture: Some(0),
            double_sided: false,
            alpha_cutoff: 0.0,
            wrap: Default::default(),
        }],
        textures: vec![texture],
        skeleton: Skeleton { nodes },
        bones,
        clips: anim::clips(),
        warnings: Vec::new(),
        up_axis: Default::default(),
        morphs: Vec::new(),
    }
}

/// The default character as `.glb` bytes (deterministic).
pub fn generate_glb() -> Vec<u8> {
    crate::gltf_write::write_glb(&generate()).expect("the generated character is always writable")
}

/// The stored default character's path under a repository root.
pub fn default_path(repo_root: &std::path::Path) -> std::path::PathBuf {
    repo_root.join(DEFAULT_CHARACTER_PATH)
}
