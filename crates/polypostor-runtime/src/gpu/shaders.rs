//! The WGSL sources of `shaders/`, embedded at compile time.

/// `character.wgsl`: a skinned character (GPU linear blend skinning) drawn into the colour and
/// view-space normal targets.
pub const CHARACTER: &str = include_str!("../../../../shaders/character.wgsl");
/// `grid.wgsl`: the ground grid on the y = 0 plane (lines every metre and every 10 cm), one
/// quad drawn with the character's `FrameUniforms`.
pub const GRID: &str = include_str!("../../../../shaders/grid.wgsl");
/// `blit.wgsl`: copies an offscreen image into a rectangle of the egui frame with one
/// full-viewport triangle (`fs_main` copies as is, `fs_encode` re-encodes to sRGB).
pub const BLIT: &str = include_str!("../../../../shaders/blit.wgsl");
/// `depth_bytes.wgsl`: writes each depth texel's f32 bits into an RGBA8 texel (low byte in
/// red), for depth readback where a depth texture cannot be copied to a buffer (OpenGL).
pub const DEPTH_BYTES: &str = include_str!("../../../../shaders/depth_bytes.wgsl");
/// Structs and functions every crowd shader shares (WGSL has no includes: it is prepended).
pub const CROWD_COMMON: &str = include_str!("../../../../shaders/crowd_common.wgsl");
/// `polypostor.wgsl` after [`CROWD_COMMON`]: the Polypostor crowd, one indexed instanced draw
/// per view in use, vertices pulled from the pack's 16-bit data.
pub const POLYPOSTOR: &str = concat!(
    include_str!("../../../../shaders/crowd_common.wgsl"),
    include_str!("../../../../shaders/polypostor.wgsl")
);
/// `crowd_mesh.wgsl` after [`CROWD_COMMON`]: skinned (`vs_skinned`, sampled joints) and rigid
/// (`vs_rigid`, pre-skinned frames) crowd meshes, one instanced draw per material.
pub const CROWD_MESH: &str = concat!(
    include_str!("../../../../shaders/crowd_common.wgsl"),
    include_str!("../../../../shaders/crowd_mesh.wgsl")
);
/// `impostor.wgsl` after [`CROWD_COMMON`]: classic impostors, one quad per character textured
/// with the nearest view's image of the nearest frame from its sheet.
pub const IMPOSTOR: &str = concat!(
    include_str!("../../../../shaders/crowd_common.wgsl"),
    include_str!("../../../../shaders/impostor.wgsl")
);
/// `crowd_ground.wgsl` after [`CROWD_COMMON`]: the opaque ground quad under a crowd, with grid
/// lines that fade with distance.
pub const CROWD_GROUND: &str = concat!(
    include_str!("../../../../shaders/crowd_common.wgsl"),
    include_str!("../../../../shaders/crowd_ground.wgsl")
);
/// `np3d.wgsl` after [`CROWD_COMMON`]: NP3D impostors, the simplified mesh of each frame
/// textured by projecting the nearest view's key-frame image onto it.
pub const NP3D: &str = concat!(
    include_str!("../../../../shaders/crowd_common.wgsl"),
    include_str!("../../../../shaders/np3d.wgsl")
);

/// Every shader with its file name (a test validates each one with naga).
pub const ALL: &[(&str, &str)] = &[
    ("character.wgsl", CHARACTER),
    ("grid.wgsl", GRID),
    ("blit.wgsl", BLIT),
    ("depth_bytes.wgsl", DEPTH_BYTES),
    ("crowd_common.wgsl", CROWD_COMMON),
    ("polypostor.wgsl", POLYPOSTOR),
    ("crowd_mesh.wgsl", CROWD_MESH),
    ("impostor.wgsl", IMPOSTOR),
    ("np3d.wgsl", NP3D),
    ("crowd_ground.wgsl", CROWD_GROUND),
];
