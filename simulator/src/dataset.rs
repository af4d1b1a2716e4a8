//! Dataset folders: `dataset.toml`, the counterpart of `scenario.toml` for real data — a
//! recorded CARMEN log instead of a world and a path, the benchmark relations that score
//! it, the odometry noise a replay adds, and the sketches of the place.
//!
//! [`Dataset::load`] reads and checks the file; [`crate::replay::Replay`] streams the log
//! as a simulation would; the evaluation scores the result against the relations. The file
//! (every table rejects unknown keys; angles in degrees in the file, radians here):
//!
//! ```toml
//! name = "intel-lab"
//! log = "intel.gfs.log"                  # CARMEN log: FLASER / ROBOTLASER1 and ODOM lines
//! relations = "intel.relations"          # optional: t1 t2 x y z roll pitch yaw
//! relations_time_offset = 976052857.337  # relation time = log timestamp + this, seconds
//! [lidar]
//! fov_deg = 180.0                        # FLASER beams span it, first at heading − fov/2
//! max_range = 50.0                       # readings at or beyond it are no return, meters
//! [odometry]                             # the drift a replay adds (see crate::odometry)
//! trans_noise = 0.05
//! rot_noise = 0.05
//! trans_bias = 0.02
//! rot_bias = 0.02
//! seed = 5
//! [[sketch]]                             # as in scenario.toml
//! ```
//!
//! A ROS 2 robot's recording instead of a CARMEN log: `bag = "run.mcap"` (rosbag2's MCAP,
//! [`crate::rosbag`]) with, optionally, `scan_topic` (default `/scan`), `odom_topic`
//! (`/odom`) and `base_frame`; no `[lidar]` table (the scans say their geometry) and no
//! noise keys (the bag's odometry is replayed as recorded, `source = "log"`): relations, when
//! given, score such a run; without them the map is reported alone.
//!
//! A log whose `ODOM` lines are the robot's raw wheel odometry (not corrected poses) says so
//! with `[odometry] source = "log"` and no noise keys: the replay publishes that odometry as
//! it is and adds nothing; such a log has no reference trajectory, only its relations score
//! a run. `source = "drift"` (the default) is the table above.

use crate::error::SimError;
use crate::rosbag::BagTopics;
use crate::scenario::{OdometryConfig, SketchConfig, SketchTable};
use crate::toml_file::{self, Ctx, Table};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// The file a dataset folder must hold.
pub const DATASET_FILE: &str = "dataset.toml";

/// A loaded and checked dataset. Angles in radians, lengths in meters, paths absolute.
#[derive(Debug, Clone, PartialEq)]
pub struct Dataset {
    /// The dataset's name.
    pub name: String,
    /// The dataset folder (absolute).
    pub dir: PathBuf,
    /// The recording (absolute path): a CARMEN log, or a ROS 2 bag when [`Dataset::bag`] is
    /// set.
    pub log: PathBuf,
    /// A ROS 2 bag's topics: `log` is an MCAP bag read with them.
    pub bag: Option<BagTopics>,
    /// The relations file (absolute path), if the dataset has one.
    pub relations: Option<PathBuf>,
    /// Relation time = log timestamp + this, seconds.
    pub relations_time_offset_s: f64,
    /// The scanner.
    pub lidar: DatasetLidar,
    /// Where the published odometry comes from.
    pub odometry_source: OdometrySource,
    /// The drift a replay adds to the log's poses (`rate_hz` is unused: the log's rate);
    /// all zero with [`OdometrySource::Log`].
    pub odometry: OdometryConfig,
    /// Seed of the replay's odometry noise.
    pub seed: u64,
    /// The hand-drawn maps, in file order.
    pub sketches: Vec<SketchConfig>,
}

/// Where a replay's odometry comes from (`[odometry] source`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OdometrySource {
    /// The log's poses are corrected (GMapping's output): the replay adds seeded drift to
    /// them, and they are the reference trajectory of the ATE.
    Drift,
    /// The log's `ODOM` lines are raw wheel odometry: replayed as they are; no reference
    /// trajectory.
    Log,
}

/// `[lidar]`: what a `FLASER` line does not say about its scanner.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DatasetLidar {
    /// Field of view of a `FLASER` scan, radians in (0, 2π].
    pub fov_rad: f64,
    /// Readings at or beyond it are no return, meters.
    pub max_range_m: f64,
}

