//! The map laid over the drawing: a smooth warp from map meters to drawing pixels, fitted
//! to the walls the LiDAR mapped, so that the robot's pose, the map and the drawing's
//! rooms can be read on the drawing and in the map alike.
//!
//! Sits after the back end: the drawing's proportions are wrong, its topology and wall
//! directions right, so a similarity (the start mark and scale guess) does not carry the map
//! onto it beyond the first room; a similarity plus offsets on a control grid a few meters
//! apart, regularized towards the similarity, does.
//! - [`warp`]: W itself (similarity + bilinear control-grid offsets), its Jacobian;
//! - [`fit`]: W estimated from the map's wall points against the drawing's lines;
//! - `search`: the fit's global start, the similarity scored best over the prior's range;
//! - [`overlay`]: the map drawn over the drawing through W, the drawing over the map
//!   through W⁻¹;
//! - [`drawing_registration`]: a session's fitted W, where it holds, and the transforms
//!   users read through it.

pub mod drawing_registration;
pub mod fit;
pub mod overlay;
mod region_search;
mod route;
mod search;
mod segment_grid;
pub mod warp;

pub use drawing_registration::{DrawingRegistration, WarpProblem};
pub use fit::{FitConfig, WarpFit, fit_warp, fit_warp_from};
pub use overlay::{render_drawing_on_map, render_map_on_drawing};
pub use warp::{ControlGrid, Similarity, Warp};
