//! Pictures: the per-part GPU renders of every view and frame, and CPU drawing of
//! triangles (masks, error measures).

pub mod raster;
pub mod renders;
