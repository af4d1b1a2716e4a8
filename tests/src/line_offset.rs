//! The floor under the pose-on-the-drawing score: how far a drawing's lines lie from where
//! its `sketch-truth.toml` puts the walls, seen from the robot's route.
//!
//! The truth file carries the world onto the drawing without the hand's wobble
//! ([`crate::sketch_truth`]). A warp W that lays the map's walls exactly on the drawn lines
//! therefore still scores, wherever the robot is, the offset of the lines around it from the
//! truth's walls; no W read against those lines does better. This module measures that
//! offset, so that `bench-warp` can print it beside W's own error.
//!
//! At a truth pose, the world's wall faces (wall cells next to a free one) within `radius_m`
//! of the robot are carried onto the drawing by the truth and moved, by one translation `d`,
//! onto the drawing's lines: least squares of the point-to-segment distances within
//! `gate_m`, the nearest segment found again each iteration (ICP, Besl & McKay 1992, with
//! translation only, so each step is the mean of the residual vectors
//! `d ← d + mean_i (f_i − (q_i + d))`, `f_i` the nearest point of the nearest line).
//! `|d|` in meters at the drawing's scale is the line offset there. Cost per pose:
//! O(iterations · n · l) for the n faces and the l lines near the robot.
//!
//! Pure: values in, values out (the world, the truth, the lines and the route are given).

use crate::sketch_truth::DrawingTruth;
use sketchslam_engine::sketch::SketchLine;
use sketchslam_simulator::world::World;
use sketchslam_types::{Point2, Pose2};

/// Iterations of the translation ICP per pose (it moves a few pixels; 15 settle it).
const ITERATIONS: usize = 15;
/// Fewer matched faces than this: no offset read there.
const MIN_MATCHED: usize = 10;

/// The world's wall faces: centres of wall cells with a free 4-neighbour, meters.
pub fn wall_faces(world: &World) -> Vec<Point2> {
    let r = world.resolution_m();
    let mut faces = Vec::new();
    for j in 0..world.height() as i64 {
        for i in 0..world.width() as i64 {
            let free_beside = [(1, 0), (-1, 0), (0, 1), (0, -1)]
                .iter()
                .any(|(di, dj)| !world.is_wall_cell(i + di, j + dj));
            if world.is_wall_cell(i, j) && free_beside {
                faces.push(Point2::new((i as f64 + 0.5) * r, (j as f64 + 0.5) * r));
            }
        }
    }
    faces
}

/// The translation (pixels) that lays `points` (drawing pixels) on `lines`, pairing each point
/// with its nearest line within `gate_px`; `None` when fewer than `MIN_MATCHED` points pair.
pub fn translation_onto_lines(
    points: &[Point2],
    lines: &[SketchLine],
    gate_px: f64,
) -> Option<Point2> {
    let mut d = Point2::new(0.0, 0.0);
    for _ in 0..ITERATIONS {
        let (mut sx, mut sy, mut n) = (0.0, 0.0, 0usize);
        for p in points {
            let q = Point2::new(p.x + d.x, p.y + d.y);
            let nearest = lines
                .iter()
                .map(|l| q.nearest_on_segment(l.a, l.b))
                .min_by(|f, g| q.distance(f).total_cmp(&q.distance(g)));
            if let Some(f) = nearest.filter(|f| q.distance(f) <= gate_px) {
                sx += f.x - q.x;
                sy += f.y - q.y;
                n += 1;
            }
        }
        if n < MIN_MATCHED {
            return None;
        }
        d = Point2::new(d.x + sx / n as f64, d.y + sy / n as f64);
    }
    Some(d)
}

