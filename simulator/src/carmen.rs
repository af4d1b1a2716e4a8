//! CARMEN log files, and GMapping's `.gfs` output files written in the same spirit: the
//! laser scans and odometry poses a real robot recorded, parsed into records in file order.
//!
//! This is the first stage of a log replay: [`crate::dataset::Dataset`] names the log,
//! this module reads it, and [`crate::replay::Replay`] turns the records into the same
//! time-ordered `SensorEvent` stream a simulation yields.
//!
//! Lines understood (whitespace-separated; lengths in meters, angles in radians, times in
//! seconds):
//!
//! ```text
//! FLASER n r1..rn x y theta odom_x odom_y odom_theta ipc_timestamp host logger_timestamp
//! ODOM x y theta tv rv accel ipc_timestamp host logger_timestamp
//! ROBOTLASER1 laser_type start_angle field_of_view angular_resolution maximum_range accuracy
//!     remission_mode num_readings r1..rn num_remissions m1..mk laser_pose_x laser_pose_y
//!     laser_pose_theta robot_pose_x robot_pose_y robot_pose_theta laser_tv laser_rv
//!     forward_safety_dist side_safety_dist turn_axis timestamp host logger_timestamp
//! LASER_READING n r1..rn x y theta timestamp      (GMapping .gfs: x y theta = odometry pose)
//! ODOM x y theta timestamp                        (GMapping .gfs: raw wheel odometry)
//! ```
//!
//! A `.gfs` file's `LASER_READING` spans the field of view end to end (361 readings over 180°
//! are 0.5° apart, the first at −90°, the last at +90°); a `FLASER`'s `n` readings are `1/n`-th
//! of it apart. GMapping's bookkeeping lines (`FRAME`, `NEFF`, `SM_UPDATE`, `ODO_UPDATE`,
//! `RESAMPLE`) are ignored like any other.
//!
//! Every other line (comments `#`, `PARAM`, `NEFF`, `RAWLASER*`, `TRUEPOS`, ...) is
//! ignored. The time of a record is its `logger_timestamp`. A malformed line of a known
//! kind is an error naming the file and the 1-based line ([`SimError::Parse`]).

use crate::error::SimError;
use sketchslam_types::Pose2;
use std::path::Path;

/// A laser scan of the log (`FLASER` or `ROBOTLASER1`).
#[derive(Debug, Clone, PartialEq)]
pub struct LaserRecord {
    /// 1-based line in the log.
    pub line: usize,
    /// `logger_timestamp`, seconds.
    pub timestamp_s: f64,
    /// The readings as written, meters.
    pub ranges_m: Vec<f64>,
    /// Beam layout written in the line (`ROBOTLASER1` only; `FLASER` has none).
    pub layout: Option<BeamLayout>,
    /// Without a layout: true when the readings span the field of view end to end
    /// (`LASER_READING`, `n − 1` gaps), false when they are `1/n`-th of it apart (`FLASER`).
    pub end_to_end: bool,
    /// Pose of the laser when the scan was taken (`x y theta` / `laser_pose_*`).
    pub laser_pose: Pose2,
    /// Pose of the robot (`odom_*` / `robot_pose_*`).
    pub robot_pose: Pose2,
}

/// The beam geometry a `ROBOTLASER1` line carries.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeamLayout {
    /// Angle of the first beam from the laser's heading, radians.
    pub start_angle_rad: f64,
    /// Angle between consecutive beams, radians.
    pub angular_resolution_rad: f64,
    /// The scanner's maximum range, meters.
    pub max_range_m: f64,
}

/// An odometry pose of the log (`ODOM`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OdomRecord {
    /// 1-based line in the log.
    pub line: usize,
    /// `logger_timestamp`, seconds.
    pub timestamp_s: f64,
    /// The pose written (`x y theta`).
    pub pose: Pose2,
}

/// One understood line of a log.
#[derive(Debug, Clone, PartialEq)]
pub enum CarmenRecord {
    /// A laser scan.
    Laser(LaserRecord),
    /// An odometry pose.
    Odometry(OdomRecord),
}

