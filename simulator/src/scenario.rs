//! Scenario folders: `scenario.toml` (see docs/architecture.md, "Files, and how a run is
//! scored"), the truth world image and the sketches, loaded and checked into a
//! [`Scenario`].
//!
//! This is the simulator's input: [`crate::simulation::Simulation`] runs a scenario, the
//! renderer draws one, and the multi-process tests hand the sketches to the service. Files
//! hold degrees; a `Scenario` holds radians. Every table rejects unknown keys, and every
//! problem comes back as a [`SimError`] naming the file, the key and the line — a scenario
//! is written by hand, so a silent default or a panic would cost someone an afternoon.
//!
//! The per-table configs ([`LidarConfig`], [`OdometryConfig`], [`SketchConfig`]) are plain
//! values with their own `validate`, so a log replay (`dataset.toml`) can reuse them and the
//! same noise model.

use crate::error::SimError;
use crate::toml_file::{self, Ctx, Table};
use crate::world::{self, World};
use serde::Deserialize;
use sketchslam_types::{Point2, Pose2, wrap_angle};
use std::path::{Path, PathBuf};

/// The file a scenario folder must hold.
pub const SCENARIO_FILE: &str = "scenario.toml";

/// A loaded and checked scenario. Angles in radians, lengths in meters, paths absolute.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    /// The scenario's name.
    pub name: String,
    /// Seed every random draw of a run derives from.
    pub seed: u64,
    /// The scenario folder (absolute).
    pub dir: PathBuf,
    /// The truth world.
    pub world: WorldConfig,
    /// The robot and its path.
    pub robot: RobotConfig,
    /// The LiDAR model.
    pub lidar: LidarConfig,
    /// The wheel-odometry model.
    pub odometry: OdometryConfig,
    /// The hand-drawn maps, in file order.
    pub sketches: Vec<SketchConfig>,
}

/// `[world]`: the truth image and its scale.
#[derive(Debug, Clone, PartialEq)]
pub struct WorldConfig {
    /// Absolute path of the truth image (dark pixels < 128 are walls).
    pub image: PathBuf,
    /// Meters per pixel.
    pub resolution_m: f64,
}

/// `[robot]`: where the robot starts and the waypoints it drives through.
#[derive(Debug, Clone, PartialEq)]
pub struct RobotConfig {
    /// Start pose in the world frame.
    pub start: Pose2,
    /// Waypoints in the world frame, driven in order.
    pub path: Vec<Point2>,
    /// Speed on straight legs, m/s.
    pub speed_m_s: f64,
    /// Turn rate when turning on the spot, rad/s.
    pub turn_rate_rad_s: f64,
}

/// `[lidar]`: a planar scanner, at the robot's centre facing its heading unless `mount`
/// says otherwise.
#[derive(Debug, Clone, PartialEq)]
pub struct LidarConfig {
    /// Scans per second.
    pub rate_hz: f64,
    /// Field of view, radians in (0, 2π].
    pub fov_rad: f64,
    /// Beams per scan, at least 2.
    pub beams: usize,
    /// Range cap: beyond it there is no return (reported as +inf), meters.
    pub max_range_m: f64,
    /// Standard deviation of the Gaussian range noise, meters.
    pub range_noise_m: f64,
    /// Where the scanner sits on the robot: its pose in the robot frame (forward, left,
    /// yaw); the file's `mount = [x_m, y_m, yaw_deg]`, default at the centre.
    pub mount: Pose2,
}

/// `[odometry]`: the wheel-odometry error model (see [`crate::odometry`]).
#[derive(Debug, Clone, PartialEq)]
pub struct OdometryConfig {
    /// Readings per second.
    pub rate_hz: f64,
    /// Standard deviation of the distance error per √meter travelled (sd after D meters is
    /// `trans_noise·√D`), meters/√meter.
    pub trans_noise: f64,
    /// Standard deviation of the heading error per √radian turned, radians/√radian.
    pub rot_noise: f64,
    /// Systematic scale error of travelled distance (0.02 = 2 % too long).
    pub trans_bias: f64,
    /// Systematic scale error of turned angle.
    pub rot_bias: f64,
}

/// `[[sketch]]`: a hand-drawn map and the start a person marked on it.
#[derive(Debug, Clone, PartialEq)]
pub struct SketchConfig {
    /// The sketch's name, unique in its scenario.
    pub name: String,
    /// Absolute path of the image (PNG or JPEG).
    pub image: PathBuf,
    /// Start column, pixels from the left.
    pub start_u_px: f64,
    /// Start row, pixels from the top.
    pub start_v_px: f64,
    /// Start heading, radians counter-clockwise from the image's +u axis.
    pub start_heading_rad: f64,
    /// The person's guess of the drawing's scale, meters per pixel.
    pub meters_per_pixel: f64,
}

