//! The mapper: one per session, fed a robot's odometry and scans in time order.
//!
//! It joins the two sides of the method and hosts the two baselines:
//! - `odometry`: every scan is placed at the dead-reckoned pose;
//! - `icp`: the paper's "conventional ICP-SLAM", frame-to-frame point-to-line ICP seeded by
//!   the odometry increment, no sketch;
//! - `sketch`: the paper's method. Per scan: MCL on the drawing with scale (eq. 1–3), the
//!   sketch lines really observed (eq. 4), the heading corrected by matching them with the
//!   scan's RANSAC lines (eq. 5), the position by point-to-line ICP with that heading held
//!   (eq. 6), then the scan is fused into the occupancy grid.
//!
//! Map frame (DESIGN.md): meters, origin at the robot's start; with a sketch the axes are the
//! drawing's (x along +u, y along −v), so the start heading is the one marked on the sketch.
//! Between scans the pose is carried forward by the odometry increment, so the trajectory
//! holds a pose at every odometry message, not only at scans.
//!
//! The `sketch` method also closes loops ([`crate::back_end::loop_closure`]): every trajectory pose
//! and every fused scan is held relative to a keyframe, so when a loop closes and the
//! keyframes move, the trajectory follows them and the grid is rebuilt from the logged
//! scans at their corrected poses (lazily, when the grid is next asked for).
//!
//! Pure: no threads, clocks or I/O; its randomness comes from a seeded ChaCha stream.

mod sketch_tracker;

use crate::EngineError;
use crate::back_end::loop_closure::{LoopCloser, LoopClosureConfig};
use crate::localization::mcl::MclConfig;
use crate::mapping::grid::{GridConfig, OccupancyGrid};
use crate::scan_matching::icp::{Icp, IcpConfig, IcpMode};
use crate::sketch::{Sketch, SketchPose};
use serde::{Deserialize, Serialize};
use sketch_tracker::SketchTracker;
use sketchslam_types::{Odometry, Point2, Pose2, Scan, SensorEvent};
use std::fmt;
use std::str::FromStr;
use std::sync::Arc;

/// How a session turns scans into a map.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Scans placed at the dead-reckoned pose.
    Odometry,
    /// Frame-to-frame ICP seeded by odometry, no sketch.
    Icp,
    /// The paper's method with a hand-drawn map.
    Sketch,
}

impl Method {
    /// Every method, baselines first.
    pub const ALL: [Method; 3] = [Method::Odometry, Method::Icp, Method::Sketch];

    /// The method's name as used in the API and on the command line.
    pub fn as_str(&self) -> &'static str {
        match self {
            Method::Odometry => "odometry",
            Method::Icp => "icp",
            Method::Sketch => "sketch",
        }
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl FromStr for Method {
    type Err = EngineError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "odometry" => Ok(Method::Odometry),
            "icp" => Ok(Method::Icp),
            "sketch" => Ok(Method::Sketch),
            other => Err(EngineError::InvalidParameter {
                name: "method",
                reason: format!("{other:?} is not one of odometry, icp, sketch"),
            }),
        }
    }
}

/// The drawing a `sketch` session localizes on, with the start a person marked on it.
#[derive(Debug, Clone)]
pub struct SketchPrior {
    /// The processed drawing.
    pub sketch: Arc<Sketch>,
    /// The start marked on the drawing and the person's guess of its scale.
    pub start: SketchPose,
}

/// Where ICP finds the reference points a new scan is aligned to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum IcpReference {
    /// The previous scan, as the paper does.
    PreviousScan,
    /// Occupied cells of the map built so far (plus the previous scan).
    Map,
}

