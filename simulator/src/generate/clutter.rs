//! Clutter: furniture boxes and cabinets in rooms, pillars and shelving rows in halls, a
//! few cabinets along wide corridors. The world has them, the LiDAR sees them, no drawing
//! shows them.
//!
//! Placed after the route (see [`super::route`]): a piece is kept only when it stays
//! [`KEEP_OFF_M`] from every leg and clear of every door, so the route's clearance holds
//! by construction (and [`super::route::check_clearance`] checks it again on the image).

use super::floor::{AreaKind, Clutter, Floor};
use super::rect::Rect;
use super::route::CLEARANCE_M;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use sketchslam_types::Point2;

/// Distance every piece keeps from the route's legs, meters.
pub const KEEP_OFF_M: f64 = CLEARANCE_M + 0.25;

/// Fills `floor.clutter` for a route with `legs`.
pub fn place(floor: &mut Floor, legs: &[(Point2, Point2)], rng: &mut ChaCha8Rng) {
    let mut pieces = Vec::new();
    for area in &floor.areas {
        let r = area.rect;
        match area.kind {
            AreaKind::Room | AreaKind::MeetingRoom => {
                let n =
                    rng.random_range(1..=3) + usize::from(area.kind == AreaKind::MeetingRoom) * 2;
                for _ in 0..n {
                    pieces.push(against_a_wall(&r, rng));
                }
                if area.kind == AreaKind::MeetingRoom {
                    // A table in the middle, when the route leaves room for it.
                    let (cx, cy) = (r.centre().x, r.centre().y);
                    let (hw, hh) = (0.25 * r.width_m(), 0.25 * r.height_m());
                    pieces.push(Clutter::Box(Rect::new(cx - hw, cy - hh, cx + hw, cy + hh)));
                }
            }
            AreaKind::Hall => {
                pieces.extend(hall_pieces(&r, rng));
            }
            AreaKind::Corridor => {
                let narrow = r.width_m().min(r.height_m());
                if narrow >= 2.2 {
                    let long = r.width_m().max(r.height_m());
                    for _ in 0..(long / 12.0) as usize {
                        pieces.push(against_a_wall(&r, rng));
                    }
                }
            }
        }
    }
    for piece in pieces {
        if keeps_off(floor, &piece, legs) {
            floor.clutter.push(piece);
        }
    }
}

/// True when `piece` stays clear of the route and of every door.
fn keeps_off(floor: &Floor, piece: &Clutter, legs: &[(Point2, Point2)]) -> bool {
    let bbox = match piece {
        Clutter::Box(r) => *r,
        Clutter::Pillar { centre, radius_m } => Rect::new(
            centre.x - radius_m,
            centre.y - radius_m,
            centre.x + radius_m,
            centre.y + radius_m,
        ),
    };
    let inside_one_area = floor.areas.iter().any(|a| {
        bbox.x0_m >= a.rect.x0_m
            && bbox.x1_m <= a.rect.x1_m
            && bbox.y0_m >= a.rect.y0_m
            && bbox.y1_m <= a.rect.y1_m
    });
    inside_one_area
        && floor
            .doors
            .iter()
            .all(|d| d.rect.expanded(0.8).intersection(&bbox).is_none())
        && legs
            .iter()
            .all(|&(a, b)| piece.distance_to_segment(a, b) >= KEEP_OFF_M)
}

/// A cabinet or desk standing against one of the rectangle's walls.
fn against_a_wall(r: &Rect, rng: &mut ChaCha8Rng) -> Clutter {
    let depth = rng.random_range(0.4..0.8);
    let len: f64 = rng.random_range(0.6..1.6);
    let side = rng.random_range(0..4);
    let horizontal = side < 2;
    let span = if horizontal {
        r.width_m()
    } else {
        r.height_m()
    };
    let len = len.min(span * 0.5);
    let at = rng.random_range(0.0..(span - len).max(0.01));
    Clutter::Box(match side {
        0 => Rect::new(r.x0_m + at, r.y0_m, r.x0_m + at + len, r.y0_m + depth),
        1 => Rect::new(r.x0_m + at, r.y1_m - depth, r.x0_m + at + len, r.y1_m),
        2 => Rect::new(r.x0_m, r.y0_m + at, r.x0_m + depth, r.y0_m + at + len),
        _ => Rect::new(r.x1_m - depth, r.y0_m + at, r.x1_m, r.y0_m + at + len),
    })
}

