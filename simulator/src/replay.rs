//! A log replay: a dataset's CARMEN log turned into the same time-ordered stream of
//! [`SimStep`]s (odometry readings and LiDAR scans, each with its reference pose) that a
//! [`crate::Simulation`] yields, so `simulator replay`, the publisher and the evaluation
//! treat real data exactly as simulated data.
//!
//! # Clock
//!
//! Stamps are the log's own clock: `stamp_ns = round(logger_timestamp · 10⁹)`, not shifted
//! to start at 0. The relations of a dataset are stamped `logger_timestamp +
//! relations_time_offset`, so a relation time `t` is `t − offset` seconds on this clock
//! and lines up with the trajectory the service writes (`trajectory.csv` holds
//! `stamp_ns · 10⁻⁹`).
//!
//! # Scans
//!
//! One `Scan` per laser line. A `FLASER` line's beams span the dataset's field of view,
//! `1/n`-th of it apart, the first at `heading − fov/2` (CARMEN's layout: 180 beams over 180°
//! are 1° apart); a `ROBOTLASER1` line carries its own start angle and resolution. Readings
//! at or beyond the dataset's `max_range` (or the line's own maximum range, if smaller), and
//! readings that are not positive, become `f32::INFINITY` (no return). sketchslam has no
//! laser offset: the laser frame is taken as the robot frame, so a scan's reference pose is
//! the laser pose the line carries.
//!
//! # Odometry, and the drift a replay adds
//!
//! The poses in a corrected log (GMapping's output, e.g. the Intel log) are already
//! corrected, so replaying them as odometry would hand the mapper the answer. The replay
//! therefore feeds every pair of consecutive reference poses, in stream order, to the
//! simulator's own [`OdometryModel`] (same noise and bias model, the dataset's `[odometry]`
//! table, seeded with its `seed` through [`stream_rng`]) and publishes the drifting
//! dead-reckoned pose it returns — starting at the identity, as a driver that zeroes its
//! odometry at boot. [`Replay::drift_note`] says so in one line, for the logs.
//!
//! A log of raw wheel odometry (`[odometry] source = "log"`, e.g. the MIT CSAIL log) is
//! replayed as it is: no drift is added, every `ODOM` line is kept (raw odometry has no
//! correction frames to respect), and the scans' poses — the odometry at their time — are
//! no reference trajectory ([`Dataset::has_reference_poses`]).
//!
//! Odometry readings are the `ODOM` lines, plus one at every scan's stamp (sent just before
//! the scan) from the scan's reference pose, so the mapper has odometry exactly at each scan.
//!
//! A raw log whose `ODOM` lines lag their stamps by one line is re-stamped
//! (`odometry_lags_one_line`): GMapping's `.gfs` writer gives each `LASER_READING` the
//! pose of the `ODOM` line *after* the one with its stamp (all 406 scans of the CSAIL log,
//! exactly), and where a line is missing the motion shows one line late — across the CSAIL
//! log's 1.07 s gaps its benchmark relations turn 50°, 69° and 25° while the `ODOM` line at
//! the gap's end has turned 10°, 1° and 0°, and the line after it the rest. There each
//! line's pose is published at the previous line's stamp (the first line's pose and the
//! last line's stamp are left over), which makes the odometry agree with the scans' own
//! poses; the note says so.
//!
//! # Order
//!
//! CARMEN logs are written in processing order, not time order (the Intel log has ~1500
//! lines whose stamp is earlier than the line before). In a corrected log an `ODOM` pose is
//! expressed in the correction of the laser line before it in the file, so an `ODOM` line is
//! kept only when its stamp lies strictly between the stamps of the laser lines around it
//! in the file; the others are dropped and counted ([`Replay::dropped_odometry`]). The kept
//! events are then sorted by stamp (stable; a scan's odometry before the scan).