/// Settings of a mapper; the defaults are the ones the evaluation reports.
#[derive(Debug, Clone)]
pub struct MapperConfig {
    /// The occupancy grid.
    pub grid: GridConfig,
    /// MCL on the sketch.
    pub mcl: MclConfig,
    /// ICP (both the baseline and the sketch method's translation step).
    pub icp: IcpConfig,
    /// Reference of the sketch method's ICP.
    pub sketch_icp_reference: IcpReference,
    /// Share of the eq. (5) heading correction applied per scan, 0..1. 1 is the paper:
    /// the heading is replaced and ICP solves the translation only. Below 1 ICP solves
    /// the full pose against the map and the sketch's line directions pull its heading by
    /// this share of their difference per scan — a drawn wall a few degrees off then
    /// bends the map less.
    pub sketch_heading_gain: f64,
    /// With a gain below 1: heading differences within this band are taken as the
    /// drawing's own angular error and ignored, radians (a person draws a wall's direction
    /// within a few degrees).
    pub sketch_heading_deadband_rad: f64,
    /// Loop closure of the `sketch` method; `None` keeps the paper's front end alone.
    /// The baselines never close loops (`icp` is the paper's frame-to-frame ICP-SLAM).
    pub loop_closure: Option<LoopClosureConfig>,
    /// Seed of every random draw of the session.
    pub seed: u64,
}

impl Default for MapperConfig {
    fn default() -> Self {
        Self {
            grid: GridConfig::default(),
            mcl: MclConfig::default(),
            icp: IcpConfig::default(),
            sketch_icp_reference: IcpReference::PreviousScan,
            sketch_heading_gain: 0.05,
            sketch_heading_deadband_rad: 4f64.to_radians(),
            loop_closure: Some(LoopClosureConfig::default()),
            seed: 1,
        }
    }
}

/// The current pose estimate.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PoseEstimate {
    /// Stamp of the last message that moved the estimate, nanoseconds.
    pub stamp_ns: u64,
    /// Pose in the map frame.
    pub map: Pose2,
    /// Pose and scale on the drawing (`sketch` sessions only).
    pub sketch: Option<SketchPose>,
}

/// One pose of the trajectory.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TrajectoryPoint {
    /// Stamp, nanoseconds.
    pub stamp_ns: u64,
    /// Pose in the map frame.
    pub pose: Pose2,
}

/// How well the session is doing.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Health {
    /// Scans fused so far.
    pub scans_processed: u64,
    /// Scans refused (no usable return at all).
    pub scans_skipped: u64,
    /// Times MCL on the sketch broke down and was recovered.
    pub recoveries: u32,
    /// Sketch lines observed at the last scan (eq. 4).
    pub lines_observed: usize,
    /// Localization score in 0..1 (1 for the baselines once initialized).
    pub localization_score: f64,
    /// Estimated scale of the drawing, meters per pixel (`sketch` only).
    pub meters_per_pixel: Option<f64>,
    /// Loops closed so far (`sketch` with loop closure only).
    #[serde(default)]
    pub loop_closures: u32,
    /// True once the first odometry message has arrived.
    pub initialized: bool,
}

/// Per-method state.
enum Engine {
    Odometry,
    Icp {
        previous_points: Option<Vec<Point2>>,
    },
    Sketch(Box<SketchTracker>),
}

/// One session's mapping state.
pub struct Mapper {
    method: Method,
    config: MapperConfig,
    engine: Engine,
    grid: OccupancyGrid,
    /// Map pose of the robot at the start (identity, or the sketch's start heading).
    start_pose: Pose2,
    /// First odometry reading: the map frame's anchor in the odometry frame.
    odom_origin: Option<Pose2>,
    /// Latest odometry reading.
    odom_now: Option<Pose2>,
    /// Odometry reading at the last corrected pose.
    odom_at_fix: Pose2,
    /// Corrected map pose at the last scan.
    map_at_fix: Pose2,
    stamp_ns: u64,
    trajectory: Vec<TrajectoryPoint>,
    health: Health,
    /// The loop-closure back end (`sketch` sessions with it enabled).
    closer: Option<LoopCloser>,
    /// Per trajectory point: its keyframe and its pose relative to it (`None` before the
    /// first keyframe, or without loop closure).
    trajectory_anchors: Vec<Option<Anchor>>,
    /// Every fused scan with its keyframe anchor, to rebuild the grid after a correction.
    scan_log: Vec<(Anchor, Scan)>,
    /// True when keyframes moved since the grid was built.
    grid_stale: bool,
}

/// A pose held relative to a keyframe of the loop-closure back end.
#[derive(Debug, Clone, Copy)]
struct Anchor {
    keyframe: usize,
    relative: Pose2,
}

