//! The `office` layout: a straight, L-, U- or ring-shaped corridor lined with rooms of one
//! size in a row (the repetition that fools loop closure), a few meeting rooms with two
//! doors, some neighbouring rooms joined by an inner door.
//!
//! Builds the [`Floor`] and the tour's [`Stop`]s for [`super::route::build`]: the corridor's
//! ends and corners are mandatory, every room is an optional visit in driving order. Loops:
//! the ring, a meeting room's two doors, a pair of joined rooms.

use super::floor::{AreaKind, Floor};
use super::rect::{Rect, snap};
use super::route::Stop;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use sketchslam_types::Point2;

/// The corridor's shape.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Shape {
    Straight,
    L,
    U,
    Ring,
}

/// Room dimensions shared by a row of rooms.
pub(super) struct RoomSize {
    /// Along the corridor, meters.
    pub(super) width_m: f64,
    /// Away from the corridor, meters.
    pub(super) depth_m: f64,
    /// Door width, meters.
    pub(super) door_m: f64,
    /// Door centre from the room's low end along the corridor, meters.
    pub(super) door_at_m: f64,
}

/// A floor and its tour (the first stop is the start).
pub fn build(rng: &mut ChaCha8Rng) -> (Floor, Vec<Stop>) {
    let shape = match rng.random_range(0..10) {
        0..=2 => Shape::Straight,
        3..=5 => Shape::L,
        6..=7 => Shape::U,
        _ => Shape::Ring,
    };
    let mut floor = Floor::new(rng.random_range(0.15..0.25));
    let cw = snap(rng.random_range(1.8..2.5));
    let door_m = snap(rng.random_range(0.9..1.2));
    let width_m = snap(rng.random_range(3.0..4.5));
    let size = RoomSize {
        width_m,
        depth_m: snap(rng.random_range(3.5..6.0)),
        door_m,
        door_at_m: door_at(width_m, door_m, rng),
    };
    let (l1, l2) = match shape {
        Shape::Straight => (snap(rng.random_range(45.0..72.0)), 0.0),
        _ => (
            snap(rng.random_range(32.0..60.0)),
            snap(rng.random_range(
                2.0 * (cw + size.depth_m) + 6.0..45.0f64.max(2.0 * (cw + size.depth_m) + 7.0),
            )),
        ),
    };
    // Corridor pieces in driving order, with the point each one ends at.
    let mut pieces: Vec<(usize, Point2)> = Vec::new();
    let half = 0.5 * cw;
    let p0 = floor.add_area(Rect::new(0.0, 0.0, l1, cw), AreaKind::Corridor);
    let start = Point2::new(1.5, half);
    match shape {
        Shape::Straight => pieces.push((p0, Point2::new(l1 - 1.5, half))),
        _ => {
            pieces.push((p0, Point2::new(l1 - half, half)));
            let p1 = floor.add_area(Rect::new(l1 - cw, 0.0, l1, l2), AreaKind::Corridor);
            if shape == Shape::L {
                pieces.push((p1, Point2::new(l1 - half, l2 - 1.5)));
            } else {
                pieces.push((p1, Point2::new(l1 - half, l2 - half)));
                let p2 = floor.add_area(Rect::new(0.0, l2 - cw, l1, l2), AreaKind::Corridor);
                if shape == Shape::U {
                    pieces.push((p2, Point2::new(1.5, l2 - half)));
                } else {
                    pieces.push((p2, Point2::new(half, l2 - half)));
                    let p3 = floor.add_area(Rect::new(0.0, 0.0, cw, l2), AreaKind::Corridor);
                    pieces.push((p3, Point2::new(half, 2.0 * cw)));
                }
            }
        }
    }
    // Rooms along both sides of every piece (a side left bare now and then).
    let mut rooms_of: Vec<Vec<(f64, Stop)>> = vec![Vec::new(); pieces.len()];
    for (k, &(piece, _)) in pieces.iter().enumerate() {
        for side in [-1.0, 1.0] {
            if rng.random_bool(0.15) {
                continue;
            }
            let r = floor.areas[piece].rect;
            let horizontal = r.width_m() >= r.height_m();
            let range = if horizontal {
                (r.x0_m, r.x1_m)
            } else {
                (r.y0_m, r.y1_m)
            };
            let row = Row {
                piece,
                horizontal,
                side,
                range_m: range,
                meeting_p: 0.12,
            };
            rooms_of[k].extend(rooms_along(&mut floor, &row, &size, rng));
        }
    }
    let mut stops = vec![Stop::must(p0, start)];
    for (k, &(piece, end)) in pieces.iter().enumerate() {
        let (from, _) = if k == 0 {
            (start, end)
        } else {
            (pieces[k - 1].1, end)
        };
        // Rooms in driving order: by their distance from where the piece is entered.
        let mut rooms = std::mem::take(&mut rooms_of[k]);
        rooms.sort_by(|a, b| {
            let da = (a.0 - along(&floor.areas[piece].rect, from)).abs();
            let db = (b.0 - along(&floor.areas[piece].rect, from)).abs();
            da.total_cmp(&db)
        });
        stops.extend(rooms.into_iter().map(|(_, s)| s));
        stops.push(Stop::must(piece, end));
    }
    let shift = floor.finish(1.5);
    for s in &mut stops {
        s.point = Point2::new(s.point.x + shift.0, s.point.y + shift.1);
    }
    (floor, stops)
}