use crate::carmen::{CarmenLog, CarmenRecord, LaserRecord};
use crate::dataset::{Dataset, OdometrySource};
use crate::error::SimError;
use crate::lidar::RANGE_MIN_M;
use crate::odometry::OdometryModel;
use crate::rosbag::{BagStream, read_bag};
use crate::simulation::{ODOMETRY_STREAM, SimStep, stream_rng};
use sketchslam_types::{Odometry, Pose2, Scan, ScanHeader, SensorEvent};
use std::path::Path;

/// The replay of a dataset's log: an iterator over [`SimStep`]s in stamp order.
#[derive(Debug, Clone)]
pub struct Replay {
    steps: std::vec::IntoIter<SimStep>,
    scans: u64,
    odometry: u64,
    dropped_odometry: u64,
    note: String,
    lidar_mount: Option<Pose2>,
}

/// A reference pose of the stream before the odometry model: what, when, where.
enum Item<'a> {
    Odom {
        stamp_ns: u64,
        pose: Pose2,
    },
    ScanOdom {
        stamp_ns: u64,
        pose: Pose2,
    },
    Scan {
        stamp_ns: u64,
        laser: &'a LaserRecord,
    },
}

impl Item<'_> {
    fn stamp_ns(&self) -> u64 {
        match self {
            Item::Odom { stamp_ns, .. }
            | Item::ScanOdom { stamp_ns, .. }
            | Item::Scan { stamp_ns, .. } => *stamp_ns,
        }
    }
}

/// Seconds of the log → nanoseconds; None for negative or absurd times.
fn stamp_ns_of(t_s: f64) -> Option<u64> {
    let ns = (t_s * 1e9).round();
    (0.0..1.8e19).contains(&ns).then_some(ns as u64)
}

/// True when most scans that share a stamp with an odometry line carry the pose of the
/// line after it rather than its own (see the module doc): the lines lag by one.
/// `odometry` and `scans` are (stamp, pose), `odometry` sorted by stamp.
fn odometry_lags_one_line(odometry: &[(u64, Pose2)], scans: &[(u64, Pose2)]) -> bool {
    let same = |a: &Pose2, b: &Pose2| {
        a.position().distance(&b.position()) < 1e-3
            && sketchslam_types::wrap_angle(a.heading_rad - b.heading_rad).abs() < 1e-3
    };
    let (mut own, mut next) = (0usize, 0usize);
    for (stamp_ns, pose) in scans {
        let i = odometry.partition_point(|(t, _)| t < stamp_ns);
        if odometry.get(i).is_none_or(|(t, _)| t != stamp_ns) {
            continue;
        }
        // A robot standing still matches both: only a moving one tells.
        match (odometry.get(i), odometry.get(i + 1)) {
            (Some((_, a)), Some((_, b))) if !same(a, b) => {
                own += usize::from(same(pose, a));
                next += usize::from(same(pose, b));
            }
            _ => {}
        }
    }
    next > own && next >= 3
}

impl Replay {
    /// Reads the dataset's log and prepares the stream (the whole log is held in memory).
    pub fn new(dataset: &Dataset) -> Result<Replay, SimError> {
        if let Some(topics) = &dataset.bag {
            return Ok(Replay::from_bag(
                &dataset.log,
                read_bag(&dataset.log, topics)?,
            ));
        }
        let log = CarmenLog::read(&dataset.log)?;
        Replay::from_log(dataset, &log)
    }

