//! The robot's route carried onto the drawing through W, and the steps of it that run
//! through a drawn wall: what the drawing says about free space.
//!
//! Sits inside the warp's fit ([`super::fit`]) beside its wall term: the map's wall points
//! say where drawn walls should be, the route says where they cannot be. The robot went from
//! keyframe to keyframe `r_j → r_{j+1}` (map meters) through free space; a warp that carries a
//! step across a drawn wall says the robot passed through it. Either W is wrong there, or the
//! person left a door out.
//!
//! A step `[W(r_j), W(r_{j+1})]` (drawing frame, pixels) runs through a drawn wall when it
//! crosses a drawn segment at `X` and no opening lies within `m` of `X`: no free end of a
//! drawn line of the segment's direction (within the fit's direction tolerance, passing
//! within `m / 4` of `X`) — an end no other drawn line passes within `m / 4` of, as a
//! door's jamb or a wall ending in a room, not two strokes in a row nor a corner. `m` is
//! the fit's last gate (`gate_m` at the prior's scale: how far a drawn wall may lie from
//! its true place once warped). So a route through a drawn door, or past a door's jamb
//! within the gate, does not count; through a wall drawn as several strokes in a row, or
//! through a corridor's closed end, it does. A step counts once, however many strokes it
//! crosses (a wall drawn with two lines is one wall).
//!
//! Cost: O(k · l) per step of `k` pieces no longer than the segment index's reach, `l` the
//! segments listed near a piece; two more lookups per crossing.

use super::fit::Segment;
use super::segment_grid::SegmentGrid;
use super::warp::Warp;
use sketchslam_types::Point2;

/// The drawn lines a route is checked against: the fit's segments and their index.
pub(super) struct RouteCheck<'a> {
    pub(super) segments: &'a [Segment],
    pub(super) index: &'a SegmentGrid,
    /// The index's reach, pixels: pieces of a step are at most this long, so every segment
    /// crossing a piece is listed near its middle.
    pub(super) reach_px: f64,
    /// `m`, pixels.
    pub(super) margin_px: f64,
    /// Cosine of the direction tolerance.
    pub(super) cos_tol: f64,
}

impl RouteCheck<'_> {
    /// How many steps of `route` (map meters, in order) `warp` carries through a drawn wall.
    pub(super) fn walls_crossed(&self, warp: &Warp, route: &[Point2]) -> usize {
        let carried: Vec<Point2> = route.iter().map(|r| warp.apply(*r)).collect();
        carried
            .windows(2)
            .filter(|step| self.step_crosses(step[0], step[1]))
            .count()
    }

    /// Whether the step `p → q` (pixels) runs through a drawn wall.
    fn step_crosses(&self, p: Point2, q: Point2) -> bool {
        let length = p.distance(&q);
        if !length.is_finite() {
            return false;
        }
        let pieces = (length / self.reach_px.max(1e-9)).ceil().max(1.0) as usize;
        (0..pieces).any(|k| {
            let at = |f: f64| Point2::new(p.x + f * (q.x - p.x), p.y + f * (q.y - p.y));
            let (a, b) = (
                at(k as f64 / pieces as f64),
                at((k + 1) as f64 / pieces as f64),
            );
            let middle = Point2::new(0.5 * (a.x + b.x), 0.5 * (a.y + b.y));
            self.index.near(middle).iter().any(|&s| {
                let s = &self.segments[s as usize];
                crossing(a, b, s).is_some_and(|x| self.away_from_opening(x, s))
            })
        })
    }

    /// Whether the wall `s` is crossed at `x` away from an opening: no free end of a drawn
    /// line of its direction lies within `m` of `x` along it. An end is free when no other
    /// drawn line passes within `m / 4` of it: a door's jamb, a wall's end in a room; not
    /// the joint of two strokes in a row, nor a corner.
    fn away_from_opening(&self, x: Point2, s: &Segment) -> bool {
        let near = self.index.near(x);
        !near.iter().any(|&k| {
            let t = &self.segments[k as usize];
            let parallel =
                (t.normal.x * s.normal.x + t.normal.y * s.normal.y).abs() >= self.cos_tol;
            parallel
                && x.distance(&t.foot(x)) <= 0.25 * self.margin_px
                && [t.a, t.b]
                    .iter()
                    .any(|&end| end.distance(&x) <= self.margin_px && self.is_free(end, k))
        })
    }

    /// Whether no drawn line but segment `own` passes within `m / 4` of its end `end`.
    fn is_free(&self, end: Point2, own: u32) -> bool {
        !self.index.near(end).iter().any(|&k| {
            k != own && {
                let t = &self.segments[k as usize];
                end.distance(&t.foot(end)) <= 0.25 * self.margin_px
            }
        })
    }
}