/// The understood lines of a log, in file order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CarmenLog {
    /// The records, in file order (not necessarily in time order: CARMEN logs are not).
    pub records: Vec<CarmenRecord>,
}

impl CarmenLog {
    /// Reads and parses the log at `path`.
    pub fn read(path: &Path) -> Result<CarmenLog, SimError> {
        let text = std::fs::read_to_string(path).map_err(|source| SimError::Io {
            file: path.to_path_buf(),
            action: "cannot read",
            source,
        })?;
        CarmenLog::parse(&text, path)
    }

    /// Parses log text as if it were the file `file` (for messages).
    pub fn parse(text: &str, file: &Path) -> Result<CarmenLog, SimError> {
        let mut records = Vec::new();
        for (n, line) in text.lines().enumerate() {
            let line_no = n + 1;
            let tokens: Vec<&str> = line.split_whitespace().collect();
            let parsed = match tokens.first() {
                Some(&"FLASER") => parse_flaser(&tokens, line_no).map(CarmenRecord::Laser),
                Some(&"ROBOTLASER1") => {
                    parse_robotlaser1(&tokens, line_no).map(CarmenRecord::Laser)
                }
                Some(&"LASER_READING") => {
                    parse_laser_reading(&tokens, line_no).map(CarmenRecord::Laser)
                }
                // GMapping's `ODOM x y theta t` has 5 fields, CARMEN's 10.
                Some(&"ODOM") if tokens.len() == 5 => {
                    parse_gfs_odom(&tokens, line_no).map(CarmenRecord::Odometry)
                }
                Some(&"ODOM") => parse_odom(&tokens, line_no).map(CarmenRecord::Odometry),
                _ => continue,
            };
            records.push(parsed.map_err(|message| SimError::Parse {
                file: file.to_path_buf(),
                line: Some(line_no),
                key: None,
                message,
            })?);
        }
        Ok(CarmenLog { records })
    }

    /// The laser records, in file order.
    pub fn lasers(&self) -> impl Iterator<Item = &LaserRecord> {
        self.records.iter().filter_map(|r| match r {
            CarmenRecord::Laser(l) => Some(l),
            CarmenRecord::Odometry(_) => None,
        })
    }

    /// The odometry records, in file order.
    pub fn odometry(&self) -> impl Iterator<Item = &OdomRecord> {
        self.records.iter().filter_map(|r| match r {
            CarmenRecord::Odometry(o) => Some(o),
            CarmenRecord::Laser(_) => None,
        })
    }
}

/// The finite number at `tokens[i]`, called `name` in messages.
fn number(tokens: &[&str], i: usize, name: &str) -> Result<f64, String> {
    let token = tokens
        .get(i)
        .ok_or_else(|| format!("{}: field `{name}` is missing", tokens[0]))?;
    token
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| {
            format!(
                "{}: field `{name}` (field {}) is not a finite number: {token:?}",
                tokens[0],
                i + 1
            )
        })
}

/// The count at `tokens[i]`, called `name` in messages.
fn count(tokens: &[&str], i: usize, name: &str) -> Result<usize, String> {
    let token = tokens
        .get(i)
        .ok_or_else(|| format!("{}: field `{name}` is missing", tokens[0]))?;
    token
        .parse::<usize>()
        .map_err(|_| format!("{}: `{name}` is not a count: {token:?}", tokens[0]))
}

/// The pose at `tokens[i..i + 3]`; its fields are called `{prefix}x`, `{prefix}y`, ...
fn pose(tokens: &[&str], i: usize, prefix: &str) -> Result<Pose2, String> {
    Ok(Pose2::new(
        number(tokens, i, &format!("{prefix}x"))?,
        number(tokens, i + 1, &format!("{prefix}y"))?,
        number(tokens, i + 2, &format!("{prefix}theta"))?,
    ))
}

