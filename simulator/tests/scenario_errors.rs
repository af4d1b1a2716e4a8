//! Bad scenario folders give clear errors naming the file, the key and (where it can be
//! found) the line, and never panic. Each test builds its own folder under the system temp
//! directory: a 6 m x 4 m room with a wall hanging from the top at x = 3 m.

use sketchslam_simulator::{Scenario, SimError};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

static COUNTER: AtomicUsize = AtomicUsize::new(0);

const GOOD: &str = r#"name = "test-room"
seed = 3

[world]
image = "world.png"
resolution = 0.1

[robot]
start = [1.0, 1.0, 0.0]
path = [[5.0, 1.0], [5.0, 3.0]]
speed = 0.5
turn_rate = 90.0

[lidar]
rate_hz = 10.0
fov_deg = 270.0
beams = 181
max_range = 10.0
range_noise = 0.01

[odometry]
rate_hz = 50.0
trans_noise = 0.03
rot_noise = 0.02
trans_bias = 0.02
rot_bias = 0.01

[[sketch]]
name = "S"
image = "sketch.png"
start = [10.0, 30.0, 0.0]
meters_per_pixel = 0.1
"#;

/// A fresh scenario folder with the world, a sketch and `toml` as `scenario.toml`.
fn folder(toml: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "sketchslam-scenario-test-{}-{}",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    // 60 x 40 px at 0.1 m: border walls, and a wall at column 30 from the top to row 25.
    let world = image::GrayImage::from_fn(60, 40, |u, v| {
        let wall = u == 0 || v == 0 || u == 59 || v == 39 || (u == 30 && v < 25);
        image::Luma([if wall { 0 } else { 255 }])
    });
    world.save(dir.join("world.png")).unwrap();
    let sketch =
        image::GrayImage::from_fn(50, 40, |u, _| image::Luma([if u == 5 { 0 } else { 255 }]));
    sketch.save(dir.join("sketch.png")).unwrap();
    std::fs::write(dir.join("scenario.toml"), toml).unwrap();
    dir
}

/// Loads `toml` (GOOD with `from` replaced by `to`) and returns the error text.
fn error_for(from: &str, to: &str) -> (SimError, String, PathBuf) {
    assert!(
        GOOD.contains(from),
        "test bug: {from:?} not in the scenario"
    );
    let dir = folder(&GOOD.replacen(from, to, 1));
    let err = Scenario::load(&dir).expect_err("the scenario should be rejected");
    let text = err.to_string();
    let file = std::fs::canonicalize(&dir).unwrap().join("scenario.toml");
    assert!(
        text.contains(&file.display().to_string()),
        "error does not name the file {}: {text}",
        file.display()
    );
    let _ = std::fs::remove_dir_all(&dir);
    (err, text, file)
}

fn assert_mentions(text: &str, parts: &[&str]) {
    for part in parts {
        assert!(text.contains(part), "{text:?} does not mention {part:?}");
    }
}

