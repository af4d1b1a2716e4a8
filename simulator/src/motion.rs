//! The robot's true motion: turn on the spot to face the next waypoint, then drive straight
//! to it, for every waypoint in order.
//!
//! This is the truth the sensor models sample: [`crate::simulation::Simulation`] asks
//! [`Motion::pose_at`] for the true pose at every odometry and scan stamp. The motion is a
//! piecewise function of time precomputed once into phases (turns and straight legs), so a
//! query is a binary search plus O(1) interpolation: O(log n) for n waypoints, pure.

use crate::scenario::RobotConfig;
use sketchslam_types::{Point2, Pose2, wrap_angle};

/// One piece of the motion, starting at `start_s` in the pose `from`.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    /// Turn on the spot by `delta_rad` (shortest way, sign = direction) at the turn rate.
    Turn {
        start_s: f64,
        duration_s: f64,
        from: Pose2,
        delta_rad: f64,
    },
    /// Drive straight from `from`'s position to `to` at the speed, heading fixed.
    Drive {
        start_s: f64,
        duration_s: f64,
        from: Pose2,
        to: Point2,
    },
}

impl Phase {
    fn start_s(&self) -> f64 {
        match *self {
            Phase::Turn { start_s, .. } | Phase::Drive { start_s, .. } => start_s,
        }
    }

    /// The pose `dt_s` seconds into the phase (clamped to it).
    fn pose_after(&self, dt_s: f64) -> Pose2 {
        match *self {
            Phase::Turn {
                duration_s,
                from,
                delta_rad,
                ..
            } => {
                let f = (dt_s / duration_s).clamp(0.0, 1.0);
                Pose2::new(from.x, from.y, from.heading_rad + f * delta_rad)
            }
            Phase::Drive {
                duration_s,
                from,
                to,
                ..
            } => {
                let f = (dt_s / duration_s).clamp(0.0, 1.0);
                Pose2::new(
                    from.x + f * (to.x - from.x),
                    from.y + f * (to.y - from.y),
                    from.heading_rad,
                )
            }
        }
    }
}

/// The true trajectory of a robot along its waypoints.
#[derive(Debug, Clone)]
pub struct Motion {
    start: Pose2,
    end: Pose2,
    phases: Vec<Phase>,
    duration_s: f64,
}

impl Motion {
    /// Precomputes the phases of `robot`'s path. Waypoints equal to the current position are
    /// skipped (no turn, no leg); each turn goes the short way (a half turn goes
    /// counter-clockwise). O(n) for n waypoints.
    ///
    /// The config is expected to be validated (positive speed and turn rate, finite
    /// numbers); a non-positive speed or rate gives a robot that never moves.
    pub fn new(robot: &RobotConfig) -> Motion {
        let mut phases = Vec::with_capacity(2 * robot.path.len());
        let mut pose = robot.start;
        let mut t_s = 0.0;
        let moves = robot.speed_m_s > 0.0 && robot.turn_rate_rad_s > 0.0;
        for &to in robot.path.iter().filter(|_| moves) {
            let (dx, dy) = (to.x - pose.x, to.y - pose.y);
            let length_m = dx.hypot(dy);
            if !(length_m > 0.0 && length_m.is_finite()) {
                continue;
            }
            let heading_rad = dy.atan2(dx);
            let delta_rad = wrap_angle(heading_rad - pose.heading_rad);
            if delta_rad != 0.0 {
                let duration_s = delta_rad.abs() / robot.turn_rate_rad_s;
                phases.push(Phase::Turn {
                    start_s: t_s,
                    duration_s,
                    from: pose,
                    delta_rad,
                });
                t_s += duration_s;
                pose = Pose2::new(pose.x, pose.y, heading_rad);
            }
            let duration_s = length_m / robot.speed_m_s;
            phases.push(Phase::Drive {
                start_s: t_s,
                duration_s,
                from: pose,
                to,
            });
            t_s += duration_s;
            pose = Pose2::new(to.x, to.y, heading_rad);
        }
        Motion {
            start: robot.start,
            end: pose,
            phases,
            duration_s: t_s,
        }
    }