    /// The stream of a ROS 2 bag read from `file`: its scans and odometry as recorded. A
    /// bag holds no reference poses; the steps' `truth` is the odometry, never scored
    /// ([`Dataset::has_reference_poses`] is false; `simulator replay BAG.mcap` refuses
    /// `--truth-out`). The note says the mount, in the session request's words.
    pub fn from_bag(file: &Path, bag: BagStream) -> Replay {
        let mut odom = Pose2::IDENTITY;
        let odometry = bag
            .events
            .iter()
            .filter(|e| matches!(e, SensorEvent::Odometry(_)))
            .count() as u64;
        let steps: Vec<SimStep> = bag
            .events
            .into_iter()
            .map(|event| {
                if let SensorEvent::Odometry(o) = &event {
                    odom = o.pose();
                }
                SimStep { event, truth: odom }
            })
            .collect();
        let mount = match bag.lidar_mount {
            Some(m) => format!(
                "the LiDAR's mount from /tf_static: \"lidar_mount\": {{\"x_m\": {:.4}, \
                 \"y_m\": {:.4}, \"yaw_deg\": {:.3}}}",
                m.x,
                m.y,
                m.heading_rad.to_degrees()
            ),
            None => "no /tf_static chain to the laser: the LiDAR is taken to be at the centre"
                .to_string(),
        };
        let skipped = match bag.skipped {
            0 => String::new(),
            n => format!("; {n} messages stamped before the epoch skipped"),
        };
        Replay {
            steps: steps.into_iter(),
            scans: bag.scans,
            odometry,
            dropped_odometry: 0,
            note: format!(
                "{}: a ROS 2 bag, its odometry replayed as recorded (no reference poses); \
                 {mount}{skipped}",
                file.display()
            ),
            lidar_mount: bag.lidar_mount,
        }
    }

    /// The LiDAR's pose on the robot, when the recording says it (a bag's `/tf_static`).
    pub fn lidar_mount(&self) -> Option<Pose2> {
        self.lidar_mount
    }