#[test]
fn the_good_scenario_loads() {
    let dir = folder(GOOD);
    let s = Scenario::load(&dir).unwrap();
    assert_eq!(s.name, "test-room");
    assert_eq!(s.seed, 3);
    assert!(s.world.image.is_absolute() && s.world.image.ends_with("world.png"));
    assert!((s.robot.turn_rate_rad_s - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    assert!((s.lidar.fov_rad - 1.5 * std::f64::consts::PI).abs() < 1e-12);
    assert_eq!(s.robot.path.len(), 2);
    let sketch = s.sketch("S").unwrap();
    assert!(sketch.image.is_absolute());
    assert_eq!((sketch.start_u_px, sketch.start_v_px), (10.0, 30.0));
    assert!(s.sketch("T").is_none());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_wrong_key_is_named_with_its_line() {
    let (err, text, _) = error_for("speed = 0.5", "sped = 0.5");
    assert_mentions(&text, &["robot.sped", "unknown field `sped`", ":11:"]);
    assert!(
        matches!(err, SimError::Parse { line: Some(11), .. }),
        "{err:?}"
    );
}

#[test]
fn an_unknown_table_is_named() {
    let (_, text, _) = error_for("[lidar]", "[camera]\nfps = 3\n[lidar]");
    assert_mentions(&text, &["camera"]);
}

#[test]
fn a_wrong_type_is_named() {
    let (_, text, _) = error_for("speed = 0.5", "speed = \"fast\"");
    assert_mentions(&text, &["robot.speed", ":11:"]);
}

#[test]
fn a_missing_key_is_named() {
    let (_, text, _) = error_for("turn_rate = 90.0\n", "");
    assert_mentions(&text, &["key `robot.turn_rate`", "missing"]);
    let (_, text, _) = error_for("seed = 3\n", "");
    assert_mentions(&text, &["key `seed`", "missing"]);
}

#[test]
fn a_missing_image_is_named() {
    let (err, text, _) = error_for("image = \"world.png\"", "image = \"nope.png\"");
    assert_mentions(&text, &["world.image", "nope.png", ":5:"]);
    assert!(matches!(err, SimError::Image { .. }), "{err:?}");

    let (_, text, _) = error_for("image = \"sketch.png\"", "image = \"gone.jpg\"");
    assert_mentions(&text, &["sketch[0].image", "gone.jpg"]);
}

#[test]
fn an_image_that_does_not_decode_is_named() {
    let dir = folder(GOOD);
    std::fs::write(dir.join("world.png"), b"not a png at all").unwrap();
    let text = Scenario::load(&dir).unwrap_err().to_string();
    assert_mentions(&text, &["world.image", "world.png", "decode"]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_path_through_a_wall_names_the_leg_and_the_hit() {
    let (err, text, _) = error_for(
        "path = [[5.0, 1.0], [5.0, 3.0]]",
        "path = [[1.0, 3.0], [5.0, 3.0]]",
    );
    assert_mentions(
        &text,
        &[
            "robot.path",
            "leg 1",
            "(1.00, 3.00) to (5.00, 3.00)",
            "at (3.00, 3.00)",
            ":10:",
        ],
    );
    assert!(matches!(err, SimError::Invalid { .. }), "{err:?}");

    let (_, text, _) = error_for("path = [[5.0, 1.0], [5.0, 3.0]]", "path = [[9.0, 1.0]]");
    assert_mentions(&text, &["robot.path", "leg 0"]);
}

#[test]
fn bad_starts_are_named() {
    let (_, text, _) = error_for("start = [1.0, 1.0, 0.0]", "start = [3.05, 3.0, 0.0]");
    assert_mentions(&text, &["robot.start", "inside a wall"]);
    let (_, text, _) = error_for("start = [1.0, 1.0, 0.0]", "start = [-1.0, 1.0, 0.0]");
    assert_mentions(&text, &["robot.start", "outside the world"]);
    let (_, text, _) = error_for("start = [1.0, 1.0, 0.0]", "start = [1.0, nan, 0.0]");
    assert_mentions(&text, &["robot.start", "finite"]);
    let (_, text, _) = error_for("start = [1.0, 1.0, 0.0]", "start = [1.0, 1.0]");
    assert_mentions(&text, &["robot.start"]);
    let (_, text, _) = error_for("start = [10.0, 30.0, 0.0]", "start = [10.0, inf, 0.0]");
    assert_mentions(&text, &["sketch[0].start", "finite"]);
    let (_, text, _) = error_for("start = [10.0, 30.0, 0.0]", "start = [100.0, 30.0, 0.0]");
    assert_mentions(&text, &["sketch[0].start", "outside"]);
}

#[test]
fn bad_numbers_are_named() {
    let cases: &[(&str, &str, &[&str])] = &[
        ("speed = 0.5", "speed = -0.5", &["robot.speed", "positive"]),
        ("turn_rate = 90.0", "turn_rate = 0.0", &["robot.turn_rate"]),
        ("resolution = 0.1", "resolution = 0", &["world.resolution"]),
        ("rate_hz = 10.0", "rate_hz = inf", &["lidar.rate_hz"]),
        (
            "fov_deg = 270.0",
            "fov_deg = 400.0",
            &["lidar.fov_deg", "(0, 360]"],
        ),
        ("fov_deg = 270.0", "fov_deg = 0.0", &["lidar.fov_deg"]),
        ("beams = 181", "beams = 1", &["lidar.beams", "at least 2"]),
        ("beams = 181", "beams = -4", &["lidar.beams"]),
        (
            "range_noise = 0.01",
            "range_noise = -0.01",
            &["lidar.range_noise"],
        ),
        ("max_range = 10.0", "max_range = 0.01", &["lidar.max_range"]),
        (
            "range_noise = 0.01",
            "range_noise = 0.01\nmount = [7.0, 0.0, 0.0]",
            &["lidar.mount", "5 m"],
        ),
        (
            "range_noise = 0.01",
            "range_noise = 0.01\nmount = [0.3, 0.0]",
            &["mount"],
        ),
        ("rate_hz = 50.0", "rate_hz = 0.0", &["odometry.rate_hz"]),
        (
            "trans_noise = 0.03",
            "trans_noise = -1.0",
            &["odometry.trans_noise"],
        ),
        (
            "rot_noise = 0.02",
            "rot_noise = nan",
            &["odometry.rot_noise"],
        ),
        (
            "trans_bias = 0.02",
            "trans_bias = -1.5",
            &["odometry.trans_bias"],
        ),
        (
            "meters_per_pixel = 0.1",
            "meters_per_pixel = 0.0",
            &["sketch[0].meters_per_pixel"],
        ),
        ("seed = 3", "seed = -3", &["seed"]),
        ("name = \"test-room\"", "name = \"\"", &["`name`", "empty"]),
    ];
    for (from, to, parts) in cases {
        let (_, text, _) = error_for(from, to);
        assert_mentions(&text, parts);
    }
}

#[test]
fn duplicate_sketch_names_are_rejected() {
    let extra = "\n[[sketch]]\nname = \"S\"\nimage = \"sketch.png\"\nstart = [1.0, 1.0, 0.0]\nmeters_per_pixel = 0.1\n";
    let dir = folder(&format!("{GOOD}{extra}"));
    let text = Scenario::load(&dir).unwrap_err().to_string();
    assert_mentions(&text, &["sketch[1].name", "twice"]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_missing_folder_or_broken_toml_is_an_error() {
    let text = Scenario::load(Path::new("/definitely/not/here"))
        .unwrap_err()
        .to_string();
    assert_mentions(&text, &["scenario.toml", "cannot read"]);
    let (_, text, _) = error_for("seed = 3", "seed = = 3");
    assert_mentions(&text, &[":2:"]);
}
