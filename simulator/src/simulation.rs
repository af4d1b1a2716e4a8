//! A simulated run: the time-ordered stream of odometry readings and LiDAR scans a robot
//! driving a scenario's path would publish, each paired with the true pose.
//!
//! This ties the pieces together: [`Motion`] gives the true pose at each stamp, the
//! [`OdometryModel`] turns consecutive true poses (at the odometry rate) into a drifting
//! dead-reckoned pose, and the [`Lidar`] casts a scan in the [`World`] (at the LiDAR rate).
//! The publisher (`simulator run`) sends `SimStep::event` over iceoryx2 and the truth
//! recorder writes `SimStep::truth` of the scans to `truth.csv`.
//!
//! # Clock and ordering
//!
//! Stamps are nanoseconds of simulated time from 0: reading `k` of a topic at rate `f` is
//! stamped `round(k·10⁹/f)`, so rates need not divide a second and nothing drifts. Both
//! topics start with reading 0 at stamp 0 and end with the last reading at or before the end
//! of the path (`⌊duration·f⌋ + 1` readings). Sequence numbers count per topic from 0. Events
//! come in stamp order; when a scan and an odometry reading share a stamp, the odometry comes
//! first, so a consumer always has odometry up to the scan's time.
//!
//! # Randomness
//!
//! Odometry and LiDAR noise draw from separate ChaCha8 streams derived from the scenario's
//! seed ([`stream_rng`]), so a run is identical for a seed, and the odometry of a seed does
//! not change when the beam count does.

use crate::error::SimError;
use crate::lidar::Lidar;
use crate::motion::Motion;
use crate::odometry::OdometryModel;
use crate::scenario::Scenario;
use crate::world::World;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use sketchslam_types::{Odometry, Pose2, Scan, SensorEvent};

/// Stream constant of the odometry noise: its rng is `seed_from_u64(seed ^ ODOMETRY_STREAM)`.
pub const ODOMETRY_STREAM: u64 = 0x0D0D_0D0D_0D0D_0D0D;
/// Stream constant of the LiDAR noise.
pub const LIDAR_STREAM: u64 = 0x11DA_11DA_11DA_11DA;
/// Stream constant of the renderer's sample scans.
pub const RENDER_STREAM: u64 = 0x5EE5_5EE5_5EE5_5EE5;

/// The random stream `stream` of a run seeded with `seed`: independent streams for
/// independent noise sources, so adding draws to one does not shift another.
pub fn stream_rng(seed: u64, stream: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed ^ stream)
}

/// One message of the simulated stream and the true pose at its stamp (world frame).
#[derive(Debug, Clone, PartialEq)]
pub struct SimStep {
    /// What the robot publishes.
    pub event: SensorEvent,
    /// The true pose at `event`'s stamp, world frame.
    pub truth: Pose2,
}

impl SimStep {
    /// The event's stamp in seconds of simulated time.
    pub fn t_s(&self) -> f64 {
        self.event.stamp_ns() as f64 * 1e-9
    }
}

/// One topic's clock: readings `0..total` at `rate_hz`.
#[derive(Debug, Clone, Copy)]
struct Clock {
    rate_hz: f64,
    next: u64,
    total: u64,
}

impl Clock {
    fn new(rate_hz: f64, duration_s: f64) -> Clock {
        // ⌊duration·f⌋ + 1 readings; the epsilon keeps an exact multiple from rounding down.
        let last = (duration_s * rate_hz * (1.0 + 1e-12)).floor();
        let total = if last.is_finite() && last >= 0.0 {
            last as u64 + 1
        } else {
            1
        };
        Clock {
            rate_hz,
            next: 0,
            total,
        }
    }

    fn stamp_ns(&self, k: u64) -> u64 {
        (k as f64 * 1e9 / self.rate_hz).round() as u64
    }

    /// The stamp of the next reading, if any are left.
    fn peek(&self) -> Option<u64> {
        (self.next < self.total).then(|| self.stamp_ns(self.next))
    }
}

/// A run of a scenario: an iterator over [`SimStep`]s in stamp order. See the module doc.
#[derive(Debug, Clone)]
pub struct Simulation {
    world: World,
    motion: Motion,
    lidar: Lidar,
    odometry: OdometryModel<ChaCha8Rng>,
    lidar_rng: ChaCha8Rng,
    odom_clock: Clock,
    scan_clock: Clock,
    last_odom_truth: Pose2,
}

