//! Document editing without a user interface: the segmentation tools (brush, fills, mirror,
//! part palette), picking triangles under the cursor, and the undo history. The editor's UI
//! calls these; tests drive them directly.

pub mod history;
pub mod paint;
