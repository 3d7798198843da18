//! # Polypostor run time
//!
//! What a game engine needs to draw the crowds Polypostor Studio bakes, and nothing of the
//! studio: no user interface, no command line, no baking. It loads and validates a baked
//! folder (the Polypostor pack and the representations beside it), keeps the crowd's agents
//! on the CPU (walking, running and standing, culled, with a level of detail and a view per
//! character), and draws them with wgpu: skinned meshes near, Polypostors in the middle,
//! impostors far (or any one representation alone).
//!
//! The shortest way in is [`scene`]: [`scene::CrowdAssets::load`] reads a baked
//! folder and the glTF it was baked from, [`scene::CrowdScene`] holds the GPU side,
//! and [`scene::CrowdScene::frame`] steps the agents and draws them into a colour and
//! depth target you own. `examples/headless_crowd.rs` does it in about a hundred lines.
//!
//! Modules:
//! - [`pack`]: the Polypostor pack format (`docs/PACK_FORMAT.md`) and its validating loader.
//! - [`reps`]: the other representations baked beside it (impostors, NP3D, rigid meshes).
//! - [`crowd`]: the agents, their gaits and clips, culling, level of detail and view choice,
//!   per-instance records (CPU only).
//! - [`records`]: the plain data between the crowd and the renderers (the 32-byte
//!   instance record, levels, clip timing).
//! - [`scene`]: a crowd with its renderers: load a baked folder, step and draw a frame.
//! - [`gpu`]: the wgpu renderers (skinned characters, Polypostors, impostors, NP3D, rigid
//!   meshes), cameras, adapter selection and readback.
//! - [`character`], [`import`], [`animation`], [`timeline`]: the character a pack was baked
//!   from (glTF 2.0 import, pose sampling and CPU skinning) and the frames of a bake.
//! - [`summary`]: what a character holds, in numbers and warnings (the `inspect` command's report).
//! - [`segment`]: body-part labels of the triangles (to tint meshes as the parts are tinted).
//! - [`viewpoints`], [`triangulate`]: view directions and nearest-view lookup; the
//!   triangulation of a part's polygon the Polypostor renderer draws.
//! - [`texture`]: BC7 images in KTX2 files (what packs store their textures as) and their decoding.
//! - [`limits`], [`safe_fs`]: every documented limit, and bounded reads of regular files.
//! - [`default_character`], [`gltf_write`]: the built-in humanoid (a character to try the
//!   run time with) and the small glTF writer it is saved with.

#![deny(missing_docs)]

pub mod animation;
pub mod character;
pub mod crowd;
pub mod default_character;
pub mod gltf_write;
pub mod gpu;
pub mod import;
pub mod limits;
pub mod pack;
pub mod quant;
pub mod records;
pub mod reps;
pub mod safe_fs;
pub mod scene;
pub mod segment;
pub mod summary;
pub mod texture;
pub mod timeline;
pub mod triangulate;
pub mod viewpoints;

pub use character::Character;
pub use import::{ImportError, ImportOptions, UpAxis, import_path, import_path_with};