    /// The stream of an already parsed `log` with `dataset`'s sensor and noise settings.
    pub fn from_log(dataset: &Dataset, log: &CarmenLog) -> Result<Replay, SimError> {
        let bad_time = |line: usize, t_s: f64| SimError::Parse {
            file: dataset.log.clone(),
            line: Some(line),
            key: None,
            message: format!("logger_timestamp {t_s} is not a time in seconds >= 0"),
        };
        // Stamps of the laser lines in file order, to window the ODOM lines between them.
        let mut laser_stamps: Vec<u64> = Vec::new();
        for laser in log.lasers() {
            laser_stamps.push(
                stamp_ns_of(laser.timestamp_s)
                    .ok_or_else(|| bad_time(laser.line, laser.timestamp_s))?,
            );
        }
        // A raw log's ODOM lines in stamp order, re-stamped when they lag by one line.
        let raw = dataset.odometry_source == OdometrySource::Log;
        let mut raw_odometry: Vec<(u64, Pose2)> = Vec::new();
        if raw {
            for o in log.odometry() {
                let stamp_ns =
                    stamp_ns_of(o.timestamp_s).ok_or_else(|| bad_time(o.line, o.timestamp_s))?;
                if o.pose.is_finite() {
                    raw_odometry.push((stamp_ns, o.pose));
                }
            }
            raw_odometry.sort_by_key(|(stamp_ns, _)| *stamp_ns);
        }
        let scan_poses: Vec<(u64, Pose2)> = laser_stamps
            .iter()
            .zip(log.lasers())
            .map(|(&t, l)| (t, l.laser_pose))
            .collect();
        let restamped = raw && odometry_lags_one_line(&raw_odometry, &scan_poses);
        if restamped {
            raw_odometry = raw_odometry.windows(2).map(|w| (w[0].0, w[1].1)).collect();
        }
        // (stamp, group, rank, item): group = laser lines seen before it in the file.
        let mut items: Vec<(u64, usize, u8, Item<'_>)> = Vec::new();
        let mut lasers_before = 0usize;
        let mut dropped_odometry = 0u64;
        for record in &log.records {
            match record {
                // A raw log's odometry enters from `raw_odometry` below.
                CarmenRecord::Odometry(_) if raw => {}
                CarmenRecord::Odometry(o) => {
                    let stamp_ns = stamp_ns_of(o.timestamp_s)
                        .ok_or_else(|| bad_time(o.line, o.timestamp_s))?;
                    let after_previous = lasers_before
                        .checked_sub(1)
                        .is_none_or(|k| stamp_ns > laser_stamps[k]);
                    let before_next = laser_stamps
                        .get(lasers_before)
                        .is_none_or(|&next| stamp_ns < next);
                    if after_previous && before_next && o.pose.is_finite() {
                        items.push((
                            stamp_ns,
                            lasers_before,
                            0,
                            Item::Odom {
                                stamp_ns,
                                pose: o.pose,
                            },
                        ));
                    } else {
                        dropped_odometry += 1;
                    }
                }
                CarmenRecord::Laser(laser) => {
                    let stamp_ns = laser_stamps[lasers_before];
                    lasers_before += 1;
                    items.push((
                        stamp_ns,
                        lasers_before,
                        1,
                        Item::ScanOdom {
                            stamp_ns,
                            pose: laser.laser_pose,
                        },
                    ));
                    items.push((stamp_ns, lasers_before, 2, Item::Scan { stamp_ns, laser }));
                }
            }
        }
        for &(stamp_ns, pose) in &raw_odometry {
            // Before the scans of its stamp (their group is one more).
            let group = laser_stamps.partition_point(|&t| t < stamp_ns);
            items.push((stamp_ns, group, 0, Item::Odom { stamp_ns, pose }));
        }
        items.sort_by_key(|(stamp, group, rank, _)| (*stamp, *group, *rank));

        let mut model =
            OdometryModel::new(&dataset.odometry, stream_rng(dataset.seed, ODOMETRY_STREAM));
        let mut steps = Vec::with_capacity(items.len());
        let (mut scans, mut odometry) = (0u64, 0u64);
        let mut previous: Option<Pose2> = None;
        for (_, _, _, item) in &items {
            match item {
                Item::Odom { pose, .. } | Item::ScanOdom { pose, .. } => {
                    let dead_reckoned = match dataset.odometry_source {
                        // Raw odometry: published as the robot reported it.
                        OdometrySource::Log => *pose,
                        OdometrySource::Drift => match previous {
                            Some(prev) => model.step(prev, *pose),
                            None => model.pose(),
                        },
                    };
                    previous = Some(*pose);
                    steps.push(SimStep {
                        event: SensorEvent::Odometry(Odometry {
                            sequence: odometry,
                            stamp_ns: item.stamp_ns(),
                            x_m: dead_reckoned.x,
                            y_m: dead_reckoned.y,
                            theta_rad: dead_reckoned.heading_rad,
                        }),
                        truth: *pose,
                    });
                    odometry += 1;
                }
                Item::Scan { stamp_ns, laser } => {
                    steps.push(SimStep {
                        event: SensorEvent::Scan(scan_of(dataset, laser, scans, *stamp_ns)),
                        truth: laser.laser_pose,
                    });
                    scans += 1;
                }
            }
        }
        let o = &dataset.odometry;
        let note = match dataset.odometry_source {
            OdometrySource::Log => format!(
                "replay of {}: the log's ODOM lines are raw wheel odometry, published as they are \
                 (no drift added; the log holds no reference trajectory){}; {scans} scans, \
                 {odometry} odometry readings",
                dataset.log.display(),
                if restamped {
                    ", each at the stamp of the line before it (the scans' poses show the \
                     lines one late)"
                } else {
                    ""
                }
            ),
            OdometrySource::Drift => format!(
                "replay of {}: the log's poses are corrected, so the published odometry is them plus \
             drift added here (trans_noise {}, rot_noise {}, trans_bias {}, rot_bias {}, seed {}); \
             {scans} scans, {odometry} odometry readings, {dropped_odometry} out-of-order ODOM \
             lines dropped",
                dataset.log.display(),
                o.trans_noise,
                o.rot_noise,
                o.trans_bias,
                o.rot_bias,
                dataset.seed
            ),
        };
        Ok(Replay {
            steps: steps.into_iter(),
            scans,
            odometry,
            dropped_odometry,
            note,
            lidar_mount: None,
        })
    }

    /// Total number of scans the replay yields.
    pub fn scan_count(&self) -> u64 {
        self.scans
    }

    /// Total number of odometry readings the replay yields.
    pub fn odometry_count(&self) -> u64 {
        self.odometry
    }

    /// `ODOM` lines left out because their stamp is out of order (see the module doc).
    pub fn dropped_odometry(&self) -> u64 {
        self.dropped_odometry
    }

    /// One line saying that the odometry is the log's corrected poses plus drift added by
    /// the replay (with the noise settings), and what the stream holds.
    pub fn drift_note(&self) -> &str {
        &self.note
    }
}

/// The `Scan` message of a laser line: see the module doc for the layout.
fn scan_of(dataset: &Dataset, laser: &LaserRecord, sequence: u64, stamp_ns: u64) -> Scan {
    let n = laser.ranges_m.len();
    let (angle_min_rad, angle_increment_rad, max_range_m) = match laser.layout {
        Some(l) => (
            l.start_angle_rad,
            l.angular_resolution_rad,
            dataset.lidar.max_range_m.min(l.max_range_m),
        ),
        None => {
            let gaps = if laser.end_to_end {
                n.saturating_sub(1)
            } else {
                n
            };
            (
                -0.5 * dataset.lidar.fov_rad,
                dataset.lidar.fov_rad / gaps.max(1) as f64,
                dataset.lidar.max_range_m,
            )
        }
    };
    let ranges_m = laser
        .ranges_m
        .iter()
        .map(|&r| {
            if r > 0.0 && r < max_range_m {
                r as f32
            } else {
                f32::INFINITY
            }
        })
        .collect();
    Scan {
        header: ScanHeader {
            sequence,
            stamp_ns,
            angle_min_rad: angle_min_rad as f32,
            angle_increment_rad: angle_increment_rad as f32,
            range_min_m: RANGE_MIN_M as f32,
            range_max_m: max_range_m as f32,
            beam_count: n as u32,
        },
        ranges_m,
    }
}

impl Iterator for Replay {
    type Item = SimStep;

