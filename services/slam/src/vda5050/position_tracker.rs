//! What the session's events say about the robot, for its `visualization`: the latest pose,
//! the velocity between the last two, and the path driven since the last loop closure (for
//! `deviationRange`). Pure: fed the events in order by [`super::bridge`].

use sketchslam_api::{PoseResponse, SessionEvent};

use super::messages::{
    AgvPosition, DrawingFrame, Velocity, agv_position, deviation_range_m, velocity_between,
};

/// Follows one session's events.
#[derive(Debug, Default)]
pub struct PositionTracker {
    latest: Option<PoseResponse>,
    fresh: bool,
    previous: Option<(f64, (f64, f64, f64))>,
    velocity: Velocity,
    path_since_closure_m: f64,
    closures: u64,
}

impl PositionTracker {
    /// A tracker for a session that has closed `closures` loops so far.
    pub fn new(closures: u64) -> Self {
        Self {
            closures,
            ..Self::default()
        }
    }

    /// Takes the next event.
    pub fn on_event(&mut self, event: &SessionEvent) {
        match event {
            SessionEvent::Pose(pose) => {
                if let Some(t) = pose.stamp {
                    let now = (pose.x, pose.y, pose.theta);
                    if let Some((t0, before)) = self.previous {
                        if let Some(v) = velocity_between(before, now, t - t0) {
                            self.velocity = v;
                        }
                        let step = (now.0 - before.0).hypot(now.1 - before.1);
                        if step.is_finite() {
                            self.path_since_closure_m += step;
                        }
                    }
                    self.previous = Some((t, now));
                }
                self.latest = Some(pose.clone());
                self.fresh = true;
            }
            SessionEvent::Status(status) => {
                if status.loop_closures > self.closures {
                    self.closures = status.loop_closures;
                    self.path_since_closure_m = 0.0;
                    // The correction moves the pose: not a motion of the robot.
                    self.previous = None;
                }
            }
        }
    }

    /// The position (in the `drawing`'s frame when given, else the map's) and velocity to
    /// send when a pose arrived since the last call; `None` otherwise (or when the pose is
    /// not finite, or has no place on the drawing).
    pub fn take_fresh(
        &mut self,
        resolution_m: f64,
        drift_per_m: f64,
        drawing: Option<&DrawingFrame>,
    ) -> Option<(AgvPosition, Velocity)> {
        if !self.fresh {
            return None;
        }
        self.fresh = false;
        let deviation = deviation_range_m(resolution_m, drift_per_m, self.path_since_closure_m);
        let position = agv_position(self.latest.as_ref()?, deviation, drawing)?;
        Some((position, self.velocity))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(t: f64, x: f64, y: f64, theta: f64) -> SessionEvent {
        SessionEvent::Pose(PoseResponse {
            session_id: "s".into(),
            x,
            y,
            theta,
            stamp: Some(t),
            sketch: None,
            map_id: "s".into(),
            position_initialized: true,
            localization_score: 1.0,
        })
    }

    #[test]
    fn a_pose_is_sent_once_with_its_velocity_and_deviation() {
        let mut tracker = PositionTracker::new(0);
        assert!(tracker.take_fresh(0.05, 0.02, None).is_none());
        tracker.on_event(&pose(0.0, 0.0, 0.0, 0.0));
        tracker.on_event(&pose(1.0, 0.5, 0.0, 0.0));
        tracker.on_event(&pose(2.0, 1.0, 0.0, 0.0));
        let (position, velocity) = tracker.take_fresh(0.05, 0.02, None).unwrap();
        assert_eq!((position.x, position.y), (1.0, 0.0));
        assert!((velocity.vx - 0.5).abs() < 1e-12);
        // 1 m since the start: 0.05 + 0.02 · 1.
        assert!((position.deviation_range - 0.07).abs() < 1e-12);
        assert!(tracker.take_fresh(0.05, 0.02, None).is_none(), "sent twice");
    }
}