/// The line offset (meters at the drawing's scale) at each of the `route`'s truth poses that
/// sees enough walls within `radius_m`: the translation laying the truth's wall `faces`
/// (world meters, [`wall_faces`]) near the robot, carried onto the drawing by `truth`, on the
/// drawing's `lines` (pixels), paired within `gate_m`.
pub fn line_offsets(
    faces: &[Point2],
    truth: &DrawingTruth,
    lines: &[SketchLine],
    route: &[Pose2],
    radius_m: f64,
    gate_m: f64,
) -> Vec<f64> {
    let s = truth.meters_per_pixel;
    let on_drawing = |p: Point2| {
        let d = truth.world_to_drawing(&Pose2::new(p.x, p.y, 0.0));
        Point2::new(d.u_px, d.v_px)
    };
    let reach_px = (radius_m + gate_m) / s;
    route
        .iter()
        .filter_map(|pose| {
            let centre = on_drawing(pose.position());
            let near: Vec<Point2> = faces
                .iter()
                .filter(|f| f.distance(&pose.position()) <= radius_m)
                .map(|f| on_drawing(*f))
                .collect();
            // Lines that reach within the faces' gate (by their bounding box).
            let lines: Vec<SketchLine> = lines
                .iter()
                .filter(|l| {
                    let (lo_u, hi_u) = (l.a.x.min(l.b.x), l.a.x.max(l.b.x));
                    let (lo_v, hi_v) = (l.a.y.min(l.b.y), l.a.y.max(l.b.y));
                    centre.x >= lo_u - reach_px
                        && centre.x <= hi_u + reach_px
                        && centre.y >= lo_v - reach_px
                        && centre.y <= hi_v + reach_px
                })
                .cloned()
                .collect();
            translation_onto_lines(&near, &lines, gate_m / s).map(|d| d.norm() * s)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    fn line(index: usize, a: (f64, f64), b: (f64, f64)) -> SketchLine {
        let (a, b) = (Point2::new(a.0, a.1), Point2::new(b.0, b.1));
        let angle = (-(b.y - a.y))
            .atan2(b.x - a.x)
            .rem_euclid(std::f64::consts::PI);
        SketchLine {
            index,
            a,
            b,
            angle_rad: angle,
        }
    }

    /// A square room's walls 100 px a side from (0, 0), sampled every pixel.
    fn square_points() -> Vec<Point2> {
        (0..100)
            .flat_map(|k| {
                let k = k as f64;
                [
                    Point2::new(k, 0.0),
                    Point2::new(k, 100.0),
                    Point2::new(0.0, k),
                    Point2::new(100.0, k),
                ]
            })
            .collect()
    }

    #[test]
    fn a_drawing_shifted_by_three_pixels_is_three_pixels_off() {
        // The room drawn 3 px right and 2 px down of where its walls are.
        let lines = [
            line(0, (3.0, 2.0), (103.0, 2.0)),
            line(1, (3.0, 102.0), (103.0, 102.0)),
            line(2, (3.0, 2.0), (3.0, 102.0)),
            line(3, (103.0, 2.0), (103.0, 102.0)),
        ];
        let d = translation_onto_lines(&square_points(), &lines, 10.0).unwrap();
        assert!(
            (d.x - 3.0).abs() < 0.05 && (d.y - 2.0).abs() < 0.05,
            "{d:?}"
        );
    }

    #[test]
    fn walls_nobody_drew_and_lines_beyond_the_gate_do_not_pull() {
        // Only the west and south walls drawn, 1 px off; a stray line 30 px away.
        let lines = [
            line(0, (0.0, 1.0), (100.0, 1.0)),
            line(1, (1.0, 0.0), (1.0, 100.0)),
            line(2, (130.0, 0.0), (130.0, 100.0)),
        ];
        let d = translation_onto_lines(&square_points(), &lines, 5.0).unwrap();
        // The undrawn walls' first pixels lie within the gate of the drawn lines' ends and
        // hold back a little (the north wall's (0…4, 100) pairs with the west line's end):
        // 0.81 px each way instead of 1, and the stray line takes no part.
        assert!(
            (d.x - 1.0).abs() < 0.25 && (d.y - 1.0).abs() < 0.25,
            "{d:?}"
        );
        // Nothing within the gate: no offset.
        assert!(translation_onto_lines(&square_points(), &lines[2..], 5.0).is_none());
    }

    #[test]
    fn the_offset_along_a_route_is_the_drawings_shift_in_meters() {
        // A 10 × 10 m world at 0.1 m per cell, walled round; drawn at 0.1 m per pixel
        // unstretched, so a world point (x, y) lands at u = x / 0.1 + 10, v = 120 − y / 0.1.
        let (n, r) = (100, 0.1);
        let walls = (0..n * n)
            .map(|k| {
                let (row, col) = (k / n, k % n);
                row == 0 || col == 0 || row == n - 1 || col == n - 1
            })
            .collect();
        let world = World::from_walls(n, n, r, walls).unwrap();
        let dir = std::env::temp_dir().join(format!("line-offset-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(
            dir.join(crate::sketch_truth::SKETCH_TRUTH_FILE),
            "world_size_m = [10.0, 10.0]\n[[sketch]]\nname = \"A\"\n\
             fx = [[0, 0], [10, 10]]\nfy = [[0, 0], [10, 10]]\nmeters_per_pixel = 0.1\n",
        )
        .unwrap();
        let truth = DrawingTruth::load(&dir, "A").unwrap().unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        // The inner faces are the cells at 0.05 and 9.95 m: pixels u = 10.5 … 109.5,
        // v = 110.5 … 20.5. Drawn 4 px right (0.4 m) and 3 px up (v − 3; 0.3 m): 0.5 m off.
        let (lo, hi) = (10.5 + 4.0, 109.5 + 4.0);
        let (top, bottom) = (20.5 - 3.0, 110.5 - 3.0);
        let lines = [
            line(0, (lo, top), (hi, top)),
            line(1, (lo, bottom), (hi, bottom)),
            line(2, (lo, top), (lo, bottom)),
            line(3, (hi, top), (hi, bottom)),
        ];
        let faces = wall_faces(&world);
        // At the centre and in a corner, 6 m of reach: every pose reads 0.5 m (outside the
        // image is wall, so the border's inner faces are the only ones).
        let route = [Pose2::new(5.0, 5.0, 0.0), Pose2::new(2.0, 2.0, FRAC_PI_2)];
        let offsets = line_offsets(&faces, &truth, &lines, &route, 6.0, 1.0);
        assert_eq!(offsets.len(), 2);
        for m in offsets {
            assert!((m - 0.5).abs() < 0.06, "{m}");
        }
    }
}
