//! The live pose on the drawing of an in-process run: each scan's pose as the session
//! publishes it then, carried onto the drawing through the warp the session held then.
//!
//! Sits beside the in-process mapping loop ([`crate::run_loop`]) and plays the part of
//! slam-service's warp worker (`sketchslam_slam::warp_cache`) deterministically: W is
//! fitted when the mapper asks (every
//! [`REFIT_KEYFRAMES`](sketchslam_engine::mapper::REFIT_KEYFRAMES) keyframes,
//! `Mapper::warp_request`), at that scan, on the map as it is then, and handed back to the
//! mapper (the service fits on a worker thread, so there the live pose reads W only once
//! the fit is done; the mapper's front end reads each fit from the same keyframe in both),
//! and the pose is read through it as the service reads it
//! (`Mapper::pose_on_drawing_through`). Until the first fit the published pose is MCL's,
//! as the service's.
//!
//! Asked to, it keeps each live fit's problem with the trajectory of its moment
//! ([`LiveFit`]), so that `bench-warp` can fit the partial maps again with other settings
//! and score them (`evaluate --keep-live-warps`).

use crate::metrics::StampedPose;
use crate::warp_problem_file::WarpProblemFile;
use anyhow::Result;
use sketchslam_engine::mapper::{Mapper, TrajectoryPoint, trajectory_csv};
use sketchslam_engine::registration::{DrawingRegistration, WarpProblem};
use sketchslam_engine::sketch::SketchPose;
use std::path::Path;
use std::sync::Arc;

/// The warp a live session holds, refitted by the service's rule.
pub struct LiveWarp {
    held: Option<Arc<DrawingRegistration>>,
    /// `Some` when the live fits' problems are kept.
    kept: Option<Vec<LiveFit>>,
}

/// A live fit's problem, kept with the map's trajectory at its scan.
pub struct LiveFit {
    /// Scans mapped when it was fitted.
    pub scans: usize,
    /// What was fitted.
    pub problem: WarpProblem,
    /// The mapper's trajectory then (map frame, one pose per scan).
    pub trajectory: Vec<TrajectoryPoint>,
}

impl LiveWarp {
    /// No warp yet; with `keep_fits`, every fit's problem is kept ([`LiveWarp::kept`]).
    pub fn new(keep_fits: bool) -> Self {
        Self {
            held: None,
            kept: keep_fits.then(Vec::new),
        }
    }

    /// After the `scans`-th scan: fits W when the mapper asks ([`Mapper::warp_request`]) and
    /// answers it (as the service's worker does, [`Mapper::deliver_warp`]), then the scan's
    /// pose on the drawing as published, through the newest W, or MCL's pose before the
    /// first fit (`None` without either).
    pub fn after_scan(&mut self, mapper: &mut Mapper, scans: usize) -> Option<SketchPose> {
        if let Some(problem) = mapper.warp_request() {
            let fitted = problem.solve().map(Arc::new);
            mapper.deliver_warp(fitted.clone());
            if let Some(fitted) = fitted {
                self.held = Some(fitted);
                if let Some(kept) = self.kept.as_mut() {
                    kept.push(LiveFit {
                        scans,
                        problem,
                        trajectory: mapper.trajectory().into_owned(),
                    });
                }
            }
        }
        match &self.held {
            Some(r) => Some(mapper.pose_on_drawing_through(r).0),
            None => mapper.pose().sketch,
        }
    }

    /// The live fits kept, in order (empty unless made to keep them).
    pub fn kept(self) -> Vec<LiveFit> {
        self.kept.unwrap_or_default()
    }
}

/// Where [`write_live_fits`] puts the live fits in a run's folder.
pub const LIVE_WARPS_DIR: &str = "live-warps";

/// Writes each live fit as `LIVE_WARPS_DIR/scan-NNNNNN/` in `out_dir`: its
/// `warp-problem.json` (mapped in `scenario_dir` with the drawing `sketch`), the
/// `trajectory.csv` of its moment and the `truth.csv` of the scans mapped then, which is
/// what `bench-warp` reads.
pub fn write_live_fits(
    out_dir: &Path,
    fits: &[LiveFit],
    truth: &[StampedPose],
    scenario_dir: &Path,
    sketch: &str,
) -> Result<()> {
    for fit in fits {
        let dir = out_dir
            .join(LIVE_WARPS_DIR)
            .join(format!("scan-{:06}", fit.scans));
        std::fs::create_dir_all(&dir)?;
        WarpProblemFile::new(&fit.problem, scenario_dir, sketch).write(&dir)?;
        std::fs::write(dir.join("trajectory.csv"), trajectory_csv(&fit.trajectory))?;
        sketchslam_simulator::truth::write_truth_csv(
            &dir.join("truth.csv"),
            &truth[..fit.scans.min(truth.len())],
        )?;
    }
    Ok(())
}