/// Where the segment `a → b` crosses `s` (both ends of `s` included, `b` excluded so that
/// consecutive pieces count a crossing at their joint once), `None` when it does not or
/// they are parallel.
fn crossing(a: Point2, b: Point2, s: &Segment) -> Option<Point2> {
    let cross = |u: Point2, v: Point2| u.x * v.y - u.y * v.x;
    let r = Point2::new(b.x - a.x, b.y - a.y);
    let e = Point2::new(s.b.x - s.a.x, s.b.y - s.a.y);
    let denominator = cross(r, e);
    if denominator.abs() < 1e-12 {
        return None;
    }
    let w = Point2::new(s.a.x - a.x, s.a.y - a.y);
    let t = cross(w, e) / denominator;
    let u = cross(w, r) / denominator;
    ((0.0..1.0).contains(&t) && (0.0..=1.0).contains(&u))
        .then(|| Point2::new(s.a.x + u * e.x, s.a.y + u * e.y))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::registration::warp::{ControlGrid, Similarity};

    fn segment(a: (f64, f64), b: (f64, f64)) -> Segment {
        Segment::between(Point2::new(a.0, a.1), Point2::new(b.0, b.1)).expect("distinct ends")
    }

    /// The identity at 10 px/m on a one-cell grid.
    fn identity() -> Warp {
        let grid = ControlGrid::covering(Point2::new(-20.0, -20.0), Point2::new(20.0, 20.0), 40.0);
        Warp::rigid(Similarity::new(10.0, 0.0, Point2::new(0.0, 0.0)), grid)
    }

    fn crossed(segments: &[Segment], route: &[(f64, f64)]) -> usize {
        let index = SegmentGrid::new(segments, 30.0).unwrap();
        let check = RouteCheck {
            segments,
            index: &index,
            reach_px: 30.0,
            margin_px: 10.0,
            cos_tol: 20f64.to_radians().cos(),
        };
        let route: Vec<Point2> = route.iter().map(|&(x, y)| Point2::new(x, y)).collect();
        check.walls_crossed(&identity(), &route)
    }

    #[test]
    fn a_route_through_a_wall_counts_and_one_beside_it_does_not() {
        // A wall along x = 50 px from y = −100 to 100 (x = 5 m at 10 px/m).
        let wall = [segment((50.0, -100.0), (50.0, 100.0))];
        assert_eq!(crossed(&wall, &[(0.0, 0.0), (4.0, 0.0), (6.0, 0.0)]), 1);
        assert_eq!(crossed(&wall, &[(0.0, 0.0), (4.0, 0.0), (4.0, 3.0)]), 0);
        // Through and back: two steps.
        assert_eq!(crossed(&wall, &[(4.0, 0.0), (6.0, 0.0), (4.0, 0.5)]), 2);
    }

    #[test]
    fn a_door_or_a_jamb_within_the_margin_does_not_count() {
        // The wall with a 20 px (2 m) door from y = −10 to 10 px.
        let wall = [
            segment((50.0, -100.0), (50.0, -10.0)),
            segment((50.0, 10.0), (50.0, 100.0)),
        ];
        // Through the door's middle.
        assert_eq!(crossed(&wall, &[(4.0, 0.0), (6.0, 0.0)]), 0);
        // Through the wall 5 px (0.5 m) past the jamb: within m = 10 px of the door.
        assert_eq!(crossed(&wall, &[(4.0, 1.5), (6.0, 1.5)]), 0);
        // 3 m past the jamb: through the wall.
        assert_eq!(crossed(&wall, &[(4.0, 4.0), (6.0, 4.0)]), 1);
    }

    #[test]
    fn a_wall_drawn_in_strokes_or_twice_is_one_wall() {
        // Two strokes meeting at y = 0 and a second line 3 px beside them.
        let wall = [
            segment((50.0, -100.0), (50.0, 0.0)),
            segment((50.0, 0.0), (50.0, 100.0)),
            segment((53.0, -100.0), (53.0, 100.0)),
        ];
        assert_eq!(crossed(&wall, &[(4.0, 0.0), (6.0, 0.0)]), 1);
    }

    #[test]
    fn a_corridor_closed_by_a_wall_is_closed_next_to_its_corners() {
        // A 2 m corridor (y = 0 and 20 px) closed at x = 50 px by a wall meeting both sides.
        let corridor = [
            segment((-100.0, 0.0), (50.0, 0.0)),
            segment((-100.0, 20.0), (50.0, 20.0)),
            segment((50.0, 0.0), (50.0, 20.0)),
        ];
        assert_eq!(crossed(&corridor, &[(4.0, 1.5), (6.0, 1.5)]), 1);
        // A wall ending in the open at y = 20 px: passing within m of its end is passing it.
        let stub = [segment((50.0, -100.0), (50.0, 20.0))];
        assert_eq!(crossed(&stub, &[(4.0, 1.5), (6.0, 1.5)]), 0);
    }

    #[test]
    fn a_long_step_finds_a_wall_far_from_its_ends() {
        // A 40 m step (400 px, more than the index's 30 px reach) across the wall.
        let wall = [segment((50.0, -100.0), (50.0, 100.0))];
        assert_eq!(crossed(&wall, &[(-15.0, 0.0), (25.0, 0.0)]), 1);
    }
}