    /// Total time to drive the whole path, seconds.
    pub fn duration_s(&self) -> f64 {
        self.duration_s
    }

    /// The start pose.
    pub fn start(&self) -> Pose2 {
        self.start
    }

    /// The final pose (at the last waypoint, facing along the last leg).
    pub fn end(&self) -> Pose2 {
        self.end
    }

    /// The true pose at time `t_s` (seconds from the start): the start before 0, the end
    /// after [`Motion::duration_s`]. O(log n): binary search for the phase, then linear
    /// interpolation of position (legs) or heading (turns) inside it.
    pub fn pose_at(&self, t_s: f64) -> Pose2 {
        if t_s.is_nan() || t_s <= 0.0 || self.phases.is_empty() {
            return self.start;
        }
        if t_s >= self.duration_s {
            return self.end;
        }
        // The last phase starting at or before t_s.
        let k = self.phases.partition_point(|p| p.start_s() <= t_s);
        let phase = &self.phases[k.saturating_sub(1)];
        phase.pose_after(t_s - phase.start_s())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI};

    fn robot() -> RobotConfig {
        // Start at the origin facing +x; 2 m east, then 1 m north, then back 1 m south.
        RobotConfig {
            start: Pose2::new(0.0, 0.0, 0.0),
            path: vec![
                Point2::new(2.0, 0.0),
                Point2::new(2.0, 0.0),
                Point2::new(2.0, 1.0),
                Point2::new(2.0, 0.0),
            ],
            speed_m_s: 0.5,
            turn_rate_rad_s: FRAC_PI_2, // a quarter turn per second
        }
    }

    fn close(a: Pose2, x: f64, y: f64, heading_rad: f64) -> bool {
        (a.x - x).abs() < 1e-12
            && (a.y - y).abs() < 1e-12
            && wrap_angle(a.heading_rad - heading_rad).abs() < 1e-12
    }

    #[test]
    fn poses_at_hand_computed_times() {
        let m = Motion::new(&robot());
        // Leg 0: 2 m at 0.5 m/s = 4 s. Turn 90 deg = 1 s. Leg 1: 1 m = 2 s.
        // Turn 180 deg = 2 s (counter-clockwise). Leg 2: 1 m = 2 s. Total 11 s.
        assert!((m.duration_s() - 11.0).abs() < 1e-12);
        assert!(close(m.pose_at(-1.0), 0.0, 0.0, 0.0));
        assert!(close(m.pose_at(0.0), 0.0, 0.0, 0.0));
        assert!(close(m.pose_at(1.0), 0.5, 0.0, 0.0));
        assert!(close(m.pose_at(4.0), 2.0, 0.0, 0.0));
        assert!(close(m.pose_at(4.5), 2.0, 0.0, FRAC_PI_2 / 2.0));
        assert!(close(m.pose_at(5.0), 2.0, 0.0, FRAC_PI_2));
        assert!(close(m.pose_at(6.0), 2.0, 0.5, FRAC_PI_2));
        assert!(close(m.pose_at(8.0), 2.0, 1.0, PI));
        assert!(close(m.pose_at(9.0), 2.0, 1.0, -FRAC_PI_2));
        assert!(close(m.pose_at(10.0), 2.0, 0.5, -FRAC_PI_2));
        assert!(close(m.pose_at(11.0), 2.0, 0.0, -FRAC_PI_2));
        assert!(close(m.pose_at(100.0), 2.0, 0.0, -FRAC_PI_2));
        assert!(close(m.end(), 2.0, 0.0, -FRAC_PI_2));
    }

    #[test]
    fn clockwise_turns_take_the_short_way() {
        let mut r = robot();
        r.path = vec![Point2::new(0.0, -1.0)];
        let m = Motion::new(&r);
        // -90 deg: 1 s of turning, then 2 s of driving.
        assert!((m.duration_s() - 3.0).abs() < 1e-12);
        assert!(close(m.pose_at(0.5), 0.0, 0.0, -FRAC_PI_2 / 2.0));
    }
}