impl Simulation {
    /// Prepares a run of `scenario` (decodes its world image).
    pub fn new(scenario: &Scenario) -> Result<Simulation, SimError> {
        let world = scenario.load_world()?;
        Ok(Simulation::with_world(scenario, world))
    }

    /// Prepares a run of `scenario` in an already loaded `world`.
    pub fn with_world(scenario: &Scenario, world: World) -> Simulation {
        let motion = Motion::new(&scenario.robot);
        let duration_s = motion.duration_s();
        Simulation {
            world,
            lidar: Lidar::new(&scenario.lidar),
            odometry: OdometryModel::new(
                &scenario.odometry,
                stream_rng(scenario.seed, ODOMETRY_STREAM),
            ),
            lidar_rng: stream_rng(scenario.seed, LIDAR_STREAM),
            odom_clock: Clock::new(scenario.odometry.rate_hz, duration_s),
            scan_clock: Clock::new(scenario.lidar.rate_hz, duration_s),
            last_odom_truth: motion.start(),
            motion,
        }
    }

    /// Length of the run in simulated seconds (the time to drive the path).
    pub fn duration_s(&self) -> f64 {
        self.motion.duration_s()
    }

    /// Total number of scans the run yields (for progress bars).
    pub fn scan_count(&self) -> u64 {
        self.scan_clock.total
    }

    /// Total number of odometry readings the run yields.
    pub fn odometry_count(&self) -> u64 {
        self.odom_clock.total
    }

    /// The truth world.
    pub fn world(&self) -> &World {
        &self.world
    }

    /// The true motion.
    pub fn motion(&self) -> &Motion {
        &self.motion
    }

    /// The scanner model.
    pub fn lidar(&self) -> &Lidar {
        &self.lidar
    }

    fn next_odometry(&mut self) -> SimStep {
        let k = self.odom_clock.next;
        let stamp_ns = self.odom_clock.stamp_ns(k);
        self.odom_clock.next += 1;
        let truth = self.motion.pose_at(stamp_ns as f64 * 1e-9);
        let pose = if k == 0 {
            self.odometry.pose()
        } else {
            self.odometry.step(self.last_odom_truth, truth)
        };
        self.last_odom_truth = truth;
        SimStep {
            event: SensorEvent::Odometry(Odometry {
                sequence: k,
                stamp_ns,
                x_m: pose.x,
                y_m: pose.y,
                theta_rad: pose.heading_rad,
            }),
            truth,
        }
    }

    fn next_scan(&mut self) -> SimStep {
        let k = self.scan_clock.next;
        let stamp_ns = self.scan_clock.stamp_ns(k);
        self.scan_clock.next += 1;
        let truth = self.motion.pose_at(stamp_ns as f64 * 1e-9);
        let ranges_m = self.lidar.scan(&self.world, truth, &mut self.lidar_rng);
        SimStep {
            event: SensorEvent::Scan(Scan {
                header: self.lidar.header(k, stamp_ns),
                ranges_m,
            }),
            truth,
        }
    }
}

impl Iterator for Simulation {
    type Item = SimStep;

    fn next(&mut self) -> Option<SimStep> {
        match (self.odom_clock.peek(), self.scan_clock.peek()) {
            (Some(o), Some(s)) if o <= s => Some(self.next_odometry()),
            (Some(_), None) => Some(self.next_odometry()),
            (_, Some(_)) => Some(self.next_scan()),
            (None, None) => None,
        }
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let left = (self.odom_clock.total - self.odom_clock.next)
            + (self.scan_clock.total - self.scan_clock.next);
        let left = usize::try_from(left).unwrap_or(usize::MAX);
        (left, Some(left))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clock_counts_readings_up_to_the_end() {
        assert_eq!(Clock::new(20.0, 10.0).total, 201);
        assert_eq!(Clock::new(20.0, 10.04).total, 201);
        assert_eq!(Clock::new(20.0, 0.0).total, 1);
        let c = Clock::new(30.0, 1.0);
        assert_eq!(c.total, 31);
        assert_eq!(c.stamp_ns(1), 33_333_333);
        assert_eq!(c.stamp_ns(30), 1_000_000_000);
    }
}