impl Dataset {
    /// Loads and checks `dir/dataset.toml`: unknown, missing or mistyped keys, a log (and
    /// relations file) that exists, a field of view in (0, 360], a positive range,
    /// non-negative noises, sketches as in a scenario with unique names.
    pub fn load(dir: &Path) -> Result<Dataset, SimError> {
        let dir = std::fs::canonicalize(dir)
            .or_else(|_| std::path::absolute(dir))
            .unwrap_or_else(|_| dir.to_path_buf());
        let file = dir.join(DATASET_FILE);
        let source = toml_file::read(&file)?;
        Dataset::from_toml(&source, &file)
    }

    /// Parses and checks dataset text as if it were the file `file`; relative paths are
    /// taken from `file`'s folder.
    pub fn from_toml(source: &str, file: &Path) -> Result<Dataset, SimError> {
        let ctx = Ctx { file, source };
        let raw: DatasetFile = ctx.deserialize()?;
        let dir = file.parent().unwrap_or(Path::new(".")).to_path_buf();
        let invalid = |table: Table, key: &str, message: String| ctx.invalid(table, key, message);
        if raw.name.trim().is_empty() {
            return Err(invalid(Table::Root, "name", "must not be empty".into()));
        }
        let (key, recording) = match (&raw.log, &raw.bag) {
            (Some(log), None) => ("log", log),
            (None, Some(bag)) => ("bag", bag),
            (Some(_), Some(_)) => {
                return Err(invalid(
                    Table::Root,
                    "bag",
                    "give either `log` (a CARMEN log) or `bag` (a ROS 2 bag), not both".into(),
                ));
            }
            (None, None) => {
                return Err(invalid(
                    Table::Root,
                    "log",
                    "is missing: give `log` (a CARMEN log) or `bag` (a ROS 2 bag)".into(),
                ));
            }
        };
        let log = dir.join(recording);
        if !log.is_file() {
            return Err(invalid(
                Table::Root,
                key,
                format!("{} is not a readable file", log.display()),
            ));
        }
        let bag = raw.bag.as_ref().map(|_| {
            let defaults = BagTopics::default();
            BagTopics {
                scan: raw.scan_topic.clone().unwrap_or(defaults.scan),
                odom: raw.odom_topic.clone().unwrap_or(defaults.odom),
                base_frame: raw.base_frame.clone(),
            }
        });
        if bag.is_none() {
            for (key, set) in [
                ("scan_topic", raw.scan_topic.is_some()),
                ("odom_topic", raw.odom_topic.is_some()),
                ("base_frame", raw.base_frame.is_some()),
            ] {
                if set {
                    return Err(invalid(Table::Root, key, "applies to a `bag` only".into()));
                }
            }
        }
        // A bag's scans carry their own geometry; a CARMEN log's need [lidar].
        let lidar_table = match (&raw.lidar, &bag) {
            (Some(l), _) => LidarTable {
                fov_deg: l.fov_deg,
                max_range: l.max_range,
            },
            (None, Some(_)) => LidarTable {
                fov_deg: 360.0,
                max_range: 1000.0,
            },
            (None, None) => {
                return Err(invalid(
                    Table::Root,
                    "lidar",
                    "the [lidar] table is missing (fov_deg, max_range of the log's scans)".into(),
                ));
            }
        };
        let empty_odometry = OdometryTable {
            source: Some("log".into()),
            trans_noise: None,
            rot_noise: None,
            trans_bias: None,
            rot_bias: None,
            seed: None,
        };
        let odometry_table = match (&raw.odometry, &bag) {
            (Some(_), Some(_)) => {
                return Err(invalid(
                    Table::Named("odometry"),
                    "source",
                    "a bag's odometry is replayed as recorded: leave [odometry] out".into(),
                ));
            }
            (Some(o), None) => o,
            (None, Some(_)) => &empty_odometry,
            (None, None) => {
                return Err(invalid(
                    Table::Root,
                    "odometry",
                    "the [odometry] table is missing".into(),
                ));
            }
        };
        let relations = match &raw.relations {
            Some(r) => {
                let path = dir.join(r);
                if !path.is_file() {
                    return Err(invalid(
                        Table::Root,
                        "relations",
                        format!("{} is not a readable file", path.display()),
                    ));
                }
                Some(path)
            }
            None => None,
        };
        if !raw.relations_time_offset.is_finite() {
            return Err(invalid(
                Table::Root,
                "relations_time_offset",
                format!(
                    "must be a finite number of seconds, got {}",
                    raw.relations_time_offset
                ),
            ));
        }
        let fov_rad = lidar_table.fov_deg.to_radians();
        if !(fov_rad.is_finite() && fov_rad > 0.0 && fov_rad <= std::f64::consts::TAU + 1e-12) {
            return Err(invalid(
                Table::Named("lidar"),
                "fov_deg",
                format!("must be in (0, 360] degrees, got {}", lidar_table.fov_deg),
            ));
        }
        if !(lidar_table.max_range.is_finite() && lidar_table.max_range > crate::lidar::RANGE_MIN_M)
        {
            return Err(invalid(
                Table::Named("lidar"),
                "max_range",
                format!(
                    "must be a finite range above {} m, got {}",
                    crate::lidar::RANGE_MIN_M,
                    lidar_table.max_range
                ),
            ));
        }
        let o = odometry_table;
        let noise_keys = [
            ("trans_noise", o.trans_noise),
            ("rot_noise", o.rot_noise),
            ("trans_bias", o.trans_bias),
            ("rot_bias", o.rot_bias),
            ("seed", o.seed.map(|s| s as f64)),
        ];
        let odometry_source = match o.source.as_deref() {
            None | Some("drift") => OdometrySource::Drift,
            Some("log") => OdometrySource::Log,
            Some(other) => {
                return Err(invalid(
                    Table::Named("odometry"),
                    "source",
                    format!("must be \"drift\" or \"log\", got {other:?}"),
                ));
            }
        };
        match odometry_source {
            OdometrySource::Drift => {
                if let Some((key, _)) = noise_keys.iter().find(|(_, v)| v.is_none()) {
                    return Err(invalid(
                        Table::Named("odometry"),
                        key,
                        "is missing (it is required unless source = \"log\")".into(),
                    ));
                }
            }
            OdometrySource::Log => {
                if let Some((key, _)) = noise_keys.iter().find(|(_, v)| v.is_some()) {
                    return Err(invalid(
                        Table::Named("odometry"),
                        key,
                        "does not apply with source = \"log\": the log's odometry is replayed \
                         as it is"
                            .into(),
                    ));
                }
            }
        }
        let odometry = OdometryConfig {
            rate_hz: 0.0,
            trans_noise: o.trans_noise.unwrap_or(0.0),
            rot_noise: o.rot_noise.unwrap_or(0.0),
            trans_bias: o.trans_bias.unwrap_or(0.0),
            rot_bias: o.rot_bias.unwrap_or(0.0),
        };
        if let Err(p) = odometry.validate_noise() {
            return Err(invalid(Table::Named("odometry"), p.key, p.message));
        }
        let mut sketches: Vec<SketchConfig> = Vec::with_capacity(raw.sketch.len());
        for (index, table) in raw.sketch.iter().enumerate() {
            let sketch = table.resolve(file, source, index)?;
            if sketches.iter().any(|s| s.name == sketch.name) {
                return Err(invalid(
                    Table::Array("sketch", index),
                    "name",
                    format!("sketch name {:?} is used twice", sketch.name),
                ));
            }
            sketches.push(sketch);
        }
        Ok(Dataset {
            name: raw.name,
            dir,
            log,
            bag,
            relations,
            relations_time_offset_s: raw.relations_time_offset,
            lidar: DatasetLidar {
                fov_rad,
                max_range_m: lidar_table.max_range,
            },
            odometry_source,
            odometry,
            seed: o.seed.unwrap_or(0),
            sketches,
        })
    }