fn expect_len(tokens: &[&str], expected: usize, layout: &str) -> Result<(), String> {
    if tokens.len() == expected {
        Ok(())
    } else {
        Err(format!(
            "{}: expected {expected} fields ({layout}), found {}",
            tokens[0],
            tokens.len()
        ))
    }
}

fn readings(tokens: &[&str], from: usize, n: usize) -> Result<Vec<f64>, String> {
    (0..n)
        .map(|k| number(tokens, from + k, &format!("r{}", k + 1)))
        .collect()
}

fn parse_flaser(tokens: &[&str], line: usize) -> Result<LaserRecord, String> {
    let n = count(tokens, 1, "n")?;
    expect_len(
        tokens,
        n + 11,
        "FLASER n r1..rn x y theta odom_x odom_y odom_theta ipc_timestamp host logger_timestamp",
    )?;
    Ok(LaserRecord {
        line,
        ranges_m: readings(tokens, 2, n)?,
        layout: None,
        end_to_end: false,
        laser_pose: pose(tokens, 2 + n, "")?,
        robot_pose: pose(tokens, 5 + n, "odom_")?,
        timestamp_s: number(tokens, 10 + n, "logger_timestamp")?,
    })
}

fn parse_robotlaser1(tokens: &[&str], line: usize) -> Result<LaserRecord, String> {
    let n = count(tokens, 8, "num_readings")?;
    let m = count(tokens, 9 + n, "num_remissions")?;
    expect_len(
        tokens,
        n + m + 24,
        "ROBOTLASER1 laser_type start_angle field_of_view angular_resolution maximum_range \
         accuracy remission_mode num_readings [readings] num_remissions [remissions] \
         laser_pose(3) robot_pose(3) laser_tv laser_rv forward_safety_dist side_safety_dist \
         turn_axis timestamp host logger_timestamp",
    )?;
    let p = 10 + n + m;
    Ok(LaserRecord {
        line,
        end_to_end: false,
        layout: Some(BeamLayout {
            start_angle_rad: number(tokens, 2, "start_angle")?,
            angular_resolution_rad: number(tokens, 4, "angular_resolution")?,
            max_range_m: number(tokens, 5, "maximum_range")?,
        }),
        ranges_m: readings(tokens, 9, n)?,
        laser_pose: pose(tokens, p, "laser_pose_")?,
        robot_pose: pose(tokens, p + 3, "robot_pose_")?,
        timestamp_s: number(tokens, p + 13, "logger_timestamp")?,
    })
}

fn parse_odom(tokens: &[&str], line: usize) -> Result<OdomRecord, String> {
    expect_len(
        tokens,
        10,
        "ODOM x y theta tv rv accel ipc_timestamp host logger_timestamp",
    )?;
    Ok(OdomRecord {
        line,
        pose: pose(tokens, 1, "")?,
        timestamp_s: number(tokens, 9, "logger_timestamp")?,
    })
}

fn parse_laser_reading(tokens: &[&str], line: usize) -> Result<LaserRecord, String> {
    let n = count(tokens, 1, "n")?;
    expect_len(tokens, n + 6, "LASER_READING n r1..rn x y theta timestamp")?;
    let at = pose(tokens, 2 + n, "")?;
    Ok(LaserRecord {
        line,
        ranges_m: readings(tokens, 2, n)?,
        layout: None,
        end_to_end: true,
        laser_pose: at,
        robot_pose: at,
        timestamp_s: number(tokens, 5 + n, "timestamp")?,
    })
}

