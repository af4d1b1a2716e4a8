//! The world generator behind `simulator generate`: from a seed, a complete scenario
//! folder — a floor plan (`world.png`), a route through it, sensor models, two or three
//! hand-drawn sketches of it (one of them photographed) and `sketch-truth.toml` saying how
//! each was drawn — that [`crate::Scenario::load`] accepts and the evaluation scores.
//!
//! Pipeline: a layout ([`office`], [`corridor`], [`hall`]) builds a [`floor::Floor`] and
//! the tour's stops; [`route`] joins them into legs; [`clutter`] furnishes the floor off the
//! route; [`route::check_clearance`] verifies the legs on the rasterized world (a failing
//! plan is re-drawn from the next sub-seed); [`sensors`] picks the LiDAR and odometry;
//! [`sketches`] decides what each drawing shows, [`drawing`] strokes it through a
//! [`mapping::DrawingMap`], [`photo`] photographs one; [`files`] writes it all, and the folder is loaded back as a check.
//!
//! All randomness comes from `ChaCha8Rng` streams of the seed: the same options give a
//! byte-identical folder.

pub mod clutter;
pub mod corridor;
pub mod drawing;
pub mod files;
pub mod floor;
pub mod hall;
pub mod mapping;
pub mod office;
pub mod photo;
pub mod rect;
pub mod route;
pub mod sensors;
pub mod sketches;

use crate::error::GenerateError;
use crate::scenario::{LidarConfig, OdometryConfig, Scenario};
use floor::{AreaKind, Floor};
use mapping::DrawingMap;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use route::Route;
use sketchslam_types::Point2;
use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

/// Floor plans tried before giving up.
const MAX_ATTEMPTS: u32 = 40;
/// The random stream of the sensors and drawings (floor plan attempts use 0, 1, ...).
const DRAWING_STREAM: u64 = 1 << 32;
/// The random stream that picks a kind for `mixed`.
const KIND_STREAM: u64 = (1 << 32) + 1;

/// What kind of building to generate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Kind {
    /// A corridor lined with rows of same-size rooms.
    Office,
    /// One long corridor with an atrium, a ring and branches.
    Corridor,
    /// Large open halls with pillars and shelving.
    Hall,
    /// One of the three, picked by the seed.
    Mixed,
}

/// Which sensors the robot has.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum LidarGrade {
    /// 20 or 40 Hz, 270°, 1081 beams, 30–50 m, good odometry (like `paper-env1`).
    Good,
    /// 5–15 Hz, 180–360° in 0.5–1.5° steps, 5.6–12 m, worn odometry (like `school`).
    Cheap,
}

/// Error of parsing a [`Kind`] or [`LidarGrade`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown {what} {given:?}; expected one of {expected}")]
pub struct ParseError {
    what: &'static str,
    given: String,
    expected: &'static str,
}

impl Kind {
    /// The three concrete kinds.
    pub const CONCRETE: [Kind; 3] = [Kind::Office, Kind::Corridor, Kind::Hall];

    /// The concrete kind for `seed` (`Mixed` picks one by the seed).
    pub fn resolve(self, seed: u64) -> Kind {
        match self {
            Kind::Mixed => {
                let mut rng = stream(seed, KIND_STREAM);
                Kind::CONCRETE[rng.random_range(0..3)]
            }
            k => k,
        }
    }
}

impl fmt::Display for Kind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Kind::Office => "office",
            Kind::Corridor => "corridor",
            Kind::Hall => "hall",
            Kind::Mixed => "mixed",
        })
    }
}

impl FromStr for Kind {
    type Err = ParseError;
    fn from_str(s: &str) -> Result<Kind, ParseError> {
        match s {
            "office" => Ok(Kind::Office),
            "corridor" => Ok(Kind::Corridor),
            "hall" => Ok(Kind::Hall),
            "mixed" => Ok(Kind::Mixed),
            _ => Err(ParseError {
                what: "kind",
                given: s.into(),
                expected: "office, corridor, hall, mixed",
            }),
        }
    }
}

impl fmt::Display for LidarGrade {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            LidarGrade::Good => "good",
            LidarGrade::Cheap => "cheap",
        })
    }
}

impl FromStr for LidarGrade {
    type Err = ParseError;
    fn from_str(s: &str) -> Result<LidarGrade, ParseError> {
        match s {
            "good" => Ok(LidarGrade::Good),
            "cheap" => Ok(LidarGrade::Cheap),
            _ => Err(ParseError {
                what: "lidar grade",
                given: s.into(),
                expected: "good, cheap",
            }),
        }
    }
}

/// What to generate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GenerateOptions {
    /// Seed of every random draw (and the scenario's `seed`).
    pub seed: u64,
    /// The building.
    pub kind: Kind,
    /// The sensors.
    pub lidar: LidarGrade,
}

/// One generated drawing.
#[derive(Debug, Clone, PartialEq)]
pub struct GeneratedDrawing {
    /// Its name in the scenario ("A", "B", "C").
    pub name: String,
    /// Its file name in the folder.
    pub file_name: String,
    /// How world points land on it.
    pub map: DrawingMap,
    /// Photographed (turned, lit unevenly, blurred, JPEG) rather than scanned.
    pub photographed: bool,
    /// The start a person marked: `[u_px, v_px, heading_deg]`.
    pub start_marked: [f64; 3],
    /// World corners of the floor's rectangles that the drawing shows (stroke ends).
    pub corners_m: Vec<Point2>,
    /// How it was drawn, in words (the scenario's comment).
    pub how: String,
}

