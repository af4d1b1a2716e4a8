//! A floor whose two wings a person drew out of proportion with each other: a 48 m corridor
//! of same-size rooms, its west half drawn to scale and its east half 30 % too wide.
//! The best affine map of the whole floor lays one wing right and the other rooms over,
//! beyond every gate of the fit; the search over each region's displacement finds the wing,
//! and the fit from there keeps it.

mod common;

use sketchslam_engine::registration::{FitConfig, Similarity, fit_warp};
use sketchslam_engine::sketch::SketchLine;
use sketchslam_types::Point2;

/// Where the east wing starts, meters.
const WING_X_M: f64 = 24.0;
/// How much wider the east wing is drawn than the west.
const WING_STRETCH: f64 = 1.3;
/// Drawing pixels per meter in the west wing.
const PX_PER_M: f64 = 10.0;

/// The walls, meters: a corridor (y 5 to 7) from x = 0 to 48, rooms 4 m wide and 5 m deep
/// south of it, each with a 1 m door.
fn walls() -> Vec<(Point2, Point2)> {
    let p = Point2::new;
    let mut w = vec![
        (p(0.0, 0.0), p(48.0, 0.0)),
        (p(0.0, 7.0), p(48.0, 7.0)),
        (p(0.0, 0.0), p(0.0, 7.0)),
        (p(48.0, 0.0), p(48.0, 7.0)),
    ];
    for k in 0..12 {
        let x = 4.0 * k as f64;
        w.push((p(x, 5.0), p(x + 1.5, 5.0)));
        w.push((p(x + 2.5, 5.0), p(x + 4.0, 5.0)));
        if k > 0 {
            w.push((p(x, 0.0), p(x, 5.0)));
        }
    }
    w
}

/// How the person drew a world point: drawing frame `(u, −v)` pixels.
fn drawn(p: Point2) -> Point2 {
    let x = if p.x <= WING_X_M {
        p.x
    } else {
        WING_X_M + WING_STRETCH * (p.x - WING_X_M)
    };
    Point2::new(PX_PER_M * x + 20.0, PX_PER_M * p.y - 120.0)
}

/// The drawing's lines, each wall split where the wings meet.
fn drawing() -> Vec<SketchLine> {
    common::drawn_lines(&walls(), WING_X_M, drawn)
}

#[test]
fn a_wing_drawn_30_percent_too_wide_is_found_rooms_over() {
    // The map's frame: the robot started in the west corridor at (2, 6).
    let start = Point2::new(2.0, 6.0);
    let points: Vec<Point2> = walls()
        .into_iter()
        .flat_map(|(a, b)| {
            let n = (a.distance(&b) / 0.05) as usize;
            (0..=n).map(move |i| {
                let t = i as f64 / n as f64;
                Point2::new(
                    a.x + t * (b.x - a.x) - start.x,
                    a.y + t * (b.y - a.y) - start.y,
                )
            })
        })
        .collect();
    // The start marked where it is drawn, the scale guessed right for the west wing.
    let prior = Similarity::new(PX_PER_M, 0.0, drawn(start));
    let fit = fit_warp(&points, &[], &drawing(), prior, &FitConfig::default()).expect("a fit");
    // Every room's corners on the drawn ones within half a meter (the east wing's far end
    // lies 7.2 m, almost two rooms, beyond where the west wing's scale puts it; without the
    // region search the fit leaves a corner 5.3 m off).
    let mut worst_m: f64 = 0.0;
    for k in 0..=12 {
        for y in [0.0, 5.0, 7.0] {
            let corner = Point2::new(4.0 * k as f64, y);
            let map = Point2::new(corner.x - start.x, corner.y - start.y);
            let off_m = fit.warp.apply(map).distance(&drawn(corner)) / PX_PER_M;
            worst_m = worst_m.max(off_m);
        }
    }
    assert!(
        worst_m < 0.5,
        "a corner lies {worst_m:.2} m off its drawn place"
    );
}