impl Mapper {
    /// A mapper for `method`; `sketch` needs a prior, the baselines ignore one.
    pub fn new(
        method: Method,
        prior: Option<SketchPrior>,
        config: MapperConfig,
    ) -> Result<Mapper, EngineError> {
        let (engine, start_pose) = match method {
            Method::Odometry => (Engine::Odometry, Pose2::IDENTITY),
            Method::Icp => (
                Engine::Icp {
                    previous_points: None,
                },
                Pose2::IDENTITY,
            ),
            Method::Sketch => {
                let prior = prior.ok_or(EngineError::InvalidParameter {
                    name: "sketch",
                    reason: "the sketch method needs a sketch and a start on it".into(),
                })?;
                let heading = prior.start.heading_rad;
                let tracker = SketchTracker::new(prior, &config)?;
                (
                    Engine::Sketch(Box::new(tracker)),
                    Pose2::new(0.0, 0.0, heading),
                )
            }
        };
        let closer = match method {
            Method::Sketch => config.loop_closure.clone().map(LoopCloser::new),
            _ => None,
        };
        Ok(Mapper {
            closer,
            trajectory_anchors: Vec::new(),
            scan_log: Vec::new(),
            grid_stale: false,
            method,
            grid: OccupancyGrid::new(config.grid),
            config,
            engine,
            start_pose,
            odom_origin: None,
            odom_now: None,
            odom_at_fix: Pose2::IDENTITY,
            map_at_fix: start_pose,
            stamp_ns: 0,
            trajectory: Vec::new(),
            health: Health::default(),
        })
    }

    /// The session's method.
    pub fn method(&self) -> Method {
        self.method
    }

    /// Feeds one message of the robot's time-ordered stream.
    pub fn on_event(&mut self, event: &SensorEvent) {
        match event {
            SensorEvent::Odometry(o) => self.on_odometry(o),
            SensorEvent::Scan(s) => self.on_scan(s),
        }
    }

    /// Feeds an odometry reading: the pose is carried forward by the increment since the
    /// last scan and appended to the trajectory.
    pub fn on_odometry(&mut self, odom: &Odometry) {
        let pose = odom.pose();
        if !pose.is_finite() {
            return;
        }
        if self.odom_origin.is_none() {
            self.odom_origin = Some(pose);
            self.odom_at_fix = pose;
            self.health.initialized = true;
            if self.method != Method::Sketch {
                self.health.localization_score = 1.0;
            }
        }
        self.odom_now = Some(pose);
        self.stamp_ns = self.stamp_ns.max(odom.stamp_ns);
        let current = self.current_map_pose();
        self.push_trajectory(odom.stamp_ns, current);
    }

    /// Feeds a scan: corrects the pose with the session's method and fuses the scan.
    pub fn on_scan(&mut self, scan: &Scan) {
        if scan.ranges_m.len() != scan.header.beam_count as usize
            || !scan.header.angle_min_rad.is_finite()
            || !scan.header.angle_increment_rad.is_finite()
        {
            self.health.scans_skipped += 1;
            return;
        }
        // Before any odometry, the robot is taken to be at its start.
        let odom_now = *self.odom_now.get_or_insert(Pose2::IDENTITY);
        if self.odom_origin.is_none() {
            self.odom_origin = Some(odom_now);
            self.odom_at_fix = odom_now;
        }
        let increment = self.odom_at_fix.between(&odom_now);
        let predicted = self.map_at_fix.compose(&increment);
        let points: Vec<Point2> = scan.points().map(|(_, p)| p).collect();
        let corrected = match &mut self.engine {
            Engine::Odometry => predicted,
            Engine::Icp { previous_points } => {
                let corrected = match previous_points.as_deref() {
                    Some(reference) if reference.len() >= 10 && points.len() >= 10 => {
                        let icp = Icp::new(reference, self.config.icp);
                        let result = icp.align(&points, increment, IcpMode::Full);
                        if result.converged {
                            self.map_at_fix.compose(&result.pose)
                        } else {
                            predicted
                        }
                    }
                    _ => predicted,
                };
                *previous_points = Some(points.clone());
                corrected
            }
            Engine::Sketch(tracker) => {
                let out = tracker.on_scan(
                    scan,
                    &points,
                    increment,
                    self.map_at_fix,
                    predicted,
                    &self.grid,
                );
                self.health.recoveries = out.recoveries;
                self.health.lines_observed = out.lines_observed;
                self.health.localization_score = out.localization_score;
                self.health.meters_per_pixel = Some(out.sketch_pose.meters_per_pixel);
                out.map_pose
            }
        };
        if !corrected.is_finite() {
            self.health.scans_skipped += 1;
            return;
        }
        let corrected = self.close_loops(corrected, &points);
        self.map_at_fix = corrected;
        self.odom_at_fix = odom_now;
        self.stamp_ns = self.stamp_ns.max(scan.header.stamp_ns);
        if !self.grid_stale {
            // (A stale grid is rebuilt from the log, this scan included.)
            self.grid.insert_scan(&corrected, scan);
        }
        if let Some(anchor) = self.anchor(&corrected) {
            self.scan_log.push((anchor, scan.clone()));
        }
        self.health.scans_processed += 1;
        self.push_trajectory(scan.header.stamp_ns, corrected);
    }