/// What [`generate`] wrote.
#[derive(Debug, Clone)]
pub struct GeneratedWorld {
    /// The scenario folder.
    pub dir: PathBuf,
    /// The scenario's name, `gen-<kind>-<seed>`.
    pub name: String,
    /// The concrete kind (`mixed` resolved).
    pub kind: Kind,
    /// The floor plan, clutter included.
    pub floor: Floor,
    /// The robot's route.
    pub route: Route,
    /// The LiDAR model written.
    pub lidar: LidarConfig,
    /// The odometry model written.
    pub odometry: OdometryConfig,
    /// The drawings, in scenario order.
    pub drawings: Vec<GeneratedDrawing>,
}

/// The `k`-th random stream of `seed`.
fn stream(seed: u64, k: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(k);
    rng
}

/// Generates a world for `options` and writes its scenario folder to `out_dir` (created if
/// needed; files of the same names, and sketches of an earlier generation, are replaced). The folder is loaded back with
/// [`Scenario::load`] before returning.
pub fn generate(
    options: &GenerateOptions,
    out_dir: &Path,
) -> Result<GeneratedWorld, GenerateError> {
    let kind = options.kind.resolve(options.seed);
    let (floor, route) = plan(options.seed, kind)?;
    let mut rng = stream(options.seed, DRAWING_STREAM);
    let (lidar, odometry) = sensors::pick(options.lidar, &mut rng);

    files::create_dir(out_dir)?;
    files::remove_old_sketches(out_dir)?;
    files::write_png(&out_dir.join(files::WORLD_FILE), &floor.world_image())?;
    let drawings = sketches::draw_all(&floor, &route, out_dir, &mut rng)?;

    let name = format!("gen-{kind}-{}", options.seed);
    let description = describe(kind, options.lidar, &floor, &route, &lidar);
    let text = files::scenario_toml(
        &name,
        options.seed,
        &description,
        &route,
        &lidar,
        &odometry,
        &drawings,
    );
    files::write_text(&out_dir.join(crate::scenario::SCENARIO_FILE), &text)?;
    let truth = files::sketch_truth_toml([floor.width_m, floor.height_m], &drawings);
    files::write_text(&out_dir.join("sketch-truth.toml"), &truth)?;
    Scenario::load(out_dir).map_err(GenerateError::Check)?;
    Ok(GeneratedWorld {
        dir: out_dir.to_path_buf(),
        name,
        kind,
        floor,
        route,
        lidar,
        odometry,
        drawings,
    })
}

/// A floor plan of `kind` with a checked route, re-drawn from the next sub-seed until one
/// passes.
fn plan(seed: u64, kind: Kind) -> Result<(Floor, Route), GenerateError> {
    let mut last = String::new();
    for attempt in 0..MAX_ATTEMPTS {
        let mut rng = stream(seed, attempt as u64);
        let (mut floor, stops) = match kind {
            Kind::Office | Kind::Mixed => office::build(&mut rng),
            Kind::Corridor => corridor::build(&mut rng),
            Kind::Hall => hall::build(&mut rng),
        };
        let span = floor.width_m.max(floor.height_m);
        if !(30.0..=90.0).contains(&span) {
            last = format!("the world is {span:.1} m across, outside [30, 90] m");
            continue;
        }
        let route = match route::build(&floor, &stops, 0.7, &mut rng) {
            Ok(r) => r,
            Err(e) => {
                last = e;
                continue;
            }
        };
        clutter::place(&mut floor, &route::legs(&route), &mut rng);
        let (w, h) = floor.size_px();
        match route::check_clearance(&route, &floor.wall_grid(), w, h) {
            Ok(()) => return Ok((floor, route)),
            Err(e) => last = e,
        }
    }
    Err(GenerateError::NoRoute {
        seed,
        kind: kind.to_string(),
        attempts: MAX_ATTEMPTS,
        last,
    })
}

/// The one-line description at the top of `scenario.toml`.
fn describe(
    kind: Kind,
    grade: LidarGrade,
    floor: &Floor,
    route: &Route,
    lidar: &LidarConfig,
) -> String {
    let count = |k: AreaKind| floor.areas.iter().filter(|a| a.kind == k).count();
    // Independent loops of the (connected) graph of areas joined by doors and links.
    let loops = (floor.doors.len() + floor.links.len() + 1).saturating_sub(floor.areas.len());
    format!(
        "A generated {kind} floor, {:.0} x {:.0} m: {} corridor pieces, {} rooms, {} meeting rooms, {} halls, {} doors, {loops} loops, {} pieces of clutter no sketch shows; a {:.0} m route that comes back over its way; {grade} LiDAR ({:.0} m, {} beams)",
        floor.width_m,
        floor.height_m,
        count(AreaKind::Corridor),
        count(AreaKind::Room),
        count(AreaKind::MeetingRoom),
        count(AreaKind::Hall),
        floor.doors.len(),
        floor.clutter.len(),
        route.length_m,
        lidar.max_range_m,
        lidar.beams
    )
}