/// The coordinate of `p` along the long axis of `piece`.
fn along(piece: &Rect, p: Point2) -> f64 {
    if piece.width_m() >= piece.height_m() {
        p.x
    } else {
        p.y
    }
}

/// Where a door goes in a room `width_m` wide: the same place in every room of a row.
pub(super) fn door_at(width_m: f64, door_m: f64, rng: &mut ChaCha8Rng) -> f64 {
    snap(rng.random_range(0.5 * door_m + 0.45..width_m - 0.5 * door_m - 0.45))
}

/// Where a row of rooms goes.
pub(super) struct Row {
    /// The area the rooms open onto.
    pub(super) piece: usize,
    /// Rooms side by side along x (on the piece's bottom or top) or along y.
    pub(super) horizontal: bool,
    /// −1: below / left of the piece, +1: above / right.
    pub(super) side: f64,
    /// The stretch along the piece the rooms fill, meters.
    pub(super) range_m: (f64, f64),
    /// Chance of a meeting room (two or three rooms wide, two doors) at each place.
    pub(super) meeting_p: f64,
}

/// Places a row of rooms; returns each room's first door position along the piece and its
/// stop. Places where a room would not fit (another area, a door off the piece) stay wall.
pub(super) fn rooms_along(
    floor: &mut Floor,
    row: &Row,
    size: &RoomSize,
    rng: &mut ChaCha8Rng,
) -> Vec<(f64, Stop)> {
    let (piece, horizontal, side) = (row.piece, row.horizontal, row.side);
    let p = floor.areas[piece].rect;
    let t = floor.wall_m;
    let (a, b) = row.range_m;
    // The room's extent across the piece.
    let (c0, c1) = match (horizontal, side > 0.0) {
        (true, true) => (p.y1_m + t, p.y1_m + t + size.depth_m),
        (true, false) => (p.y0_m - t - size.depth_m, p.y0_m - t),
        (false, true) => (p.x1_m + t, p.x1_m + t + size.depth_m),
        (false, false) => (p.x0_m - t - size.depth_m, p.x0_m - t),
    };
    let rect_at = |lo: f64, hi: f64| {
        if horizontal {
            Rect::new(lo, c0, hi, c1)
        } else {
            Rect::new(c0, lo, c1, hi)
        }
    };
    let mut out = Vec::new();
    let mut pos = a + snap(rng.random_range(0.0..size.width_m));
    let mut prev: Option<usize> = None;
    while pos + size.width_m <= b {
        let meeting = rng.random_bool(row.meeting_p);
        let units = if meeting { rng.random_range(2..=3) } else { 1 };
        let width = units as f64 * size.width_m + (units - 1) as f64 * t;
        let rect = rect_at(pos, pos + width);
        let doors_at: Vec<f64> = if meeting {
            vec![
                pos + size.door_at_m,
                pos + width - size.width_m + size.door_at_m,
            ]
        } else {
            vec![pos + size.door_at_m]
        };
        let door_ok = doors_at
            .iter()
            .all(|&c| Floor::door_between(&p, &rect, c, size.door_m).is_some());
        if pos + width > b || !floor.fits(&rect) || !door_ok {
            prev = None;
            pos += size.width_m + t;
            continue;
        }
        let kind = if meeting {
            AreaKind::MeetingRoom
        } else {
            AreaKind::Room
        };
        let room = floor.add_area(rect, kind);
        for &c in &doors_at {
            floor.add_door(piece, room, c, size.door_m);
        }
        // Neighbours joined by an inner door, deep in the room.
        if let Some(prev) = prev
            && rng.random_bool(0.3)
        {
            let mid = 0.5 * (c0 + c1) + 0.2 * side * (c1 - c0);
            floor.add_door(prev, room, mid, size.door_m);
        }
        out.push((doors_at[0], Stop::may(room, rect.centre())));
        prev = Some(room);
        pos += width + t;
    }
    out
}