    /// Hands a keyframe to the loop-closure back end when one is due; when a loop closes,
    /// re-anchors the trajectory on the optimized keyframes and returns the scan's
    /// corrected pose.
    fn close_loops(&mut self, pose: Pose2, points: &[Point2]) -> Pose2 {
        if !self
            .closer
            .as_ref()
            .is_some_and(|c| c.wants_keyframe(&pose))
        {
            return pose;
        }
        let Some(closer) = &mut self.closer else {
            return pose;
        };
        let heading_prior = match &mut self.engine {
            Engine::Sketch(tracker) if closer.uses_heading_priors() => {
                tracker.heading_prior(points, &pose)
            }
            _ => None,
        };
        let outcome = closer.add_keyframe(pose, points, heading_prior);
        self.health.loop_closures = closer.closures().len() as u32;
        if !outcome.optimized {
            return pose;
        }
        let keyframes = closer.poses();
        let corrected = keyframes[outcome.index];
        for (point, anchor) in self.trajectory.iter_mut().zip(&self.trajectory_anchors) {
            if let Some(a) = anchor {
                point.pose = keyframes[a.keyframe].compose(&a.relative);
            }
        }
        self.grid_stale = true;
        if let Engine::Sketch(tracker) = &mut self.engine {
            tracker.on_map_corrected(points, corrected);
        }
        corrected
    }

    /// `pose` relative to the newest keyframe, when there is a back end with keyframes.
    fn anchor(&self, pose: &Pose2) -> Option<Anchor> {
        let keyframes = self.closer.as_ref()?.poses();
        let keyframe = keyframes.len().checked_sub(1)?;
        Some(Anchor {
            keyframe,
            relative: keyframes[keyframe].between(pose),
        })
    }

    /// The map pose now: the last corrected pose carried forward by odometry.
    fn current_map_pose(&self) -> Pose2 {
        match self.odom_now {
            Some(now) => self.map_at_fix.compose(&self.odom_at_fix.between(&now)),
            None => self.map_at_fix,
        }
    }

    fn push_trajectory(&mut self, stamp_ns: u64, pose: Pose2) {
        // One pose per stamp: a scan's correction replaces the odometry pose of its stamp.
        let anchor = self.anchor(&pose);
        if let Some(last) = self.trajectory.last_mut() {
            if last.stamp_ns == stamp_ns {
                last.pose = pose;
                if let Some(a) = self.trajectory_anchors.last_mut() {
                    *a = anchor;
                }
                return;
            }
            if last.stamp_ns > stamp_ns {
                return;
            }
        }
        self.trajectory.push(TrajectoryPoint { stamp_ns, pose });
        self.trajectory_anchors.push(anchor);
    }

    /// The current pose estimate.
    pub fn pose(&self) -> PoseEstimate {
        PoseEstimate {
            stamp_ns: self.stamp_ns,
            map: self.current_map_pose(),
            sketch: match &self.engine {
                Engine::Sketch(t) => Some(t.sketch_pose()),
                _ => None,
            },
        }
    }

    /// The map pose of the robot at its start.
    pub fn start_pose(&self) -> Pose2 {
        self.start_pose
    }

    /// Every pose so far, one per odometry message and scan, in stamp order.
    pub fn trajectory(&self) -> &[TrajectoryPoint] {
        &self.trajectory
    }

