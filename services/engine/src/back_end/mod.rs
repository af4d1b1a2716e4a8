//! The back end: keyframes, loop closures and the pose graph that straightens the map.
//!
//! Behind the front end of a `sketch` session: the mapper hands it a keyframe every half
//! meter or so, and gets back either nothing or a correction of every keyframe:
//! - [`loop_closure`]: keyframes, candidate search, verification, and when to optimize;
//! - [`closure_consistency`]: the χ² tests a matched loop passes before it enters the graph
//!   (against the odometry chain, and pairwise against other loops);
//! - [`pose_graph`]: SE(2) Gauss–Newton with robust (Huber) edges;
//! - [`heading_prior`]: the drawing's wall directions as an optional heading prior on
//!   keyframes.

pub mod closure_consistency;
pub mod heading_prior;
pub mod loop_closure;
pub mod pose_graph;