fn parse_gfs_odom(tokens: &[&str], line: usize) -> Result<OdomRecord, String> {
    expect_len(tokens, 5, "ODOM x y theta timestamp")?;
    Ok(OdomRecord {
        line,
        pose: pose(tokens, 1, "")?,
        timestamp_s: number(tokens, 4, "timestamp")?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const LOG: &str = "# a comment\n\
        PARAM robot_front_laser_max 81.83\n\
        ODOM 0.5 0.25 0.1 0 0 0 1.5 host 1.25\n\
        FLASER 3 1.0 2.0 81.83 0.1 0.2 0.3 0.4 0.5 0.6 2.0 host 2.5\n\
        NEFF 15\n\
        ROBOTLASER1 0 -1.5 3.0 0.0175 50.0 0.01 0 2 1.5 2.5 1 7.0 1 2 3 4 5 6 0 0 0 0 0 3.0 host 3.5\n";

    #[test]
    fn parses_flaser_odom_and_robotlaser1() {
        let log = CarmenLog::parse(LOG, Path::new("x.log")).unwrap();
        assert_eq!(log.records.len(), 3);
        let odom: Vec<_> = log.odometry().collect();
        assert_eq!(odom[0].line, 3);
        assert_eq!(odom[0].pose, Pose2::new(0.5, 0.25, 0.1));
        assert_eq!(odom[0].timestamp_s, 1.25);
        let lasers: Vec<_> = log.lasers().collect();
        assert_eq!(lasers[0].ranges_m, vec![1.0, 2.0, 81.83]);
        assert_eq!(lasers[0].laser_pose, Pose2::new(0.1, 0.2, 0.3));
        assert_eq!(lasers[0].robot_pose, Pose2::new(0.4, 0.5, 0.6));
        assert_eq!(lasers[0].timestamp_s, 2.5);
        assert!(lasers[0].layout.is_none());
        assert_eq!(lasers[1].ranges_m, vec![1.5, 2.5]);
        assert_eq!(lasers[1].laser_pose, Pose2::new(1.0, 2.0, 3.0));
        assert_eq!(lasers[1].robot_pose, Pose2::new(4.0, 5.0, 6.0));
        assert_eq!(lasers[1].timestamp_s, 3.5);
        let layout = lasers[1].layout.unwrap();
        assert_eq!(layout.start_angle_rad, -1.5);
        assert_eq!(layout.max_range_m, 50.0);
    }

    #[test]
    fn errors_name_file_and_line() {
        let bad = "ODOM 0 0 0 0 0 0 1 host 1\nFLASER 3 1.0 2.0 0 0 0 0 0 0 2.0 host 2.5\n";
        let e = CarmenLog::parse(bad, Path::new("/d/x.log"))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("/d/x.log:2:"), "{e}");
        assert!(e.contains("expected 14 fields"), "{e}");
        let bad = "ODOM 0 nan 0 0 0 0 1 host 1\n";
        let e = CarmenLog::parse(bad, Path::new("x.log"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("x.log:1:") && e.contains("`y`"), "{e}");
    }

    #[test]
    fn parses_gmapping_gfs_lines_and_skips_its_bookkeeping() {
        let gfs = "PARAM delta 0.05\n\
            ODOM 576.537 0.107 -2.255213 1134864629.895182\n\
            ODO_UPDATE 30 0.000 0.000 0.000000 0.000000\n\
            LASER_READING 3 1.5 81.91 2.5 576.48 -0.10 -1.48 1134864642.914187\n\
            FRAME 1\nNEFF 30\nSM_UPDATE 30 1 2 3\nRESAMPLE 1 2 3\n";
        let log = CarmenLog::parse(gfs, Path::new("x.gfs")).unwrap();
        assert_eq!(log.records.len(), 2);
        let odom = log.odometry().next().unwrap();
        assert_eq!(odom.line, 2);
        assert!((odom.timestamp_s - 1134864629.895182).abs() < 1e-6);
        assert!((odom.pose.x - 576.537).abs() < 1e-12);
        let laser = log.lasers().next().unwrap();
        assert_eq!(laser.ranges_m, vec![1.5, 81.91, 2.5]);
        assert!(laser.end_to_end && laser.layout.is_none());
        assert_eq!(laser.laser_pose, laser.robot_pose);
        assert!((laser.timestamp_s - 1134864642.914187).abs() < 1e-6);
        // A short line names its layout.
        let err = CarmenLog::parse("LASER_READING 3 1 2 3 0 0\n", Path::new("x.gfs"));
        assert!(
            err.unwrap_err()
                .to_string()
                .contains("LASER_READING n r1..rn")
        );
    }
}