/// One problem found by a config's `validate`: the key inside its table and what is wrong.
#[derive(Debug, Clone, PartialEq)]
pub struct ConfigProblem {
    /// The key inside the table, e.g. `rate_hz`.
    pub key: &'static str,
    /// What is wrong.
    pub message: String,
}

fn positive(key: &'static str, value: f64, unit: &str) -> Result<(), ConfigProblem> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(ConfigProblem {
            key,
            message: format!("must be a positive finite number ({unit}), got {value}"),
        })
    }
}

fn non_negative(key: &'static str, value: f64, unit: &str) -> Result<(), ConfigProblem> {
    if value.is_finite() && value >= 0.0 {
        Ok(())
    } else {
        Err(ConfigProblem {
            key,
            message: format!("must be a finite number >= 0 ({unit}), got {value}"),
        })
    }
}

fn scale_bias(key: &'static str, value: f64) -> Result<(), ConfigProblem> {
    if value.is_finite() && value > -1.0 {
        Ok(())
    } else {
        Err(ConfigProblem {
            key,
            message: format!(
                "must be a finite scale error above -1 (0.02 = 2 % too much), got {value}"
            ),
        })
    }
}

impl LidarConfig {
    /// Checks the values; keys in the error are the file's (`fov_deg`, `max_range`, ...).
    pub fn validate(&self) -> Result<(), ConfigProblem> {
        positive("rate_hz", self.rate_hz, "Hz")?;
        let fov_deg = self.fov_rad.to_degrees();
        if !(self.fov_rad.is_finite()
            && self.fov_rad > 0.0
            && self.fov_rad <= std::f64::consts::TAU + 1e-12)
        {
            return Err(ConfigProblem {
                key: "fov_deg",
                message: format!("must be in (0, 360] degrees, got {fov_deg}"),
            });
        }
        if self.beams < 2 {
            return Err(ConfigProblem {
                key: "beams",
                message: format!("must be at least 2, got {}", self.beams),
            });
        }
        positive("max_range", self.max_range_m, "meters")?;
        if self.max_range_m <= crate::lidar::RANGE_MIN_M {
            return Err(ConfigProblem {
                key: "max_range",
                message: format!(
                    "must exceed the minimum range {} m, got {}",
                    crate::lidar::RANGE_MIN_M,
                    self.max_range_m
                ),
            });
        }
        non_negative("range_noise", self.range_noise_m, "meters")?;
        let m = self.mount;
        // A scanner is on the robot: within a few meters of its centre, yaw within a turn.
        if !(m.is_finite() && m.x.abs() <= 5.0 && m.y.abs() <= 5.0)
            || m.heading_rad.abs() > std::f64::consts::TAU + 1e-12
        {
            return Err(ConfigProblem {
                key: "mount",
                message: format!(
                    "must be [x_m, y_m, yaw_deg] with |x|, |y| ≤ 5 m and |yaw| ≤ 360°, got [{}, {}, {}]",
                    m.x,
                    m.y,
                    m.heading_rad.to_degrees()
                ),
            });
        }
        Ok(())
    }
}

impl OdometryConfig {
    /// Checks the values; keys in the error are the file's.
    pub fn validate(&self) -> Result<(), ConfigProblem> {
        positive("rate_hz", self.rate_hz, "Hz")?;
        self.validate_noise()
    }

    /// Checks only the noise model (for a log replay, whose rate is the log's).
    pub fn validate_noise(&self) -> Result<(), ConfigProblem> {
        non_negative("trans_noise", self.trans_noise, "meters per sqrt(meter)")?;
        non_negative("rot_noise", self.rot_noise, "radians per sqrt(radian)")?;
        scale_bias("trans_bias", self.trans_bias)?;
        scale_bias("rot_bias", self.rot_bias)
    }
}

impl Scenario {
    /// Loads and checks `dir/scenario.toml`, its world image and its sketches.
    ///
    /// Checks: unknown, missing or mistyped keys; positive resolution, speed, turn rate and
    /// rates; at least 2 beams; a field of view in (0, 360]; non-negative noises; finite
    /// numbers; images that exist and decode; a start inside the world and in free space;
    /// every straight path leg free of walls; sketch starts finite and on their image;
    /// unique sketch names.
    pub fn load(dir: &Path) -> Result<Scenario, SimError> {
        let dir = std::fs::canonicalize(dir)
            .or_else(|_| std::path::absolute(dir))
            .unwrap_or_else(|_| dir.to_path_buf());
        let file = dir.join(SCENARIO_FILE);
        let source = toml_file::read(&file)?;
        Scenario::from_toml(&source, &file)
    }

