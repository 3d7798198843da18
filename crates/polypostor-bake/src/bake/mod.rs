//! The Polypostor bake, stage by stage (the pipeline of `../shared/DESIGN.md`, steps 3–9).
//!
//! Start at `crate::job`: the one entry every bake goes through (the command line, the
//! editor's Ctrl+B and its export dialog), which resolves the inputs, checks the plan, runs
//! [`pipeline`] and writes the folder. The stages, in the order a bake runs them, each a
//! folder of modules on plain data, testable without a GPU (every module is also reachable
//! as `bake::<module>`):
//!
//! 1. [`setup`] — what is asked for, checked before any work:
//!    [`settings`] (the one settings struct: stored in the project, overridden by the
//!    command line's flags, validated), [`plan`] (limits and the memory estimate),
//!    [`overrides`] (the artist's per-view corrections: key frame, order, pins),
//!    [`caps`] (the loops each cut opens, closed by coloured caps; per-part meshes), and
//!    [`segment`] (per-triangle body-part labels, automatic from the skin; run time crate).
//! 2. [`render`] — pictures: [`renders`] (the per-part GPU renders of every view and
//!    frame; view directions from [`viewpoints`]) and [`raster`] (CPU drawing, error measures).
//! 3. [`shape`] — mask to polygon: [`contour`] (outer-contour tracing, Moore
//!    neighbourhood, holes filled), [`simplify`] (greedy simplification with the
//!    edge-length-ratio term), [`triangulate`] (constrained Delaunay, `n - 2` triangles;
//!    run time crate).
//! 4. [`fitting`] — the key polygon onto every frame: [`fit`] (the exact dynamic program
//!    over the triangulation's dual tree, `O(n·m³)`), [`image_cost`] (its objective: colour,
//!    normal and coverage error of a mapped triangle), [`part_fit`] (one part in one view
//!    over every frame: trace, simplify, fast or exact fit, restarts), [`gap`] (the fast
//!    mode against the exact DP).
//! 5. [`per_view`] — decisions per view: [`keys`] (extra key images, greedy under a byte
//!    budget) and [`visibility`] (the parts' drawing order, exact minimum feedback arc set).
//! 6. [`output`] — what a bake tells: [`report`] (`report.json`), [`inspect`] (the
//!    inspector's per-view data), [`profile`] (CPU seconds per stage), [`eta`] (the
//!    progress bar's remaining time).
//!
//! [`pipeline`] runs stages 2–5 one view at a time (and the one re-fit path); the pack's
//! atlas, BC7 encoding and writing live in `crate::pack`, the other representations' bake
//! in `crate::reps::bake`.

pub mod fitting;
pub mod output;
pub mod per_view;
pub mod pipeline;
pub mod render;
pub mod setup;
pub mod shape;

pub use fitting::{fit, gap, image_cost, interior, part_fit, subpixel};
pub use output::{eta, inspect, profile, report};
pub use per_view::{keys, visibility};
pub use polypostor_runtime::{segment, triangulate, viewpoints};
pub use render::{raster, renders};
pub use setup::{caps, overrides, plan, settings};
pub use shape::{contour, simplify};
