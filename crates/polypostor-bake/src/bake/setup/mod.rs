//! What a bake is asked for and checked against before any work: its settings (stored in
//! the project, overridden by the command line), the plan and memory estimate, the artist's
//! per-view corrections, the caps that close the cuts between parts.

pub mod caps;
pub mod overrides;
pub mod plan;
pub mod settings;
