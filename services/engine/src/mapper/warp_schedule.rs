//! When a `sketch` session's map is fitted to its drawing, and from which scan a fit is
//! read by the front end.
//!
//! Beside the mapper's per-scan flow: fitting the warp W from the map onto the drawing
//! ([`crate::registration`]) takes seconds on a grown map, so it runs off the scan path — on
//! the service's warp worker, or inline in an in-process run. The mapper only asks
//! ([`WarpSchedule::request`]) and is answered ([`WarpSchedule::deliver`]). For two runs of
//! the same stream to build the same map whoever fits and however long it takes, the rule
//! is in keyframe counts, never in wall time:
//!
//! - a fit is asked for once the map has [`REFIT_KEYFRAMES`] keyframes more than at the
//!   last request (the first at the first keyframe; after a failed fit, at the next
//!   keyframe);
//! - the fit of the map at `k` keyframes takes effect at the first scan where the map has
//!   `k + REFIT_KEYFRAMES` keyframes — when the next fit is asked for. A fit therefore has
//!   10 keyframes of route (5 m at the default spacing, seconds of driving) to complete;
//!   one that has not by then is waited for ([`WarpSchedule::overdue`]), which in a
//!   lock-step replay costs time and in real time happens only when a fit takes longer
//!   than the robot takes to drive 5 m.

use crate::registration::DrawingRegistration;
use std::sync::Arc;

/// A new fit is asked for once the map has this many keyframes more than at the last
/// request (5 m of route at the default keyframe spacing); each fit takes effect this many
/// keyframes after its map.
pub const REFIT_KEYFRAMES: usize = 10;

/// The requests and answers of a session's warp fits.
#[derive(Debug, Clone, Default)]
pub(super) struct WarpSchedule {
    /// Keyframes of the map at which the next request is due.
    next_request_at: usize,
    /// Keyframes of the map of the request not yet answered.
    awaiting: Option<usize>,
    /// The last fit delivered, until it takes effect.
    arrived: Option<Arc<DrawingRegistration>>,
    /// The fit the front end reads.
    in_effect: Option<Arc<DrawingRegistration>>,
}

impl WarpSchedule {
    /// True when a fit of the map at `keyframes` keyframes is to be asked for now.
    pub(super) fn due(&self, keyframes: usize) -> bool {
        keyframes > 0 && self.awaiting.is_none() && keyframes >= self.next_request_at
    }

    /// Records that the map at `keyframes` keyframes was handed out to be fitted. The fit
    /// delivered before, due by now, takes effect first, so the answer cannot replace it
    /// before its time.
    pub(super) fn request(&mut self, keyframes: usize) {
        self.before_scan(keyframes);
        self.awaiting = Some(keyframes);
        self.next_request_at = keyframes + REFIT_KEYFRAMES;
    }

    /// The answer to the last request: the fit, or `None` when W could not be fitted (the
    /// next request is then due at the next keyframe). An answer with no request pending
    /// is ignored.
    pub(super) fn deliver(&mut self, fit: Option<Arc<DrawingRegistration>>) {
        let Some(asked_at) = self.awaiting.take() else {
            return;
        };
        match fit {
            Some(fit) => self.arrived = Some(fit),
            None => self.next_request_at = asked_at + 1,
        }
    }

    /// True when the scan about to be mapped, on a map of `keyframes` keyframes, would
    /// take a fit into effect that has not been delivered: the caller delivers it first to
    /// stay deterministic.
    pub(super) fn overdue(&self, keyframes: usize) -> bool {
        self.awaiting
            .is_some_and(|asked_at| keyframes >= asked_at + REFIT_KEYFRAMES)
    }

    /// Before a scan on a map of `keyframes` keyframes: takes the delivered fit into effect
    /// when its time has come.
    pub(super) fn before_scan(&mut self, keyframes: usize) {
        if self
            .arrived
            .as_ref()
            .is_some_and(|fit| keyframes >= fit.keyframes + REFIT_KEYFRAMES)
        {
            self.in_effect = self.arrived.take();
        }
    }

    /// The fit the front end reads.
    pub(super) fn in_effect(&self) -> Option<&DrawingRegistration> {
        self.in_effect.as_deref()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::registration::{ControlGrid, Similarity, Warp, WarpFit};
    use sketchslam_types::Point2;

    fn fit_at(keyframes: usize) -> Arc<DrawingRegistration> {
        let similarity = Similarity::new(20.0, 0.0, Point2::new(0.0, 0.0));
        let grid = ControlGrid::covering(Point2::new(0.0, 0.0), Point2::new(4.0, 4.0), 2.0);
        Arc::new(DrawingRegistration {
            fit: WarpFit {
                warp: Warp::rigid(similarity, grid),
                inliers: 0,
                rms_px: 0.0,
                support: Vec::new(),
                walls_crossed: 0,
            },
            keyframes,
            map_revision: 0,
            anchors: Vec::new(),
        })
    }

    #[test]
    fn a_fit_takes_effect_ten_keyframes_after_its_map_however_early_it_arrives() {
        let mut s = WarpSchedule::default();
        assert!(!s.due(0), "nothing to fit before the first keyframe");
        assert!(s.due(1));
        s.request(1);
        assert!(!s.due(5), "one request at a time");
        assert!(!s.overdue(10));
        s.deliver(Some(fit_at(1)));
        for k in 1..11 {
            s.before_scan(k);
            assert!(s.in_effect().is_none(), "in effect early at {k}");
            assert!(!s.due(k));
        }
        // Asked again at keyframe 11 (after that scan) and answered at once: the fit of
        // keyframe 1 holds until keyframe 21 all the same.
        assert!(s.due(11));
        s.request(11);
        s.deliver(Some(fit_at(11)));
        s.before_scan(11);
        assert_eq!(s.in_effect().map(|f| f.keyframes), Some(1));
        s.before_scan(20);
        assert_eq!(s.in_effect().map(|f| f.keyframes), Some(1));
        s.before_scan(21);
        assert_eq!(s.in_effect().map(|f| f.keyframes), Some(11));
        s.request(21);
        // Not delivered by keyframe 31: the caller must wait.
        assert!(!s.overdue(30));
        assert!(s.overdue(31));
        s.before_scan(31);
        assert_eq!(s.in_effect().map(|f| f.keyframes), Some(11));
        s.deliver(Some(fit_at(21)));
        assert!(!s.overdue(31));
        s.before_scan(31);
        assert_eq!(s.in_effect().map(|f| f.keyframes), Some(21));
    }

    #[test]
    fn a_failed_fit_is_asked_again_at_the_next_keyframe_and_stray_answers_are_ignored() {
        let mut s = WarpSchedule::default();
        s.deliver(Some(fit_at(3)));
        s.before_scan(100);
        assert!(s.in_effect().is_none(), "an answer nobody asked for");
        s.request(4);
        s.deliver(None);
        assert!(!s.due(4));
        assert!(s.due(5));
        assert!(!s.overdue(50));
    }
}
