//! Walls as lines: the scan's straight walls and the drawing's, and the heading they give.
//!
//! Third stage of a `sketch` session's scan, after localization on the drawing picked the
//! sketch lines in view ([`crate::localization::line_observation`]):
//! - [`ransac`]: straight walls of a scan (RANSAC);
//! - [`matching`]: scan lines ↔ sketch lines and the heading correction of eq. (5);
//! - [`wall_directions`]: the drawing's dominant wall directions, a heading reference for
//!   keyframes that needs no localization on the drawing.

pub mod matching;
pub mod ransac;
pub mod wall_directions;
