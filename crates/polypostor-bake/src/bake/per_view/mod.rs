//! What each view decides once its parts are fitted: the extra key images (greedy under a
//! byte budget) and the parts' drawing order (exact minimum feedback arc set).

pub mod keys;
pub mod visibility;
