//! The WGSL sources of `shaders/`, embedded at compile time.

pub const CHARACTER: &str = include_str!("../../../../shaders/character.wgsl");
pub const GRID: &str = include_str!("../../../../shaders/grid.wgsl");
pub const BLIT: &str = include_str!("../../../../shaders/blit.wgsl");
pub const DEPTH_BYTES: &str = include_str!("../../../../shaders/depth_bytes.wgsl");
/// Structs and functions every crowd shader shares (WGSL has no includes: it is prepended).
pub const CROWD_COMMON: &str = include_str!("../../../../shaders/crowd_common.wgsl");
pub const POLYPOSTOR: &str = concat!(
    include_str!("../../../../shaders/crowd_common.wgsl"),
    include_str!("../../../../shaders/polypostor.wgsl")
);
pub const CROWD_MESH: &str = concat!(
    include_str!("../../../../shaders/crowd_common.wgsl"),
    include_str!("../../../../shaders/crowd_mesh.wgsl")
);
pub const IMPOSTOR: &str = concat!(
    include_str!("../../../../shaders/crowd_common.wgsl"),
    include_str!("../../../../shaders/impostor.wgsl")
);
pub const CROWD_GROUND: &str = concat!(
    include_str!("../../../../shaders/crowd_common.wgsl"),
    include_str!("../../../../shaders/crowd_ground.wgsl")
);
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
