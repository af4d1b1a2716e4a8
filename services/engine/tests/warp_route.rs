//! The robot's route decides where the walls alone cannot: a partial map of a corridor of
//! same-size rooms, whose shelving, shifted one room along, lies on the drawn wall that
//! closes the corridor. Every wall point stays on a drawn line under that shift and the
//! shelf's go onto one, which outweighs the start mark's 1.75 σ: from the same starts, the
//! walls alone end 8 m off (the map folded towards the corridor's closed end, measured with
//! an empty route). Every such warp walks the robot through the closing wall; with the route
//! the fit holds the map where it is.

use sketchslam_engine::registration::{FitConfig, Similarity, fit_warp};
use sketchslam_engine::sketch::SketchLine;
use sketchslam_types::Point2;

/// Pixels per meter of the drawing (drawn to scale: the truth is the prior).
const SCALE: f64 = 10.0;

/// The rooms' width along the corridor, meters: more than the fit's first gate (3 m), so
/// that the shelf does not pull the fit from the start mark, and within the global search's
/// reach (2 σ of the mark's 2 m), which offers the shifted start.
const PERIOD_M: f64 = 3.5;

/// The floor's walls, meters: a 3 m corridor along x from −21 to 28 m, rooms 3.5 m wide and
/// 3 m deep on both sides with a 1 m door each, the corridor closed at x = 0.
fn floor() -> Vec<((f64, f64), (f64, f64))> {
    let mut walls = vec![
        ((-21.0, -3.0), (28.0, -3.0)),
        ((-21.0, 6.0), (28.0, 6.0)),
        ((0.0, 0.0), (0.0, 3.0)),
    ];
    for k in -6..8 {
        let x = PERIOD_M * f64::from(k);
        // The corridor's walls between the doors, and the rooms' dividers.
        for y in [0.0, 3.0] {
            walls.push(((x - 0.5 * PERIOD_M + 0.5, y), (x + 0.5 * PERIOD_M - 0.5, y)));
        }
        walls.push(((x, -3.0), (x, 0.0)));
        walls.push(((x, 3.0), (x, 6.0)));
    }
    walls
}

/// The drawing of [`floor`], to scale.
fn drawing() -> Vec<SketchLine> {
    // Map meters to image pixels (u, v): u = 10 x + 300, v = −10 y + 200.
    let px = |x: f64, y: f64| Point2::new(SCALE * x + 300.0, -SCALE * y + 200.0);
    floor()
        .iter()
        .enumerate()
        .map(|(i, &((ax, ay), (bx, by)))| SketchLine::new(i, px(ax, ay), px(bx, by)))
        .collect()
}

/// The similarity the drawing was made with: map (x, y) to the drawing frame (u, −v).
fn truth() -> Similarity {
    Similarity::new(SCALE, 0.0, Point2::new(300.0, -200.0))
}

/// The map: the floor's walls from x = 2 to 14 m every 10 cm (the closing wall not seen
/// yet), and shelving across the corridor at x = 3.5 m from y = 0 to 1.2 m, in line with
/// a room's divider.
fn walls() -> Vec<Point2> {
    let mut points = Vec::new();
    for ((ax, ay), (bx, by)) in floor() {
        let n = (f64::hypot(bx - ax, by - ay) / 0.1).round() as usize;
        for i in 0..=n {
            let t = i as f64 / n as f64;
            let p = Point2::new(ax + t * (bx - ax), ay + t * (by - ay));
            if (2.0..=14.0).contains(&p.x) {
                points.push(p);
            }
        }
    }
    for i in 0..=12 {
        points.push(Point2::new(PERIOD_M, 0.1 * f64::from(i)));
    }
    points
}

/// The robot's keyframes: along the corridor's free half, x = 2.5 to 13 m, every 0.5 m.
fn route() -> Vec<Point2> {
    (0..=21)
        .map(|i| Point2::new(2.5 + 0.5 * f64::from(i), 2.3))
        .collect()
}

/// How far along the corridor (x) the fit puts the map from the truth, meters.
fn shift_m(route: &[Point2]) -> f64 {
    let fit = fit_warp(&walls(), route, &drawing(), truth(), &FitConfig::default()).expect("a fit");
    let p = Point2::new(8.0, 1.5);
    (fit.warp.apply(p).x - truth().apply(p).x) / SCALE
}

#[test]
fn the_route_through_the_closing_wall_holds_the_map_where_it_is() {
    let shift = shift_m(&route());
    assert!(
        shift.abs() < 0.3,
        "with the route, expected the map where it is (0 m), got {shift:.2} m"
    );
}