    /// The map built so far; after a loop closure it is first rebuilt from the logged
    /// scans at their corrected poses (O(scans · beams), once per correction).
    pub fn grid(&mut self) -> &OccupancyGrid {
        if self.grid_stale {
            if let Some(closer) = &self.closer {
                let keyframes = closer.poses();
                let mut grid = OccupancyGrid::new(self.config.grid);
                for (anchor, scan) in &self.scan_log {
                    grid.insert_scan(&keyframes[anchor.keyframe].compose(&anchor.relative), scan);
                }
                self.grid = grid;
            }
            self.grid_stale = false;
        }
        &self.grid
    }

    /// How the session is doing.
    pub fn health(&self) -> Health {
        self.health
    }
}

/// Writes a trajectory as `trajectory.csv` text: header `t,x,y,theta`, seconds, meters,
/// radians.
pub fn trajectory_csv(trajectory: &[TrajectoryPoint]) -> String {
    let mut out = String::from("t,x,y,theta\n");
    for p in trajectory {
        out.push_str(&format!(
            "{:.9},{:.6},{:.6},{:.6}\n",
            p.stamp_ns as f64 * 1e-9,
            p.pose.x,
            p.pose.y,
            p.pose.heading_rad
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use sketchslam_types::Point2;
    use sketchslam_types::ScanHeader;

    fn odom(seq: u64, x: f64, y: f64, th: f64) -> Odometry {
        Odometry {
            sequence: seq,
            stamp_ns: seq * 1_000_000,
            x_m: x,
            y_m: y,
            theta_rad: th,
        }
    }

    #[test]
    fn odometry_method_follows_dead_reckoning_from_the_start() {
        let mut m = Mapper::new(Method::Odometry, None, MapperConfig::default()).unwrap();
        // The odometry frame's origin is anywhere; the map frame starts at the first reading.
        m.on_odometry(&odom(0, 10.0, 5.0, std::f64::consts::FRAC_PI_2));
        m.on_odometry(&odom(1, 10.0, 7.0, std::f64::consts::FRAC_PI_2));
        let p = m.pose().map;
        assert!((p.x - 2.0).abs() < 1e-9 && p.y.abs() < 1e-9 && p.heading_rad.abs() < 1e-9);
        assert_eq!(m.trajectory().len(), 2);
    }

    #[test]
    fn garbage_scans_do_not_reach_the_map() {
        let mut m = Mapper::new(Method::Odometry, None, MapperConfig::default()).unwrap();
        m.on_odometry(&odom(0, 0.0, 0.0, 0.0));
        let header = ScanHeader {
            sequence: 0,
            stamp_ns: 1,
            angle_min_rad: -1.0,
            angle_increment_rad: 0.5,
            range_min_m: 0.05,
            range_max_m: 30.0,
            beam_count: 5,
        };
        let scan = Scan {
            header,
            ranges_m: vec![f32::NAN, f32::INFINITY, -1.0, 0.0, f32::NEG_INFINITY],
        };
        m.on_scan(&scan);
        assert!(m.grid().occupied_points().is_empty());
        let empty = Scan {
            header: ScanHeader {
                beam_count: 0,
                ..header
            },
            ranges_m: vec![],
        };
        m.on_scan(&empty);
        let lying = Scan {
            header: ScanHeader {
                beam_count: 9,
                ..header
            },
            ranges_m: vec![1.0],
        };
        m.on_scan(&lying);
        assert_eq!(m.health().scans_skipped, 1);
    }

    #[test]
    fn sketch_method_needs_a_prior() {
        assert!(Mapper::new(Method::Sketch, None, MapperConfig::default()).is_err());
        assert_eq!("icp".parse::<Method>().unwrap(), Method::Icp);
        assert!("slam".parse::<Method>().is_err());
    }

    /// A 10 × 6 m room with a 2 × 1 m pillar, drawn exactly at 0.05 m per pixel, and
    /// the robot's truth on two laps around the pillar, a pose every 0.2 m.
    fn room_and_laps() -> (Sketch, Vec<Pose2>) {
        let px = |x: f64, y: f64| Point2::new(10.0 + x / 0.05, 130.0 - y / 0.05);
        let walls = [
            ((0.0, 0.0), (10.0, 0.0)),
            ((10.0, 0.0), (10.0, 6.0)),
            ((10.0, 6.0), (0.0, 6.0)),
            ((0.0, 6.0), (0.0, 0.0)),
            ((4.0, 2.5), (6.0, 2.5)),
            ((6.0, 2.5), (6.0, 3.5)),
            ((6.0, 3.5), (4.0, 3.5)),
            ((4.0, 3.5), (4.0, 2.5)),
        ];
        let sketch = Sketch {
            width_px: 220,
            height_px: 140,
            strokes: vec![false; 220 * 140],
            lines: walls
                .iter()
                .enumerate()
                .map(|(i, (a, b))| crate::sketch::SketchLine::new(i, px(a.0, a.1), px(b.0, b.1)))
                .collect(),
        };
        let corners: [(f64, f64); 4] = [(2.0, 1.5), (8.0, 1.5), (8.0, 4.5), (2.0, 4.5)];
        let mut truth = Vec::new();
        for lap in 0..2 {
            for k in 0..4 {
                let (a, b) = (corners[k], corners[(k + 1) % 4]);
                let heading = (b.1 - a.1).atan2(b.0 - a.0);
                let n = ((b.0 - a.0).hypot(b.1 - a.1) / 0.2).round() as usize;
                for i in 0..n {
                    let t = i as f64 / n as f64;
                    truth.push(Pose2::new(
                        a.0 + t * (b.0 - a.0),
                        a.1 + t * (b.1 - a.1),
                        heading,
                    ));
                }
            }
            if lap == 1 {
                truth.push(Pose2::new(2.0, 1.5, 0.0));
            }
        }
        (sketch, truth)
    }

    #[test]
    fn a_closed_loop_moves_the_trajectory_and_rebuilds_the_grid() {
        let (sketch, truth) = room_and_laps();
        let raycaster = crate::sketch::raycast::SketchRaycaster::new(&sketch);
        let start = truth[0];
        let prior = SketchPrior {
            sketch: Arc::new(sketch),
            start: SketchPose {
                u_px: 10.0 + start.x / 0.05,
                v_px: 130.0 - start.y / 0.05,
                heading_rad: start.heading_rad,
                meters_per_pixel: 0.05,
            },
        };
        let mut m = Mapper::new(Method::Sketch, Some(prior), MapperConfig::default()).unwrap();
        // Odometry turns 3° too far per meter: ~8 m of heading drift in two laps.
        let mut odom_pose = Pose2::IDENTITY;
        for (k, t) in truth.iter().enumerate() {
            if k > 0 {
                let step = truth[k - 1].between(t);
                let d = step.position().norm();
                let drift = Pose2::new(step.x, step.y, step.heading_rad + d * 3f64.to_radians());
                odom_pose = odom_pose.compose(&drift);
            }
            let stamp_ns = k as u64 * 100_000_000;
            m.on_odometry(&Odometry {
                sequence: k as u64,
                stamp_ns,
                x_m: odom_pose.x,
                y_m: odom_pose.y,
                theta_rad: odom_pose.heading_rad,
            });
            let fov = 270f64.to_radians();
            let ranges: Vec<f32> = (0..271)
                .map(|i| {
                    let a = t.heading_rad - fov / 2.0 + i as f64 * fov / 270.0;
                    let (u, v) = (10.0 + t.x / 0.05, 130.0 - t.y / 0.05);
                    raycaster
                        .cast(u, v, a, 300.0)
                        .map_or(f32::INFINITY, |h| (h.range_px * 0.05) as f32)
                })
                .collect();
            let mut scan = Scan::centred(fov, 0.05, 15.0, ranges);
            scan.header.stamp_ns = stamp_ns;
            m.on_scan(&scan);
        }
        let health = m.health();
        assert!(health.loop_closures >= 1, "{health:?}");
        // The trajectory holds every stamp, and its last pose is the current estimate.
        assert_eq!(m.trajectory().len(), truth.len());
        let last = m.trajectory().last().unwrap().pose;
        assert!(last.position().distance(&m.pose().map.position()) < 1e-9);
        // Map frame = start frame: the end, back at the start, is within a few cm of it.
        let end = start.between(truth.last().unwrap());
        assert!(last.position().distance(&end.position()) < 0.1, "{last:?}");
        // The grid was rebuilt from every scan at the corrected poses.
        assert_eq!(m.grid().scans_inserted(), truth.len() as u64);
    }
}