    fn next(&mut self) -> Option<SimStep> {
        self.steps.next()
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        self.steps.size_hint()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dataset::DatasetLidar;
    use crate::scenario::OdometryConfig;
    use std::path::{Path, PathBuf};

    fn dataset(noise: f64) -> Dataset {
        Dataset {
            odometry_source: OdometrySource::Drift,
            name: "t".into(),
            dir: PathBuf::from("/d"),
            log: PathBuf::from("/d/x.log"),
            bag: None,
            relations: None,
            relations_time_offset_s: 0.0,
            lidar: DatasetLidar {
                fov_rad: std::f64::consts::PI,
                max_range_m: 50.0,
            },
            odometry: OdometryConfig {
                rate_hz: 0.0,
                trans_noise: noise,
                rot_noise: noise,
                trans_bias: 0.0,
                rot_bias: 0.0,
            },
            seed: 5,
            sketches: Vec::new(),
        }
    }

    const LOG: &str = "ODOM 0 0 0 0 0 0 0.5 h 0.5\n\
        ODOM 0.1 0 0 0 0 0 1.0 h 1.0\n\
        ODOM 0.3 0 0 0 0 0 2.5 h 2.5\n\
        FLASER 4 1.0 81.83 -1 2.0 0.2 0 0 0.2 0 0 2.0 h 2.0\n\
        ODOM 0.25 0 0 0 0 0 1.9 h 1.9\n\
        ODOM 0.4 0 0.1 0 0 0 3.0 h 3.0\n";

    #[test]
    fn stream_is_ordered_windowed_and_noise_free_without_noise() {
        let log = CarmenLog::parse(LOG, Path::new("x.log")).unwrap();
        let replay = Replay::from_log(&dataset(0.0), &log).unwrap();
        assert_eq!(replay.scan_count(), 1);
        assert_eq!(replay.dropped_odometry(), 2);
        assert!(replay.drift_note().contains("drift"));
        let steps: Vec<SimStep> = replay.collect();
        let stamps: Vec<u64> = steps.iter().map(|s| s.event.stamp_ns()).collect();
        assert_eq!(
            stamps,
            vec![
                500_000_000,
                1_000_000_000,
                2_000_000_000,
                2_000_000_000,
                3_000_000_000
            ]
        );
        // Without noise the odometry reproduces the reference poses (start at identity).
        for s in &steps {
            if let SensorEvent::Odometry(o) = &s.event {
                assert!((o.x_m - s.truth.x).abs() < 1e-12, "{o:?} {:?}", s.truth);
                assert!((o.theta_rad - s.truth.heading_rad).abs() < 1e-12);
            }
        }
        let SensorEvent::Scan(scan) = &steps[3].event else {
            panic!("the scan follows its odometry")
        };
        assert_eq!(scan.ranges_m[0], 1.0);
        assert_eq!(scan.ranges_m[1], f32::INFINITY);
        assert_eq!(scan.ranges_m[2], f32::INFINITY);
        assert!((scan.header.angle_min_rad + std::f32::consts::FRAC_PI_2).abs() < 1e-6);
        assert!((scan.header.angle_increment_rad - std::f32::consts::FRAC_PI_4).abs() < 1e-6);
        assert_eq!(steps[3].truth, Pose2::new(0.2, 0.0, 0.0));
    }

    #[test]
    fn noise_makes_the_odometry_drift() {
        let log = CarmenLog::parse(LOG, Path::new("x.log")).unwrap();
        let steps: Vec<SimStep> = Replay::from_log(&dataset(0.2), &log).unwrap().collect();
        let SensorEvent::Odometry(last) = &steps[4].event else {
            panic!("odometry last")
        };
        assert!((last.x_m - 0.4).abs() > 1e-6);
    }

    /// The Intel log of the shared data sets: 910 scans of 180 beams.
    #[test]
    fn intel_log_has_910_scans_of_180_beams() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/datasets/intel-lab");
        if !dir.join(crate::dataset::DATASET_FILE).is_file() {
            eprintln!("skipped: no shared dataset at {}", dir.display());
            return;
        }
        let dataset = Dataset::load(&dir).unwrap();
        let log = CarmenLog::read(&dataset.log).unwrap();
        assert_eq!(log.lasers().count(), 910);
        assert!(log.lasers().all(|l| l.ranges_m.len() == 180));
        // The drawings listed grow over time (two sketches, then a CAD plan): check that
        // there is one and that each image named is there, not how many there are.
        assert!(dataset.sketches.iter().any(|s| s.name == "person-1"));
        assert!(dataset.sketches.iter().all(|s| s.image.is_file()));
        let replay = Replay::from_log(&dataset, &log).unwrap();
        assert_eq!(replay.scan_count(), 910);
        let mut last = 0;
        for step in replay {
            assert!(step.event.stamp_ns() >= last);
            last = step.event.stamp_ns();
        }
    }