    /// Parses and checks scenario text as if it were the file `file`; relative image paths
    /// are taken from `file`'s folder.
    pub fn from_toml(source: &str, file: &Path) -> Result<Scenario, SimError> {
        let ctx = Ctx { file, source };
        let raw: ScenarioFile = ctx.deserialize()?;
        let dir = file.parent().unwrap_or(Path::new(".")).to_path_buf();
        raw.check(&ctx, dir)
    }

    /// The sketch called `name`, if any.
    pub fn sketch(&self, name: &str) -> Option<&SketchConfig> {
        self.sketches.iter().find(|s| s.name == name)
    }

    /// Loads the truth world (decodes the image again).
    pub fn load_world(&self) -> Result<World, SimError> {
        world::load_for(
            &self.dir.join(SCENARIO_FILE),
            None,
            &self.world.image,
            self.world.resolution_m,
        )
    }
}

// ---------------------------------------------------------------------------------------
// The file as written.

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ScenarioFile {
    name: String,
    seed: u64,
    world: WorldTable,
    robot: RobotTable,
    lidar: LidarTable,
    odometry: OdometryTable,
    #[serde(default)]
    sketch: Vec<SketchTable>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct WorldTable {
    image: PathBuf,
    resolution: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RobotTable {
    start: [f64; 3],
    path: Vec<[f64; 2]>,
    speed: f64,
    turn_rate: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct LidarTable {
    rate_hz: f64,
    fov_deg: f64,
    beams: usize,
    max_range: f64,
    range_noise: f64,
    /// `[x_m, y_m, yaw_deg]`: the scanner's pose on the robot.
    #[serde(default)]
    mount: Option<[f64; 3]>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct OdometryTable {
    rate_hz: f64,
    trans_noise: f64,
    rot_noise: f64,
    trans_bias: f64,
    rot_bias: f64,
}

/// `[[sketch]]` as written; public so that a `dataset.toml` loader can reuse it.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SketchTable {
    /// The sketch's name.
    pub name: String,
    /// Image path, relative to the file's folder.
    pub image: PathBuf,
    /// `[u_px, v_px, heading_deg]`.
    pub start: [f64; 3],
    /// Scale guess, meters per pixel.
    pub meters_per_pixel: f64,
}

impl SketchTable {
    /// Resolves and checks the `index`-th `[[sketch]]` of `file` (relative images are taken
    /// from `file`'s folder): the image exists and decodes, the start is finite and on the
    /// image, the scale is positive.
    pub fn resolve(
        &self,
        file: &Path,
        source: &str,
        index: usize,
    ) -> Result<SketchConfig, SimError> {
        let ctx = Ctx { file, source };
        let dir = file.parent().unwrap_or(Path::new("."));
        let table = Table::Array("sketch", index);
        if self.name.trim().is_empty() {
            return Err(ctx.invalid(table, "name", "must not be empty".into()));
        }
        let image = dir.join(&self.image);
        let luma = world::decode_luma(&image).map_err(|e| SimError::Image {
            file: file.to_path_buf(),
            line: ctx.key_line(table, "image"),
            key: table.key("image"),
            image: image.clone(),
            message: e.to_string(),
        })?;
        let [u, v, heading_deg] = self.start;
        if !(u.is_finite() && v.is_finite() && heading_deg.is_finite()) {
            return Err(ctx.invalid(
                table,
                "start",
                format!("sketch {:?}: [u, v, heading_deg] must be finite numbers, got [{u}, {v}, {heading_deg}]", self.name),
            ));
        }
        let (w, h) = (luma.width() as f64, luma.height() as f64);
        if !(0.0..w).contains(&u) || !(0.0..h).contains(&v) {
            return Err(ctx.invalid(
                table,
                "start",
                format!(
                    "sketch {:?}: start pixel ({u}, {v}) is outside the {w}x{h} image",
                    self.name
                ),
            ));
        }
        if let Err(p) = positive("meters_per_pixel", self.meters_per_pixel, "meters") {
            return Err(ctx.invalid(table, p.key, p.message));
        }
        Ok(SketchConfig {
            name: self.name.clone(),
            image,
            start_u_px: u,
            start_v_px: v,
            start_heading_rad: wrap_angle(heading_deg.to_radians()),
            meters_per_pixel: self.meters_per_pixel,
        })
    }
}

impl ScenarioFile {
    fn check(self, ctx: &Ctx<'_>, dir: PathBuf) -> Result<Scenario, SimError> {
        if self.name.trim().is_empty() {
            return Err(ctx.invalid(Table::Root, "name", "must not be empty".into()));
        }

        // [world]
        let w = Table::Named("world");
        if let Err(p) = positive("resolution", self.world.resolution, "meters per pixel") {
            return Err(ctx.invalid(w, p.key, p.message));
        }
        let world_image = dir.join(&self.world.image);
        let world = world::load_for(
            ctx.file,
            ctx.key_line(w, "image"),
            &world_image,
            self.world.resolution,
        )?;

        // [robot]
        let robot = self.robot.check(ctx, &world)?;

        // [lidar]
        let lidar = LidarConfig {
            rate_hz: self.lidar.rate_hz,
            fov_rad: self.lidar.fov_deg.to_radians(),
            beams: self.lidar.beams,
            max_range_m: self.lidar.max_range,
            range_noise_m: self.lidar.range_noise,
            mount: self.lidar.mount.map_or(Pose2::IDENTITY, |[x, y, yaw_deg]| {
                Pose2::new(x, y, yaw_deg.to_radians())
            }),
        };
        if let Err(p) = lidar.validate() {
            return Err(ctx.invalid(Table::Named("lidar"), p.key, p.message));
        }

        // [odometry]
        let o = &self.odometry;
        let odometry = OdometryConfig {
            rate_hz: o.rate_hz,
            trans_noise: o.trans_noise,
            rot_noise: o.rot_noise,
            trans_bias: o.trans_bias,
            rot_bias: o.rot_bias,
        };
        if let Err(p) = odometry.validate() {
            return Err(ctx.invalid(Table::Named("odometry"), p.key, p.message));
        }

        // [[sketch]]
        let mut sketches: Vec<SketchConfig> = Vec::with_capacity(self.sketch.len());
        for (index, table) in self.sketch.iter().enumerate() {
            let sketch = table.resolve(ctx.file, ctx.source, index)?;
            if sketches.iter().any(|s| s.name == sketch.name) {
                return Err(ctx.invalid(
                    Table::Array("sketch", index),
                    "name",
                    format!("sketch name {:?} is used twice", sketch.name),
                ));
            }
            sketches.push(sketch);
        }

        Ok(Scenario {
            name: self.name,
            seed: self.seed,
            dir,
            world: WorldConfig {
                image: world_image,
                resolution_m: self.world.resolution,
            },
            robot,
            lidar,
            odometry,
            sketches,
        })
    }
}

impl RobotTable {
    fn check(&self, ctx: &Ctx<'_>, world: &World) -> Result<RobotConfig, SimError> {
        let t = Table::Named("robot");
        let [x, y, heading_deg] = self.start;
        if !(x.is_finite() && y.is_finite() && heading_deg.is_finite()) {
            return Err(ctx.invalid(
                t,
                "start",
                format!(
                    "[x, y, heading_deg] must be finite numbers, got [{x}, {y}, {heading_deg}]"
                ),
            ));
        }
        let start = Pose2::new(x, y, heading_deg.to_radians());
        let (w_m, h_m) = world.size_m();
        if !world.contains(start.position()) {
            return Err(ctx.invalid(
                t,
                "start",
                format!("({x}, {y}) is outside the world, which spans [0, {w_m}) x [0, {h_m}) m"),
            ));
        }
        if world.is_wall(start.position()) {
            return Err(ctx.invalid(
                t,
                "start",
                format!("({x}, {y}) is inside a wall of the world image"),
            ));
        }
        if self.path.is_empty() {
            return Err(ctx.invalid(t, "path", "needs at least one waypoint".into()));
        }
        let mut path = Vec::with_capacity(self.path.len());
        for (k, &[px, py]) in self.path.iter().enumerate() {
            if !(px.is_finite() && py.is_finite()) {
                return Err(ctx.invalid(
                    t,
                    "path",
                    format!("waypoint {k} must be finite numbers, got [{px}, {py}]"),
                ));
            }
            path.push(Point2::new(px, py));
        }
        // Leg k runs from waypoint k-1 (the start for k = 0) to waypoint k.
        let mut from = start.position();
        for (k, &to) in path.iter().enumerate() {
            if let Some(hit) = world.segment_hits_wall(from, to) {
                let what = if world.contains(hit) {
                    "runs into a wall"
                } else {
                    "leaves the world"
                };
                return Err(ctx.invalid(
                    t,
                    "path",
                    format!(
                        "leg {k} from ({:.2}, {:.2}) to ({:.2}, {:.2}) {what} at ({:.2}, {:.2})",
                        from.x, from.y, to.x, to.y, hit.x, hit.y
                    ),
                ));
            }
            from = to;
        }
        if let Err(p) = positive("speed", self.speed, "m/s") {
            return Err(ctx.invalid(t, p.key, p.message));
        }
        if let Err(p) = positive("turn_rate", self.turn_rate, "deg/s") {
            return Err(ctx.invalid(t, p.key, p.message));
        }
        Ok(RobotConfig {
            start,
            path,
            speed_m_s: self.speed,
            turn_rate_rad_s: self.turn_rate.to_radians(),
        })
    }
}
