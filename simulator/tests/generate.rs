//! `simulator generate`: generated folders load, their routes are clear and in range, the
//! same seed gives the same bytes, and the drawings are where `sketch-truth.toml` says.
//!
//! The drawing checks re-implement the sketch-truth formula here (as
//! `tests/src/sketch_truth.rs` does, which this crate cannot depend on) from the file as
//! written, and look for dark stroke pixels in the image files as written.

use serde::Deserialize;
use sketchslam_simulator::generate::{GenerateOptions, GeneratedWorld, Kind, LidarGrade, generate};
use sketchslam_simulator::{Scenario, Simulation, World};
use sketchslam_types::{Point2, Pose2, wrap_angle};
use std::path::{Path, PathBuf};

/// A fresh folder under the system's temp dir, removed on drop.
struct TempDir(PathBuf);

impl TempDir {
    fn new(tag: &str) -> TempDir {
        let dir = std::env::temp_dir().join(format!("sketchslam-gen-{}-{tag}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        TempDir(dir)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn make(seed: u64, kind: Kind, lidar: LidarGrade, dir: &Path) -> GeneratedWorld {
    generate(&GenerateOptions { seed, kind, lidar }, dir)
        .unwrap_or_else(|e| panic!("seed {seed} {kind} {lidar}: {e}"))
}

/// The closest any leg comes to a wall cell, meters (legs sampled every 2 cm).
fn route_clearance_m(scenario: &Scenario, world: &World) -> f64 {
    let r = world.resolution_m();
    let reach = (0.5 / r).ceil() as i64;
    let mut closest = f64::INFINITY;
    let mut from = scenario.robot.start.position();
    for &to in &scenario.robot.path {
        let n = (from.distance(&to) / 0.02).ceil().max(1.0) as usize;
        for s in 0..=n {
            let t = s as f64 / n as f64;
            let p = Point2::new(from.x + t * (to.x - from.x), from.y + t * (to.y - from.y));
            let (ci, cj) = ((p.x / r).floor() as i64, (p.y / r).floor() as i64);
            for j in cj - reach..=cj + reach {
                for i in ci - reach..=ci + reach {
                    if world.is_wall_cell(i, j) {
                        let dx = (i as f64 * r - p.x).max(p.x - (i + 1) as f64 * r).max(0.0);
                        let dy = (j as f64 * r - p.y).max(p.y - (j + 1) as f64 * r).max(0.0);
                        closest = closest.min(dx.hypot(dy));
                    }
                }
            }
        }
        from = to;
    }
    closest
}

fn route_length_m(scenario: &Scenario) -> f64 {
    let mut from = scenario.robot.start.position();
    let mut len = 0.0;
    for &to in &scenario.robot.path {
        len += from.distance(&to);
        from = to;
    }
    len
}

#[test]
fn every_kind_and_grade_loads_with_a_clear_route_in_range() {
    for kind in Kind::CONCRETE {
        for lidar in [LidarGrade::Good, LidarGrade::Cheap] {
            for seed in [1, 7, 23] {
                let tmp = TempDir::new(&format!("{kind}-{lidar}-{seed}"));
                let world = make(seed, kind, lidar, &tmp.0);
                let scenario = Scenario::load(&tmp.0).unwrap();
                assert_eq!(scenario.name, format!("gen-{kind}-{seed}"));
                assert_eq!(scenario.seed, seed);
                let grid = scenario.load_world().unwrap();
                let (w_m, h_m) = grid.size_m();
                let span = w_m.max(h_m);
                assert!(
                    (30.0..=90.0 + 1e-9).contains(&span),
                    "{kind} {seed}: {span} m across"
                );
                let len = route_length_m(&scenario);
                assert!(
                    (150.0..=350.0).contains(&len),
                    "{kind} {seed}: route {len:.1} m"
                );
                assert!((len - world.route.length_m).abs() < 1e-6);
                let sim = Simulation::new(&scenario).unwrap();
                let min_scans = scenario.lidar.rate_hz * len / scenario.robot.speed_m_s;
                assert!(
                    sim.scan_count() as f64 >= min_scans,
                    "{kind} {seed}: {} scans",
                    sim.scan_count()
                );
                let clear = route_clearance_m(&scenario, &grid);
                assert!(
                    clear >= 0.35 - 1e-9,
                    "{kind} {seed}: a leg comes {clear:.3} m from a wall"
                );
                match lidar {
                    LidarGrade::Good => {
                        assert_eq!(scenario.lidar.beams, 1081);
                        assert!([20.0, 40.0].contains(&scenario.lidar.rate_hz));
                        assert!((30.0..=50.0).contains(&scenario.lidar.max_range_m));
                    }
                    LidarGrade::Cheap => {
                        assert!((5.0..=15.0).contains(&scenario.lidar.rate_hz));
                        assert!((5.6..=12.0).contains(&scenario.lidar.max_range_m));
                        let fov_deg = scenario.lidar.fov_rad.to_degrees();
                        assert!((180.0 - 1e-9..=360.0 + 1e-9).contains(&fov_deg));
                        // Steps of 0.5–1.5°.
                        let step_deg = fov_deg / scenario.lidar.beams as f64;
                        assert!((0.49..=1.51).contains(&step_deg), "{step_deg}");
                    }
                }
                assert!((2..=3).contains(&scenario.sketches.len()));
                let turned: Vec<_> = world.drawings.iter().filter(|d| d.photographed).collect();
                assert_eq!(turned.len(), 1, "one photographed drawing per world");
                assert!(turned[0].file_name.ends_with(".jpg"));
                assert!((2.0..=8.0).contains(&turned[0].map.rotate_deg.abs()));
                assert!(tmp.0.join("sketch-truth.toml").is_file());
            }
        }
    }
}

#[test]
fn the_same_seed_gives_the_same_bytes_and_another_seed_another_world() {
    let (a, b, c) = (
        TempDir::new("same-a"),
        TempDir::new("same-b"),
        TempDir::new("other"),
    );
    let options = |seed| GenerateOptions {
        seed,
        kind: Kind::Mixed,
        lidar: LidarGrade::Good,
    };
    generate(&options(42), &a.0).unwrap();
    // Over an older generation with other sketches: the same files come out.
    generate(&options(7), &b.0).unwrap();
    generate(&options(42), &b.0).unwrap();
    generate(&options(43), &c.0).unwrap();
    let names = |d: &TempDir| {
        let mut n: Vec<_> = std::fs::read_dir(&d.0)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        n.sort();
        n
    };
    assert_eq!(names(&a), names(&b));
    let names = names(&a);
    assert!(names.len() >= 5, "{names:?}");
    for name in &names {
        let (x, y) = (
            std::fs::read(a.0.join(name)).unwrap(),
            std::fs::read(b.0.join(name)).unwrap(),
        );
        assert!(x == y, "{name:?} differs between two runs of seed 42");
    }
    let world = |d: &TempDir| std::fs::read(d.0.join("world.png")).unwrap();
    assert_ne!(world(&a), world(&c));
    let toml = |d: &TempDir| std::fs::read_to_string(d.0.join("scenario.toml")).unwrap();
    assert_ne!(toml(&a), toml(&c));
}

#[test]
fn mixed_picks_each_kind_for_some_seed() {
    let kinds: std::collections::HashSet<Kind> = (0..30).map(|s| Kind::Mixed.resolve(s)).collect();
    assert_eq!(kinds.len(), 3, "{kinds:?}");
    for k in [Kind::Office, Kind::Corridor, Kind::Hall, Kind::Mixed] {
        assert_eq!(k.to_string().parse::<Kind>().unwrap(), k);
    }
    for g in [LidarGrade::Good, LidarGrade::Cheap] {
        assert_eq!(g.to_string().parse::<LidarGrade>().unwrap(), g);
    }
    assert!("castle".parse::<Kind>().is_err());
}

// ---------------------------------------------------------------------------------------
// The drawing truth, re-implemented from sketch-truth.toml's header.

#[derive(Deserialize)]
struct TruthFile {
    world_size_m: [f64; 2],
    sketch: Vec<TruthSketch>,
}

#[derive(Deserialize)]
struct TruthSketch {
    name: String,
    fx: Vec<[f64; 2]>,
    fy: Vec<[f64; 2]>,
    meters_per_pixel: f64,
    rotate_deg: f64,
}

fn lerp(knots: &[[f64; 2]], x: f64) -> (f64, f64) {
    let mut k = 0;
    while k + 2 < knots.len() && knots[k + 1][0] <= x {
        k += 1;
    }
    let ([x0, y0], [x1, y1]) = (knots[k], knots[k + 1]);
    let slope = (y1 - y0) / (x1 - x0);
    (y0 + slope * (x - x0), slope)
}

/// `(u, v, heading)` of a world pose on the drawing, by the file's formula.
fn on_drawing(t: &TruthSketch, size: [f64; 2], pose: &Pose2) -> (f64, f64, f64) {
    let s = t.meters_per_pixel;
    let w = (lerp(&t.fx, size[0]).0 / s).ceil() + 20.0;
    let h = (lerp(&t.fy, size[1]).0 / s).ceil() + 20.0;
    let (fx, dfx) = lerp(&t.fx, pose.x);
    let (fy, dfy) = lerp(&t.fy, pose.y);
    let (u, v) = (fx / s + 10.0, h - 10.0 - fy / s);
    let rot = t.rotate_deg.to_radians();
    let heading =
        wrap_angle((dfy * pose.heading_rad.sin()).atan2(dfx * pose.heading_rad.cos()) + rot);
    if rot == 0.0 {
        return (u, v, heading);
    }
    let (c, si) = (rot.cos(), rot.sin());
    // (less a hair, as the evaluation does, so a quarter turn does not add a pixel)
    let (nw, nh) = (
        (w * c.abs() + h * si.abs() - 1e-9).ceil(),
        (w * si.abs() + h * c.abs() - 1e-9).ceil(),
    );
    let (du, dv) = (u - 0.5 * w, v - 0.5 * h);
    (
        0.5 * nw + du * c + dv * si,
        0.5 * nh - du * si + dv * c,
        heading,
    )
}

fn dark_pixel_within(img: &image::GrayImage, u: f64, v: f64, radius_px: f64) -> bool {
    let r = radius_px.ceil() as i64;
    for j in (v.round() as i64 - r)..=(v.round() as i64 + r) {
        for i in (u.round() as i64 - r)..=(u.round() as i64 + r) {
            if i < 0 || j < 0 || i >= img.width() as i64 || j >= img.height() as i64 {
                continue;
            }
            if (i as f64 - u).hypot(j as f64 - v) <= radius_px
                && img.get_pixel(i as u32, j as u32).0[0] < 128
            {
                return true;
            }
        }
    }
    false
}

#[test]
fn drawn_corners_and_marked_starts_are_where_the_sketch_truth_says() {
    let mut photos = 0;
    for kind in Kind::CONCRETE {
        for seed in [3, 11] {
            let tmp = TempDir::new(&format!("truth-{kind}-{seed}"));
            let world = make(seed, kind, LidarGrade::Good, &tmp.0);
            let scenario = Scenario::load(&tmp.0).unwrap();
            let text = std::fs::read_to_string(tmp.0.join("sketch-truth.toml")).unwrap();
            let truth: TruthFile = toml::from_str(&text).unwrap();
            assert_eq!(truth.sketch.len(), scenario.sketches.len());
            for drawing in &world.drawings {
                let t = truth
                    .sketch
                    .iter()
                    .find(|t| t.name == drawing.name)
                    .unwrap();
                let cfg = scenario.sketch(&drawing.name).unwrap();
                let img = image::open(&cfg.image).unwrap().to_luma8();
                photos += usize::from(t.rotate_deg != 0.0);
                // Every drawn corner has ink within 5 px of where the formula puts it.
                assert!(
                    drawing.corners_m.len() >= 4,
                    "{kind} {seed} {}: few corners",
                    drawing.name
                );
                for c in &drawing.corners_m {
                    let (u, v, _) = on_drawing(t, truth.world_size_m, &Pose2::new(c.x, c.y, 0.0));
                    assert!(
                        dark_pixel_within(&img, u, v, 5.0),
                        "{kind} {seed} {}: no stroke within 5 px of corner ({:.2}, {:.2}) at ({u:.1}, {v:.1})",
                        drawing.name,
                        c.x,
                        c.y
                    );
                }
                // The image is the size the formula says.
                let (u_far, v_far, _) =
                    on_drawing(t, truth.world_size_m, &Pose2::new(0.0, 0.0, 0.0));
                assert!(u_far >= 0.0 && v_far < img.height() as f64);
                // The marked start: within 1.5 m-equivalent and 10° of the true start.
                let (u, v, heading) = on_drawing(t, truth.world_size_m, &scenario.robot.start);
                let off_m = (u - cfg.start_u_px).hypot(v - cfg.start_v_px) * t.meters_per_pixel;
                assert!(
                    off_m <= 1.5,
                    "{kind} {seed} {}: start marked {off_m:.2} m off",
                    drawing.name
                );
                let dh = wrap_angle(heading - cfg.start_heading_rad).to_degrees();
                assert!(
                    dh.abs() <= 10.0,
                    "{kind} {seed} {}: heading {dh:.1}° off",
                    drawing.name
                );
            }
        }
    }
    assert_eq!(photos, 6, "one photographed drawing per world");
}

#[test]
fn drawings_are_mostly_paper_with_some_ink() {
    let tmp = TempDir::new("paper");
    let world = make(5, Kind::Office, LidarGrade::Cheap, &tmp.0);
    for d in &world.drawings {
        let img = image::open(tmp.0.join(&d.file_name)).unwrap().to_luma8();
        let dark = img.pixels().filter(|p| p.0[0] < 128).count() as f64;
        let share = dark / (img.width() * img.height()) as f64;
        assert!(
            share > 0.005 && share < 0.25,
            "{}: {:.3} of the pixels are ink",
            d.name,
            share
        );
    }
}