    #[test]
    fn a_lag_of_one_odometry_line_is_told_from_the_scans_own_poses() {
        // A robot driving along x, one line every 100 ns.
        let odometry: Vec<(u64, Pose2)> = (0..6)
            .map(|k| (k * 100, Pose2::new(k as f64 * 0.2, 0.0, 0.0)))
            .collect();
        let scans_at = |shift: usize| -> Vec<(u64, Pose2)> {
            [1usize, 2, 3, 4]
                .iter()
                .map(|&k| (odometry[k].0, odometry[k + shift].1))
                .collect()
        };
        assert!(odometry_lags_one_line(&odometry, &scans_at(1)));
        assert!(!odometry_lags_one_line(&odometry, &scans_at(0)));
        // Standing still, both readings fit every scan: nothing to tell.
        let still: Vec<(u64, Pose2)> = (0..6).map(|k| (k * 100, Pose2::IDENTITY)).collect();
        let scans: Vec<(u64, Pose2)> = (1..5).map(|k| (k * 100, Pose2::IDENTITY)).collect();
        assert!(!odometry_lags_one_line(&still, &scans));
        // Scans between lines say nothing either.
        let between: Vec<(u64, Pose2)> = (1..5usize)
            .map(|k| (k as u64 * 100 + 50, odometry[k + 1].1))
            .collect();
        assert!(!odometry_lags_one_line(&odometry, &between));
    }

