//! Exact ray casting: ranges worked out by hand in a square room, and agreement with a
//! brute-force fine march in the bundled paper-env1 world.

use sketchslam_simulator::World;
use sketchslam_types::Point2;
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI, SQRT_2};
use std::path::Path;

/// 10 x 10 cells of 0.5 m with a one-cell wall border: free space is [0.5, 4.5]² m.
/// `pillar` adds a wall cell at column 6, row 5 from the top (x in [3, 3.5), y in [2, 2.5)).
fn room(pillar: bool) -> World {
    let mut walls = vec![false; 100];
    for k in 0..10 {
        walls[k] = true; // top row
        walls[90 + k] = true; // bottom row
        walls[10 * k] = true; // left column
        walls[10 * k + 9] = true; // right column
    }
    if pillar {
        walls[10 * 5 + 6] = true;
    }
    World::from_walls(10, 10, 0.5, walls).unwrap()
}

fn assert_range(world: &World, origin: Point2, angle_rad: f64, expected_m: f64) {
    let r = world
        .cast(origin, angle_rad, 100.0)
        .unwrap_or_else(|| panic!("no hit at angle {angle_rad}"));
    assert!(
        (r - expected_m).abs() < 1e-9,
        "angle {angle_rad}: got {r}, expected {expected_m}"
    );
}

#[test]
fn square_room_by_hand() {
    let w = room(false);
    // Off-centre origin: 0.8 m from the left wall, 3.2 m from the right,
    // 1.6 m from the bottom, 2.4 m from the top.
    let o = Point2::new(1.3, 2.1);
    assert_range(&w, o, 0.0, 3.2);
    assert_range(&w, o, PI, 0.8);
    assert_range(&w, o, FRAC_PI_2, 2.4);
    assert_range(&w, o, -FRAC_PI_2, 1.6);
    // Diagonals: the nearer of the two walls along the diagonal, times √2.
    assert_range(&w, o, FRAC_PI_4, 2.4 * SQRT_2);
    assert_range(&w, o, 3.0 * FRAC_PI_4, 0.8 * SQRT_2);
    assert_range(&w, o, -3.0 * FRAC_PI_4, 0.8 * SQRT_2);
    assert_range(&w, o, -FRAC_PI_4, 1.6 * SQRT_2);
    // Direction (0.8, 0.6): 3.2 / 0.8 = 2.4 / 0.6 = 4 m, exactly into the corner (4.5, 4.5).
    assert_range(&w, o, 0.6f64.atan2(0.8), 4.0);
    // Direction (0.6, -0.8): the right wall at 3.2 / 0.6 = 5.33 m, the bottom at
    // 1.6 / 0.8 = 2 m.
    assert_range(&w, o, (-0.8f64).atan2(0.6), 2.0);
    // Angles outside (−π, π] mean the same direction.
    assert_range(&w, o, 2.0 * PI, 3.2);
}

#[test]
fn a_pillar_shadows_the_far_wall() {
    let w = room(true);
    let o = Point2::new(1.3, 2.1);
    // The pillar's left face is at x = 3.0, and y = 2.1 is inside [2, 2.5).
    assert_range(&w, o, 0.0, 1.7);
    // From above the pillar the ray passes over it.
    assert_range(&w, Point2::new(1.3, 2.6), 0.0, 3.2);
    // Straight down onto the pillar's top face at y = 2.5.
    assert_range(&w, Point2::new(3.2, 4.0), -FRAC_PI_2, 1.5);
}

#[test]
fn range_limits_and_degenerate_origins() {
    let w = room(false);
    let o = Point2::new(1.3, 2.1);
    assert_eq!(w.cast(o, 0.0, 3.0), None);
    assert!(w.cast(o, 0.0, 3.2 + 1e-9).is_some());
    // Inside a wall or outside the world: zero range.
    assert_eq!(w.cast(Point2::new(0.2, 2.0), 0.0, 10.0), Some(0.0));
    assert_eq!(w.cast(Point2::new(-3.0, 2.0), 0.0, 10.0), Some(0.0));
    // Non-finite input never panics.
    assert_eq!(w.cast(o, f64::NAN, 10.0), None);
    assert_eq!(w.cast(Point2::new(f64::NAN, 1.0), 0.0, 10.0), Some(0.0));
}

/// Fine march: the first sample at step `step_m` that lies in a wall.
fn march(world: &World, o: Point2, angle_rad: f64, max_m: f64, step_m: f64) -> Option<f64> {
    let (dx, dy) = (angle_rad.cos(), angle_rad.sin());
    let mut t = 0.0;
    while t <= max_m {
        if world.is_wall(Point2::new(o.x + dx * t, o.y + dy * t)) {
            return Some(t);
        }
        t += step_m;
    }
    None
}

#[test]
fn agrees_with_a_fine_march_in_paper_env1() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/paper-env1/world.png");
    let w = World::load(&dir, 0.05).unwrap();
    let step_m = 0.0005;
    let origins = [
        Point2::new(5.5, 5.5),
        Point2::new(30.123, 5.77),
        Point2::new(25.2, 25.0),
        Point2::new(27.3, 31.1),
    ];
    for o in origins {
        for k in 0..90 {
            let a = -PI + k as f64 * (2.0 * PI / 90.0) + 0.0123;
            let exact = w.cast(o, a, 50.0);
            let marched = march(&w, o, a, 50.0, step_m);
            match (exact, marched) {
                (Some(e), Some(m)) => {
                    assert!(
                        e <= m + 1e-9 && m - e <= step_m + 1e-9,
                        "{o:?} {a}: {e} vs {m}"
                    )
                }
                (None, None) => {}
                other => panic!("{o:?} {a}: {other:?}"),
            }
        }
    }
}
