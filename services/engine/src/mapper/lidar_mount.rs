//! Where the LiDAR sits on the robot, and the change of frame at the mapper's edges.
//!
//! A scan is a fan of rays from the LiDAR, not from the robot's centre: a scanner 0.3 m
//! ahead of the axle sees a wall 0.3 m nearer than the centre does, and when the robot turns
//! in place the scanner swings through an arc. Fed to the mapper as if taken at the centre,
//! every rotation becomes a false translation and the map bends.
//!
//! The mapper therefore runs on the LiDAR's poses. With the mount `M` (the LiDAR's pose in
//! the robot frame: forward `x`, left `y`, yaw `θ`):
//!
//! ```text
//! odometry in:   L_odom = R_odom ⊕ M         (the dead-reckoned pose carried to the LiDAR)
//! start in:      L_0    = R_0 ⊕ M            (on the drawing: in pixels, with its scale)
//! poses out:     R      = L ⊕ M⁻¹            (trajectory, pose, pose on the drawing)
//! ```
//!
//! The map frame stays the robot's: origin at the robot's start, axes as before, so the
//! map, the warp onto the drawing and the trajectory mean what they meant without a mount.
//! A zero mount changes nothing, bit for bit: every conversion is skipped.
//!
//! Cost: one SE(2) composition per pose crossing the edge.

use sketchslam_types::Pose2;

use crate::sketch::SketchPose;

/// The robot→LiDAR transform and its inverse.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LidarMount {
    mount: Pose2,
    inverse: Pose2,
    identity: bool,
}

impl LidarMount {
    /// The mount `M`: the LiDAR's pose in the robot frame.
    pub fn new(mount: Pose2) -> LidarMount {
        LidarMount {
            mount,
            inverse: mount.inverse(),
            identity: mount.x == 0.0 && mount.y == 0.0 && mount.heading_rad == 0.0,
        }
    }

    /// True for a LiDAR at the robot's centre, facing forward.
    pub fn is_identity(&self) -> bool {
        self.identity
    }

    /// The LiDAR's pose when the robot is at `robot`: `R ⊕ M`.
    pub fn to_lidar(&self, robot: Pose2) -> Pose2 {
        if self.identity {
            robot
        } else {
            robot.compose(&self.mount)
        }
    }

    /// The robot's pose when the LiDAR is at `lidar`: `L ⊕ M⁻¹`.
    pub fn to_robot(&self, lidar: Pose2) -> Pose2 {
        if self.identity {
            lidar
        } else {
            lidar.compose(&self.inverse)
        }
    }

    /// A motion between two LiDAR poses (`L_a⁻¹ ⊕ L_b`) as the robot's between the same
    /// instants: `R_a⁻¹ ⊕ R_b = M ⊕ (L_a⁻¹ ⊕ L_b) ⊕ M⁻¹`.
    pub fn relative_to_robot(&self, lidar_relative: Pose2) -> Pose2 {
        if self.identity {
            lidar_relative
        } else {
            self.mount.compose(&lidar_relative).compose(&self.inverse)
        }
    }

    /// [`LidarMount::to_lidar`] on the drawing: the offset in meters is drawn with the
    /// pose's own scale ([`SketchPose::advanced`]).
    pub fn sketch_to_lidar(&self, robot: SketchPose) -> SketchPose {
        if self.identity {
            robot
        } else {
            let m = self.mount;
            robot.advanced(m.x, m.y, m.heading_rad)
        }
    }

    /// [`LidarMount::to_robot`] on the drawing.
    pub fn sketch_to_robot(&self, lidar: SketchPose) -> SketchPose {
        if self.identity {
            lidar
        } else {
            let m = self.inverse;
            lidar.advanced(m.x, m.y, m.heading_rad)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    fn close(a: Pose2, b: Pose2) -> bool {
        (a.x - b.x).abs() < 1e-12
            && (a.y - b.y).abs() < 1e-12
            && sketchslam_types::wrap_angle(a.heading_rad - b.heading_rad).abs() < 1e-12
    }

    #[test]
    fn a_lidar_ahead_of_a_robot_facing_north_is_north_of_it() {
        // Robot at (2, 1) facing +y; LiDAR 0.3 m ahead, 0.1 m to the left, turned 5°.
        let mount = LidarMount::new(Pose2::new(0.3, 0.1, 5f64.to_radians()));
        let robot = Pose2::new(2.0, 1.0, FRAC_PI_2);
        let lidar = mount.to_lidar(robot);
        // Ahead is +y, left is −x.
        assert!(close(
            lidar,
            Pose2::new(2.0 - 0.1, 1.0 + 0.3, FRAC_PI_2 + 5f64.to_radians())
        ));
        assert!(close(mount.to_robot(lidar), robot));
    }

    #[test]
    fn on_the_drawing_the_offset_is_drawn_at_the_drawing_scale() {
        // 0.1 m per pixel, robot facing +u (east on the page): 0.3 m ahead is 3 px to the
        // right; 0.1 m to the left is 1 px up (smaller v).
        let mount = LidarMount::new(Pose2::new(0.3, 0.1, 0.0));
        let robot = SketchPose {
            u_px: 100.0,
            v_px: 50.0,
            heading_rad: 0.0,
            meters_per_pixel: 0.1,
        };
        let lidar = mount.sketch_to_lidar(robot);
        assert!((lidar.u_px - 103.0).abs() < 1e-9 && (lidar.v_px - 49.0).abs() < 1e-9);
        let back = mount.sketch_to_robot(lidar);
        assert!((back.u_px - 100.0).abs() < 1e-9 && (back.v_px - 50.0).abs() < 1e-9);
        assert!(back.heading_rad.abs() < 1e-12);
    }

    #[test]
    fn a_lidar_ahead_swings_sideways_when_the_robot_turns_in_place() {
        // The robot turns 90° on the spot; a LiDAR 0.3 m ahead goes from (0.3, 0) facing +x
        // to (0, 0.3) facing +y: in its own starting frame, 0.3 m back and 0.3 m left.
        let mount = LidarMount::new(Pose2::new(0.3, 0.0, 0.0));
        let (ra, rb) = (Pose2::IDENTITY, Pose2::new(0.0, 0.0, FRAC_PI_2));
        let (la, lb) = (mount.to_lidar(ra), mount.to_lidar(rb));
        let lidar_rel = la.between(&lb);
        assert!(close(lidar_rel, Pose2::new(-0.3, 0.3, FRAC_PI_2)));
        assert!(close(mount.relative_to_robot(lidar_rel), ra.between(&rb)));
    }

    #[test]
    fn a_zero_mount_returns_its_input_untouched() {
        let mount = LidarMount::new(Pose2::IDENTITY);
        assert!(mount.is_identity());
        // A heading beyond ±π would be wrapped by a composition; untouched here.
        let p = Pose2::new(1.0, 2.0, 7.0);
        assert_eq!(mount.to_lidar(p), p);
        assert_eq!(mount.to_robot(p), p);
    }
}