    /// The MIT CSAIL log of the shared data sets: GMapping's .gfs with raw wheel odometry,
    /// replayed as it is.
    #[test]
    fn csail_gfs_has_406_scans_of_361_beams_and_its_raw_odometry_is_replayed_as_is() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/datasets/mit-csail");
        let dataset = Dataset::load(&dir).unwrap();
        assert_eq!(dataset.odometry_source, OdometrySource::Log);
        assert!(!dataset.has_reference_poses());
        let log = CarmenLog::read(&dataset.log).unwrap();
        assert_eq!(log.lasers().count(), 406);
        assert!(
            log.lasers()
                .all(|l| l.ranges_m.len() == 361 && l.end_to_end)
        );
        assert_eq!(log.odometry().count(), 1988);
        let lines: Vec<_> = log.odometry().collect();
        let replay = Replay::from_log(&dataset, &log).unwrap();
        assert_eq!(replay.scan_count(), 406);
        // Every ODOM line's pose kept but the first (re-stamped, below), plus one at each scan.
        assert_eq!(replay.odometry_count(), 1987 + 406);
        assert_eq!(replay.dropped_odometry(), 0);
        let note = replay.drift_note().to_string();
        assert!(note.contains("raw wheel odometry"));
        // The .gfs lines lag by one: every pose is published at the line before's stamp,
        // so the odometry at a scan's stamp is the scan's own pose.
        assert!(note.contains("the line before it"), "{note}");
        let steps: Vec<SimStep> = replay.collect();
        let SensorEvent::Odometry(o) = &steps[0].event else {
            panic!("the stream starts with odometry")
        };
        assert_eq!(o.stamp_ns, stamp_ns_of(lines[0].timestamp_s).unwrap());
        assert_eq!(
            o.pose(),
            lines[1].pose,
            "raw odometry is published unchanged"
        );
        let SensorEvent::Odometry(second) = &steps[1].event else {
            panic!("odometry first")
        };
        assert_eq!(second.stamp_ns, stamp_ns_of(lines[1].timestamp_s).unwrap());
        assert_eq!(second.pose(), lines[2].pose);
        let scan_at = steps
            .iter()
            .position(|s| matches!(s.event, SensorEvent::Scan(_)))
            .unwrap();
        let first_laser = log.lasers().next().unwrap();
        for step in &steps[scan_at - 2..scan_at] {
            let SensorEvent::Odometry(o) = &step.event else {
                panic!("a scan's odometry comes just before it")
            };
            // (ODOM lines are written to the millimetre, scans to the micrometre.)
            let d = o.pose().between(&first_laser.laser_pose);
            assert!(
                d.position().norm() < 1e-3 && d.heading_rad.abs() < 1e-6,
                "{d:?}"
            );
        }
        let scan = steps
            .iter()
            .find_map(|s| match &s.event {
                SensorEvent::Scan(scan) => Some(scan.clone()),
                _ => None,
            })
            .unwrap();
        // 361 readings over 180°: 0.5° apart, the last at +90°.
        assert!((scan.header.angle_increment_rad as f64 - 0.5f64.to_radians()).abs() < 1e-6);
        assert!((scan.beam_angle_rad(360) - 90f64.to_radians()).abs() < 1e-5);
        let mut last = 0;
        for step in &steps {
            assert!(step.event.stamp_ns() >= last);
            last = step.event.stamp_ns();
        }
    }
}