    /// The sketch called `name`, if any.
    pub fn sketch(&self, name: &str) -> Option<&SketchConfig> {
        self.sketches.iter().find(|s| s.name == name)
    }

    /// True when the log's poses are a reference trajectory (corrected poses), so an ATE
    /// against them means something.
    pub fn has_reference_poses(&self) -> bool {
        self.odometry_source == OdometrySource::Drift
    }
}

// ---------------------------------------------------------------------------------------
// The file as written.

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct DatasetFile {
    name: String,
    #[serde(default)]
    log: Option<PathBuf>,
    #[serde(default)]
    bag: Option<PathBuf>,
    #[serde(default)]
    scan_topic: Option<String>,
    #[serde(default)]
    odom_topic: Option<String>,
    #[serde(default)]
    base_frame: Option<String>,
    #[serde(default)]
    relations: Option<PathBuf>,
    #[serde(default)]
    relations_time_offset: f64,
    #[serde(default)]
    lidar: Option<LidarTable>,
    #[serde(default)]
    odometry: Option<OdometryTable>,
    #[serde(default)]
    sketch: Vec<SketchTable>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct LidarTable {
    fov_deg: f64,
    max_range: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct OdometryTable {
    #[serde(default)]
    source: Option<String>,
    #[serde(default)]
    trans_noise: Option<f64>,
    #[serde(default)]
    rot_noise: Option<f64>,
    #[serde(default)]
    trans_bias: Option<f64>,
    #[serde(default)]
    rot_bias: Option<f64>,
    #[serde(default)]
    seed: Option<u64>,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp_dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("sketchslam-ds-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    const TEXT: &str = "name = \"t\"\nlog = \"x.log\"\n[lidar]\nfov_deg = 180.0\nmax_range = 50.0\n\
        [odometry]\ntrans_noise = 0.05\nrot_noise = 0.05\ntrans_bias = 0.02\nrot_bias = 0.02\nseed = 5\n";

    #[test]
    fn loads_a_minimal_dataset_and_rejects_bad_values() {
        let dir = temp_dir("min");
        std::fs::write(dir.join("x.log"), "ODOM 0 0 0 0 0 0 0 h 0\n").unwrap();
        std::fs::write(dir.join(DATASET_FILE), TEXT).unwrap();
        let d = Dataset::load(&dir).unwrap();
        assert_eq!(d.name, "t");
        assert!((d.lidar.fov_rad - std::f64::consts::PI).abs() < 1e-12);
        assert_eq!(d.seed, 5);
        assert!(d.relations.is_none());

        let file = dir.join(DATASET_FILE);
        let e = Dataset::from_toml(&TEXT.replace("fov_deg = 180.0", "fov_deg = -1"), &file)
            .unwrap_err()
            .to_string();
        assert!(e.contains(":4:") && e.contains("lidar.fov_deg"), "{e}");
        let e = Dataset::from_toml(&format!("{TEXT}bogus = 1\n"), &file)
            .unwrap_err()
            .to_string();
        assert!(e.contains("bogus"), "{e}");
        let e = Dataset::from_toml(&TEXT.replace("x.log", "missing.log"), &file)
            .unwrap_err()
            .to_string();
        assert!(e.contains(":2:") && e.contains("`log`"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn raw_odometry_is_source_log_without_noise_keys() {
        let dir = temp_dir("raw");
        std::fs::write(dir.join("x.log"), "ODOM 0 0 0 0\n").unwrap();
        let file = dir.join(DATASET_FILE);
        let noise =
            "trans_noise = 0.05\nrot_noise = 0.05\ntrans_bias = 0.02\nrot_bias = 0.02\nseed = 5\n";
        let raw = TEXT.replace(noise, "source = \"log\"\n");
        let d = Dataset::from_toml(&raw, &file).unwrap();
        assert_eq!(d.odometry_source, OdometrySource::Log);
        assert!(!d.has_reference_poses());
        assert_eq!(d.odometry.trans_noise, 0.0);
        // The default is drift, which needs every noise key...
        let d = Dataset::from_toml(TEXT, &file).unwrap();
        assert_eq!(d.odometry_source, OdometrySource::Drift);
        let e = Dataset::from_toml(&TEXT.replace("seed = 5\n", ""), &file)
            .unwrap_err()
            .to_string();
        assert!(e.contains("odometry.seed") && e.contains("missing"), "{e}");
        // ...and raw odometry takes none of them.
        let e = Dataset::from_toml(&raw.replace("source", "seed = 1\nsource"), &file)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("odometry.seed") && e.contains("does not apply"),
            "{e}"
        );
        let e = Dataset::from_toml(&raw.replace("\"log\"", "\"wheels\""), &file)
            .unwrap_err()
            .to_string();
        assert!(e.contains("odometry.source") && e.contains("wheels"), "{e}");
    }
}
