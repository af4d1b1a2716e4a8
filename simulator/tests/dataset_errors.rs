//! Bad `dataset.toml` files give the same errors as bad scenarios (one loader and key
//! locator): the file, the dotted key and the line where it is written.

use sketchslam_simulator::SimError;
use sketchslam_simulator::dataset::{DATASET_FILE, Dataset};
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

static COUNTER: AtomicUsize = AtomicUsize::new(0);

const GOOD: &str = r#"# A recorded log (comments may hold "key = value" too).
name = "test-log"
log = "x.log"

[lidar]
fov_deg = 180.0
max_range = 50.0

[odometry]
trans_noise = 0.05
rot_noise = 0.05
trans_bias = 0.02
rot_bias = 0.02
seed = 5

[[sketch]]
name = "S"
image = "sketch.png"
start = [10.0, 30.0, 0.0]
meters_per_pixel = 0.1
"#;

/// A fresh dataset folder with a log, a sketch and GOOD (`from` replaced by `to`) as
/// `dataset.toml`; the error text of loading it and the file's path.
fn error_for(from: &str, to: &str) -> (SimError, String, PathBuf) {
    assert!(GOOD.contains(from), "test bug: {from:?} not in the file");
    let dir = std::env::temp_dir().join(format!(
        "sketchslam-dataset-test-{}-{}",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("x.log"), "ODOM 0 0 0 0 0 0 0 h 0\n").unwrap();
    let sketch =
        image::GrayImage::from_fn(50, 40, |u, _| image::Luma([if u == 5 { 0 } else { 255 }]));
    sketch.save(dir.join("sketch.png")).unwrap();
    std::fs::write(dir.join(DATASET_FILE), GOOD.replacen(from, to, 1)).unwrap();
    let err = Dataset::load(&dir).expect_err("the dataset should be rejected");
    let text = err.to_string();
    let file = std::fs::canonicalize(&dir).unwrap().join(DATASET_FILE);
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
fn a_wrong_key_is_named_with_its_line() {
    let (err, text, _) = error_for("max_range = 50.0", "max_rang = 50.0");
    assert!(matches!(err, SimError::Parse { .. }), "{err:?}");
    assert_mentions(
        &text,
        &["lidar.max_rang", "unknown field `max_rang`", ":7:"],
    );
}

#[test]
fn a_wrong_type_and_a_missing_key_are_named() {
    let (_, text, _) = error_for("seed = 5", "seed = \"five\"");
    assert_mentions(&text, &["odometry.seed", ":14:"]);
    let (_, text, _) = error_for("rot_bias = 0.02\n", "");
    assert_mentions(&text, &["key `odometry.rot_bias`", "missing"]);
}

#[test]
fn bad_values_are_named_with_their_line() {
    let (err, text, _) = error_for("fov_deg = 180.0", "fov_deg = 400.0");
    assert!(matches!(err, SimError::Invalid { .. }), "{err:?}");
    assert_mentions(&text, &["key `lidar.fov_deg`", ":6:", "(0, 360]"]);
    let (_, text, _) = error_for("trans_noise = 0.05", "trans_noise = -1.0");
    assert_mentions(&text, &["key `odometry.trans_noise`", ":10:"]);
    let (_, text, _) = error_for("log = \"x.log\"", "log = \"y.log\"");
    assert_mentions(&text, &["key `log`", ":3:", "y.log"]);
    let (_, text, _) = error_for("start = [10.0, 30.0, 0.0]", "start = [99.0, 30.0, 0.0]");
    assert_mentions(&text, &["key `sketch[0].start`", ":19:", "outside"]);
}

#[test]
fn duplicate_sketch_names_are_named_with_their_line() {
    let twice = "meters_per_pixel = 0.1\n\n[[sketch]]\nname = \"S\"\nimage = \"sketch.png\"\n\
                 start = [10.0, 30.0, 0.0]\nmeters_per_pixel = 0.1\n";
    let (_, text, _) = error_for("meters_per_pixel = 0.1\n", twice);
    assert_mentions(&text, &["key `sketch[1].name`", ":23:", "twice"]);
}
