//! GPU rendering: the runtime crate's renderers ([`polypostor_runtime::gpu`], re-exported
//! here) and the bake's per-part renders ([`PartRenderer`]).

pub use polypostor_runtime::gpu::*;

mod part_renderer;

pub use part_renderer::{PartImages, PartRenderer};
