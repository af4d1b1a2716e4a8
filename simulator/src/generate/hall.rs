//! The `hall` layout: two or three large open halls (15–36 m) in a row, joined by short
//! corridors — two between the first pair, the loop — with a few small rooms off their
//! long walls; pillars, shelving rows and boxes fill the halls ([`super::clutter`]).
//!
//! Builds the [`Floor`] and the tour's [`Stop`]s: east along the bottom of every hall,
//! back west along the top (through the other corridor), down to the start.

use super::floor::{AreaKind, Floor};
use super::office::{RoomSize, Row, door_at, rooms_along};
use super::rect::{Rect, snap};
use super::route::Stop;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use sketchslam_types::Point2;

/// How far inside a hall's walls the tour drives its ring, meters.
const INSET_M: f64 = 2.5;
/// How far a joining corridor reaches into each hall, meters.
const REACH_M: f64 = 1.8;

/// A floor and its tour (the first stop is the start).
pub fn build(rng: &mut ChaCha8Rng) -> (Floor, Vec<Stop>) {
    let mut floor = Floor::new(rng.random_range(0.15..0.25));
    let n = if rng.random_bool(0.6) { 2 } else { 3 };
    let (wx_lo, wx_hi) = if n == 2 { (18.0, 36.0) } else { (15.0, 24.0) };
    let mut halls: Vec<(usize, Rect)> = Vec::new();
    let mut x = 0.0;
    for _ in 0..n {
        let (w, h) = (
            snap(rng.random_range(wx_lo..wx_hi)),
            snap(rng.random_range(15.0..30.0)),
        );
        let y0 = snap(rng.random_range(0.0..4.0));
        let rect = Rect::new(x, y0, x + w, y0 + h);
        halls.push((floor.add_area(rect, AreaKind::Hall), rect));
        x = snap(x + w + rng.random_range(3.0..6.0));
    }
    // Joining corridors: two between the first pair, one or two between the others.
    for k in 0..n - 1 {
        let (a, b) = (halls[k].1, halls[k + 1].1);
        let (lo, hi) = (a.y0_m.max(b.y0_m) + 2.0, a.y1_m.min(b.y1_m) - 2.0);
        let cw = snap(rng.random_range(2.0..3.0));
        let span = hi - lo - cw;
        let lower = snap(lo + rng.random_range(0.0..0.2) * span);
        floor.add_area(
            Rect::new(a.x1_m - REACH_M, lower, b.x0_m + REACH_M, lower + cw),
            AreaKind::Corridor,
        );
        if k == 0 || rng.random_bool(0.5) {
            let upper = snap(hi - cw - rng.random_range(0.0..0.2) * span);
            floor.add_area(
                Rect::new(a.x1_m - REACH_M, upper, b.x0_m + REACH_M, upper + cw),
                AreaKind::Corridor,
            );
        }
    }
    // Small rooms off the halls' bottom and top walls.
    let door_m = snap(rng.random_range(0.9..1.2));
    let width_m = snap(rng.random_range(3.0..5.0));
    let size = RoomSize {
        width_m,
        depth_m: snap(rng.random_range(3.0..5.0)),
        door_m,
        door_at_m: door_at(width_m, door_m, rng),
    };
    let mut bottom_rooms: Vec<Vec<(f64, Stop)>> = vec![Vec::new(); n];
    let mut top_rooms: Vec<Vec<(f64, Stop)>> = vec![Vec::new(); n];
    for (k, &(hall, r)) in halls.iter().enumerate() {
        for (side, list) in [(-1.0, &mut bottom_rooms[k]), (1.0, &mut top_rooms[k])] {
            if rng.random_bool(0.4) {
                continue;
            }
            let len = rng.random_range(0.3..0.7) * r.width_m();
            let from = r.x0_m + rng.random_range(0.0..(r.width_m() - len));
            let row = Row {
                piece: hall,
                horizontal: true,
                side,
                range_m: (from, from + len),
                meeting_p: 0.0,
            };
            *list = rooms_along(&mut floor, &row, &size, rng);
        }
    }
    let corner = |r: &Rect, right: bool, up: bool| {
        Point2::new(
            if right {
                r.x1_m - INSET_M
            } else {
                r.x0_m + INSET_M
            },
            if up {
                r.y1_m - INSET_M
            } else {
                r.y0_m + INSET_M
            },
        )
    };
    let mut stops = Vec::new();
    for (k, &(hall, r)) in halls.iter().enumerate() {
        stops.push(Stop::must(hall, corner(&r, false, false)));
        let mut rooms = std::mem::take(&mut bottom_rooms[k]);
        rooms.sort_by(|p, q| p.0.total_cmp(&q.0));
        stops.extend(rooms.into_iter().map(|(_, s)| s));
        stops.push(Stop::must(hall, corner(&r, true, false)));
    }
    for (k, &(hall, r)) in halls.iter().enumerate().rev() {
        stops.push(Stop::must(hall, corner(&r, true, true)));
        let mut rooms = std::mem::take(&mut top_rooms[k]);
        rooms.sort_by(|p, q| q.0.total_cmp(&p.0));
        stops.extend(rooms.into_iter().map(|(_, s)| s));
        stops.push(Stop::must(hall, corner(&r, false, true)));
    }
    let shift = floor.finish(1.5);
    for s in &mut stops {
        s.point = Point2::new(s.point.x + shift.0, s.point.y + shift.1);
    }
    (floor, stops)
}