/// A grid of pillars, rows of shelving and a few loose boxes in a hall.
fn hall_pieces(r: &Rect, rng: &mut ChaCha8Rng) -> Vec<Clutter> {
    let mut out = Vec::new();
    // Pillars on a regular grid (the spacing of the building's structure).
    let pitch = rng.random_range(5.0..8.0);
    let radius_m = rng.random_range(0.2..0.35);
    let square = rng.random_bool(0.5);
    let mut y = r.y0_m + pitch;
    while y < r.y1_m - 1.0 {
        let mut x = r.x0_m + pitch;
        while x < r.x1_m - 1.0 {
            out.push(if square {
                Clutter::Box(Rect::new(
                    x - radius_m,
                    y - radius_m,
                    x + radius_m,
                    y + radius_m,
                ))
            } else {
                Clutter::Pillar {
                    centre: Point2::new(x, y),
                    radius_m,
                }
            });
            x += pitch;
        }
        y += pitch;
    }
    // Shelving rows in one part of the hall, along x or along y.
    let along_x = rng.random_bool(0.5);
    let depth = rng.random_range(0.5..0.9);
    let aisle = rng.random_range(2.2..3.2);
    let (lo, hi) = if along_x {
        (r.y0_m, r.y1_m)
    } else {
        (r.x0_m, r.x1_m)
    };
    let (a0, a1) = if along_x {
        (r.x0_m, r.x1_m)
    } else {
        (r.y0_m, r.y1_m)
    };
    let row_len = rng.random_range(0.3..0.6) * (a1 - a0);
    let row_at = a0 + rng.random_range(0.15..0.85) * (a1 - a0 - row_len);
    let mut c = lo + rng.random_range(3.0..5.0);
    let stop = lo + rng.random_range(0.5..0.9) * (hi - lo);
    while c + depth < stop {
        let rect = if along_x {
            Rect::new(row_at, c, row_at + row_len, c + depth)
        } else {
            Rect::new(c, row_at, c + depth, row_at + row_len)
        };
        // A row split in two by a cross aisle sometimes.
        if rng.random_bool(0.3) {
            let mid = 0.5;
            let (a, b) = split(&rect, along_x, mid, aisle);
            out.push(Clutter::Box(a));
            out.push(Clutter::Box(b));
        } else {
            out.push(Clutter::Box(rect));
        }
        c += depth + aisle;
    }
    for _ in 0..rng.random_range(2..6) {
        let (w, h) = (rng.random_range(0.5..1.5), rng.random_range(0.5..1.5));
        let x = rng.random_range(r.x0_m..(r.x1_m - w));
        let y = rng.random_range(r.y0_m..(r.y1_m - h));
        out.push(Clutter::Box(Rect::new(x, y, x + w, y + h)));
    }
    out
}

/// `rect` cut across its length at `t` (0..1) with a gap of `gap_m`.
fn split(rect: &Rect, along_x: bool, t: f64, gap_m: f64) -> (Rect, Rect) {
    if along_x {
        let m = rect.x0_m + t * rect.width_m();
        (
            Rect::new(rect.x0_m, rect.y0_m, m - 0.5 * gap_m, rect.y1_m),
            Rect::new(m + 0.5 * gap_m, rect.y0_m, rect.x1_m, rect.y1_m),
        )
    } else {
        let m = rect.y0_m + t * rect.height_m();
        (
            Rect::new(rect.x0_m, rect.y0_m, rect.x1_m, m - 0.5 * gap_m),
            Rect::new(rect.x0_m, m + 0.5 * gap_m, rect.x1_m, rect.y1_m),
        )
    }
}
