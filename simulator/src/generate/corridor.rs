//! The `corridor` layout: one long corridor (60–84 m) with an atrium somewhere along it, a
//! ring of side corridors (the loop), one or two dead-end branches, and a few clusters of
//! same-size rooms, with long featureless stretches between them.
//!
//! Builds the [`Floor`] and the tour's [`Stop`]s: out to the far end (through the atrium,
//! round the ring, into branches and rooms as the length allows), then straight back under
//! the ring to the start — the revisit.

use super::floor::{AreaKind, Floor};
use super::office::{RoomSize, Row, door_at, rooms_along};
use super::rect::{Rect, snap};
use super::route::Stop;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use sketchslam_types::Point2;

/// A floor and its tour (the first stop is the start).
pub fn build(rng: &mut ChaCha8Rng) -> (Floor, Vec<Stop>) {
    let mut floor = Floor::new(rng.random_range(0.15..0.25));
    let lm = snap(rng.random_range(60.0..84.0));
    let cw = snap(rng.random_range(2.0..3.0));
    let main = floor.add_area(Rect::new(0.0, 0.0, lm, cw), AreaKind::Corridor);
    // Groups of stops, ordered along x afterwards.
    let mut groups: Vec<(f64, Vec<Stop>)> = Vec::new();

    // The atrium: the corridor runs through it.
    let (ax, ay) = (
        snap(rng.random_range(10.0..18.0)),
        snap(rng.random_range(10.0..16.0)),
    );
    let acx = lm * rng.random_range(0.3..0.7);
    let below = snap(rng.random_range(2.0..(ay - cw - 2.0)));
    let atrium_rect = Rect::new(acx - 0.5 * ax, -below, acx + 0.5 * ax, ay - below);
    let atrium = floor.add_area(atrium_rect, AreaKind::Hall);
    let r = atrium_rect;
    // Round the atrium: its far side always, the part below the corridor when it is deep.
    let mut visit = vec![
        Stop::must(atrium, Point2::new(r.x0_m + 2.5, r.y1_m - 2.5)),
        Stop::must(atrium, Point2::new(r.x1_m - 2.5, r.y1_m - 2.5)),
    ];
    if below >= 5.0 {
        visit.push(Stop::may(atrium, Point2::new(r.x1_m - 2.5, r.y0_m + 2.5)));
        visit.push(Stop::may(atrium, Point2::new(r.x0_m + 2.5, r.y0_m + 2.5)));
    }
    groups.push((r.x0_m, visit));

    // The ring, on the longer side of the atrium, above the corridor.
    let (lo, hi) = if acx > 0.5 * lm {
        (3.0, r.x0_m - 3.0)
    } else {
        (r.x1_m + 3.0, lm - 3.0)
    };
    let bw = snap(rng.random_range(1.8..2.4));
    let room_for = hi - lo - bw;
    let ring_w = snap(if room_for > 10.5 {
        rng.random_range(10.0..room_for.min(20.0))
    } else {
        room_for
    });
    let xa = snap(lo + rng.random_range(0.0..(hi - lo - bw - ring_w).max(0.01)));
    let xb = xa + ring_w;
    let top_y = snap(cw + rng.random_range(8.0..14.0));
    floor.add_area(Rect::new(xa, 0.0, xa + bw, top_y), AreaKind::Corridor);
    floor.add_area(Rect::new(xb, 0.0, xb + bw, top_y), AreaKind::Corridor);
    let top = floor.add_area(
        Rect::new(xa, top_y - bw, xb + bw, top_y),
        AreaKind::Corridor,
    );
    groups.push((
        xa,
        vec![
            Stop::must(top, Point2::new(xa + 0.5 * bw, top_y - 0.5 * bw)),
            Stop::must(top, Point2::new(xb + 0.5 * bw, top_y - 0.5 * bw)),
        ],
    ));
    let door_m = snap(rng.random_range(0.9..1.2));

    // Dead-end branches below the corridor, with rooms along them.
    for _ in 0..rng.random_range(1..=2) {
        let len = snap(rng.random_range(6.0..12.0));
        let w = snap(rng.random_range(1.8..2.4));
        let x = snap(rng.random_range(2.0..lm - w - 2.0));
        if !floor.fits(&Rect::new(x, -len, x + w, -floor.wall_m - 0.05)) {
            continue;
        }
        let branch = floor.add_area(Rect::new(x, -len, x + w, cw), AreaKind::Corridor);
        let width_m = snap(rng.random_range(3.0..4.5));
        let size = RoomSize {
            width_m,
            depth_m: snap(rng.random_range(3.5..5.0)),
            door_m,
            door_at_m: door_at(width_m, door_m, rng),
        };
        let mut stops = Vec::new();
        for side in [-1.0, 1.0] {
            let row = Row {
                piece: branch,
                horizontal: false,
                side,
                range_m: (-len, 0.0),
                meeting_p: 0.0,
            };
            stops.extend(rooms_along(&mut floor, &row, &size, rng));
        }
        // From the junction down: rooms nearest the corridor first, then the end.
        stops.sort_by(|p, q| q.0.total_cmp(&p.0));
        let mut visit: Vec<Stop> = stops.into_iter().map(|(_, s)| s).collect();
        visit.push(Stop::may(branch, Point2::new(x + 0.5 * w, -len + 1.2)));
        groups.push((x, visit));
    }

    // Clusters of same-size rooms along the corridor, both sides.
    let width_m = snap(rng.random_range(3.0..4.5));
    let size = RoomSize {
        width_m,
        depth_m: snap(rng.random_range(3.5..6.0)),
        door_m,
        door_at_m: door_at(width_m, door_m, rng),
    };
    for _ in 0..rng.random_range(2..=4) {
        let n = rng.random_range(3..=6) as f64;
        let len = n * (size.width_m + floor.wall_m);
        let from = snap(rng.random_range(0.0..(lm - len).max(0.1)));
        let side = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
        let row = Row {
            piece: main,
            horizontal: true,
            side,
            range_m: (from, from + len),
            meeting_p: 0.1,
        };
        for (at, stop) in rooms_along(&mut floor, &row, &size, rng) {
            groups.push((at, vec![stop]));
        }
    }

    groups.sort_by(|p, q| p.0.total_cmp(&q.0));
    let mut stops = vec![Stop::must(main, Point2::new(1.5, 0.5 * cw))];
    stops.extend(groups.into_iter().flat_map(|g| g.1));
    stops.push(Stop::must(main, Point2::new(lm - 1.5, 0.5 * cw)));
    let shift = floor.finish(1.5);
    for s in &mut stops {
        s.point = Point2::new(s.point.x + shift.0, s.point.y + shift.1);
    }
    (floor, stops)
}
