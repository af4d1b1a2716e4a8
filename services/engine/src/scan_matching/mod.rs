//! Scan matching: a scan's pose against reference points.
//!
//! Used by the front end (point-to-line ICP, eq. 6, after the heading of eq. 5) and by the
//! back end (correlative search of loop-closure candidates, refined by ICP):
//! - [`icp`]: point-to-line ICP on a k-d tree, full or translation-only;
//! - [`motion_prior`]: the odometry's prediction fused with an ICP match, so the directions
//!   a scan does not measure (a corridor's axis) follow the odometry;
//! - [`odometry_noise`]: how far the odometry's guess can be off, so whether ICP can start
//!   from it;
//! - [`correlative`]: Olson's correlative scan matching with branch and bound;
//! - [`heading_plateau`]: how well a correlative match pins its heading (the angular
//!   twin of its translation plateau);
//! - [`observed_region`]: where a reference looked, and a correlative match re-placed by
//!   its score over that region only (no pull toward more overlap).

pub mod correlative;
pub mod heading_plateau;
pub mod icp;
pub mod motion_prior;
pub mod observed_region;
pub mod odometry_noise;
