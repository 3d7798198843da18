//! The Polypostor bake, stage by stage (the pipeline of `../shared/DESIGN.md`, steps 3–9).
//!
//! Each module is one algorithm on plain data, testable without a GPU:
//! - [`viewpoints`]: directions spread uniformly over the upper hemisphere (or the sphere),
//!   with nearest-view lookup.
//! - [`contour`]: outer-contour tracing of a part mask (Moore neighbourhood, holes filled).
//! - [`simplify`]: greedy polygon simplification with the edge-length-ratio term.
//! - [`triangulate`]: constrained Delaunay triangulation of a simple polygon without interior
//!   vertices (spade), `n - 2` triangles.
//! - [`fit`]: the exact dynamic program that maps a source polygon's vertices onto a target
//!   polygon's, over the triangulation's dual tree, `O(n·m³)`.
//! - [`segment`]: per-triangle body-part labels, automatic from the skin and the hierarchy.
//! - [`caps`]: the loops each cut opens, closed by coloured caps; per-part meshes.
//! - [`visibility`]: the drawing order of parts from the occlusion graph (exact minimum
//!   feedback arc set).
//! - [`overrides`]: the artist's per-view corrections (key frame, order, pins) every bake applies.
//! - [`image_cost`]: the fit's objective (colour, normal and coverage error of a mapped triangle).
//! - [`part_fit`]: one part in one view over every frame (trace, simplify, fast or exact fit).
//! - [`keys`]: the extra key images of a view's parts (greedy choice under a byte budget).
//! - [`settings`]: the bake's settings as one struct (stored in the project, overridden by
//!   the command line's flags) and their validation.
//! - [`renders`], [`raster`]: the per-part GPU renders of every view and frame; CPU drawing.
//! - [`pipeline`]: the whole bake, one view at a time, and the one re-fit path.
//! - [`plan`]: checks and memory estimates made before any work starts.
//! - [`report`]: `report.json`; [`inspect`]: the inspector's per-view data.
//! - [`profile`]: CPU seconds per stage (the bake's profiling table).
//! - [`gap`]: the fast fitting mode against the exact DP on a few views of a bake.
//! - [`eta`]: the remaining-time estimate of a bake's progress bar.

pub mod caps;
pub mod contour;
pub mod eta;
pub mod fit;
pub mod gap;
pub mod image_cost;
pub mod inspect;
pub mod job;
pub mod keys;
pub mod overrides;
pub mod part_fit;
pub mod pipeline;
pub mod plan;
pub mod profile;
pub mod raster;
pub mod renders;
pub mod report;
pub use polypostor_runtime::segment;
pub mod settings;
pub mod simplify;
pub use polypostor_runtime::triangulate;
pub use polypostor_runtime::viewpoints;
pub mod visibility;
