//! The live pose on the drawing of an in-process run: each scan's pose as the session
//! publishes it then, carried onto the drawing through the warp the session held then.
//!
//! Sits beside the in-process mapping loop ([`crate::run_loop`]) and plays the part of
//! slam-service's warp worker (`sketchslam_slam::warp_cache`) deterministically: W is
//! refitted once the map has [`REFIT_KEYFRAMES`] keyframes more than at the last fit, at
//! that scan, on the map as it is then (the service fits on a worker thread, so there W is
//! also as old as a fit takes), and the pose is read through it as the service reads it
//! (`Mapper::pose_on_drawing_through`). Until the first fit the published pose is MCL's,
//! as the service's.

use sketchslam_engine::mapper::Mapper;
use sketchslam_engine::registration::DrawingRegistration;
use sketchslam_engine::sketch::SketchPose;
use sketchslam_slam::warp_cache::REFIT_KEYFRAMES;

/// The warp a live session holds, refitted by the service's rule.
#[derive(Default)]
pub struct LiveWarp {
    held: Option<DrawingRegistration>,
}

impl LiveWarp {
    /// After a scan: refits W when due, then the scan's pose on the drawing as published,
    /// through W, or MCL's pose before the first fit (`None` without either).
    pub fn after_scan(&mut self, mapper: &Mapper) -> Option<SketchPose> {
        let due = self
            .held
            .as_ref()
            .is_none_or(|r| mapper.keyframe_count() >= r.keyframes + REFIT_KEYFRAMES);
        if due && let Some(fitted) = mapper.warp_problem().and_then(|p| p.solve()) {
            self.held = Some(fitted);
        }
        match &self.held {
            Some(r) => Some(mapper.pose_on_drawing_through(r).0),
            None => mapper.pose().sketch,
        }
    }
}
