//! The floor plan of a generated world: axis-aligned rectangles of free space (corridor
//! pieces, rooms, halls), the doors cut through the walls between them, the links where
//! two rectangles overlap, and the clutter inside (which no drawing shows).
//!
//! The layouts ([`super::office`], [`super::corridor`], [`super::hall`]) build a [`Floor`],
//! the route ([`super::route`]) walks its doors and links, [`super::clutter`] fills it,
//! and [`Floor::world_image`] rasterizes it into `world.png` (everything not carved out is
//! wall). All coordinates are snapped to the world's 0.05 m grid ([`super::rect`]) so the
//! image is exact.

use super::rect::{PX_PER_M, RESOLUTION_M, Rect, point_segment_distance, snap};
use image::{GrayImage, Luma};
use sketchslam_types::Point2;

/// What a rectangle of free space is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AreaKind {
    /// A piece of corridor (pieces overlap at bends and junctions).
    Corridor,
    /// A room of the repeated size.
    Room,
    /// A bigger room (meeting room), often with two doors.
    MeetingRoom,
    /// A large open hall or atrium.
    Hall,
}

/// A rectangle of free space.
#[derive(Debug, Clone, PartialEq)]
pub struct Area {
    /// Its extent.
    pub rect: Rect,
    /// What it is.
    pub kind: AreaKind,
}

/// A door: a gap through the wall between two areas.
#[derive(Debug, Clone, PartialEq)]
pub struct Door {
    /// The gap (free space spanning the wall's thickness).
    pub rect: Rect,
    /// The two areas it joins.
    pub areas: [usize; 2],
    /// On the door's centre line, one point inside each area (same order as `areas`), deep
    /// enough for the route to turn there.
    pub approach: [Point2; 2],
}

/// Two overlapping areas (corridor pieces at a bend, a corridor entering a hall).
#[derive(Debug, Clone, PartialEq)]
pub struct Link {
    /// The two areas.
    pub areas: [usize; 2],
    /// The route's ways from one to the other: the centre of their overlap, and on a long
    /// overlap (a corridor running through a hall) also points 1 m from either end.
    pub points: Vec<Point2>,
}

/// Furniture and structure that the drawings leave out.
#[derive(Debug, Clone, PartialEq)]
pub enum Clutter {
    /// A box (desk, cabinet, shelf row), filled.
    Box(Rect),
    /// A round pillar.
    Pillar {
        /// Its centre.
        centre: Point2,
        /// Its radius, meters.
        radius_m: f64,
    },
}

impl Clutter {
    /// Distance from the clutter to the segment `a → b`.
    pub fn distance_to_segment(&self, a: Point2, b: Point2) -> f64 {
        match self {
            Clutter::Box(r) => r.distance_to_segment(a, b),
            Clutter::Pillar { centre, radius_m } => {
                (point_segment_distance(*centre, a, b) - radius_m).max(0.0)
            }
        }
    }
}

/// A floor plan.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Floor {
    /// World width, meters (a whole number of pixels).
    pub width_m: f64,
    /// World height, meters.
    pub height_m: f64,
    /// Wall thickness between neighbouring areas, meters.
    pub wall_m: f64,
    /// The free-space rectangles.
    pub areas: Vec<Area>,
    /// The doors.
    pub doors: Vec<Door>,
    /// The overlaps (filled in by [`Floor::finish`]).
    pub links: Vec<Link>,
    /// The clutter (filled in after the route).
    pub clutter: Vec<Clutter>,
}

/// How deep a door's approach point lies inside an area, at most (half the depth when
/// less: on a corridor's centre line, so a row of doors does not make the route zigzag).
const APPROACH_M: f64 = 1.5;
/// Wall left on each side of a door, at least, meters.
const JAMB_M: f64 = 0.35;

impl Floor {
    /// An empty floor with walls `wall_m` thick.
    pub fn new(wall_m: f64) -> Floor {
        Floor {
            wall_m: snap(wall_m),
            ..Floor::default()
        }
    }

    /// True when `rect` keeps a wall's thickness from every area already placed.
    pub fn fits(&self, rect: &Rect) -> bool {
        let grown = rect.expanded(self.wall_m - 0.01);
        self.areas
            .iter()
            .all(|a| a.rect.intersection(&grown).is_none())
    }

    /// Adds an area and returns its index.
    pub fn add_area(&mut self, rect: Rect, kind: AreaKind) -> usize {
        self.areas.push(Area { rect, kind });
        self.areas.len() - 1
    }

    /// The door between the rectangles `a` and `b` (separated by a wall no thicker than
    /// 0.6 m) centred at `along_m` on the shared wall, `width_m` wide; `None` when it
    /// would not fit with its jambs.
    pub fn door_between(
        a: &Rect,
        b: &Rect,
        along_m: f64,
        width_m: f64,
    ) -> Option<(Rect, [Point2; 2])> {
        let half = 0.5 * width_m;
        let c = snap(along_m);
        let depth = |extent: f64| (0.5 * extent).min(APPROACH_M);
        let fits = |lo: f64, hi: f64| c - half - JAMB_M >= lo && c + half + JAMB_M <= hi;
        let gap = |g: f64| g > 0.0 && g <= 0.6;
        if gap(b.x0_m - a.x1_m) || gap(a.x0_m - b.x1_m) {
            // A vertical wall between them; the door runs along y.
            if !fits(a.y0_m.max(b.y0_m), a.y1_m.min(b.y1_m)) {
                return None;
            }
            let (l, r, a_left) = if b.x0_m > a.x1_m {
                (a, b, true)
            } else {
                (b, a, false)
            };
            let rect = Rect::new(l.x1_m, c - half, r.x0_m, c + half);
            let pl = Point2::new(l.x1_m - depth(l.width_m()), c);
            let pr = Point2::new(r.x0_m + depth(r.width_m()), c);
            Some((rect, if a_left { [pl, pr] } else { [pr, pl] }))
        } else if gap(b.y0_m - a.y1_m) || gap(a.y0_m - b.y1_m) {
            if !fits(a.x0_m.max(b.x0_m), a.x1_m.min(b.x1_m)) {
                return None;
            }
            let (lo, hi, a_low) = if b.y0_m > a.y1_m {
                (a, b, true)
            } else {
                (b, a, false)
            };
            let rect = Rect::new(c - half, lo.y1_m, c + half, hi.y0_m);
            let pl = Point2::new(c, lo.y1_m - depth(lo.height_m()));
            let ph = Point2::new(c, hi.y0_m + depth(hi.height_m()));
            Some((rect, if a_low { [pl, ph] } else { [ph, pl] }))
        } else {
            None
        }
    }

    /// Adds the door between areas `a` and `b` (see [`Floor::door_between`]).
    pub fn add_door(&mut self, a: usize, b: usize, along_m: f64, width_m: f64) -> Option<usize> {
        let (rect, approach) =
            Floor::door_between(&self.areas[a].rect, &self.areas[b].rect, along_m, width_m)?;
        self.doors.push(Door {
            rect,
            areas: [a, b],
            approach,
        });
        Some(self.doors.len() - 1)
    }

    /// Moves everything so that the bounding box starts at `margin_m`, sets the world
    /// size, and finds the links (overlaps of at least `1.6 m` both ways). Returns the
    /// shift applied, so layouts can move their own points along.
    pub fn finish(&mut self, margin_m: f64) -> (f64, f64) {
        let (mut x0, mut y0, mut x1, mut y1) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
        for a in &self.areas {
            x0 = x0.min(a.rect.x0_m);
            y0 = y0.min(a.rect.y0_m);
            x1 = x1.max(a.rect.x1_m);
            y1 = y1.max(a.rect.y1_m);
        }
        let (dx, dy) = (snap(margin_m - x0), snap(margin_m - y0));
        for a in &mut self.areas {
            a.rect = a.rect.translated(dx, dy);
        }
        for d in &mut self.doors {
            d.rect = d.rect.translated(dx, dy);
            for p in &mut d.approach {
                *p = Point2::new(p.x + dx, p.y + dy);
            }
        }
        self.width_m = snap(x1 + dx + margin_m);
        self.height_m = snap(y1 + dy + margin_m);
        self.links.clear();
        for i in 0..self.areas.len() {
            for j in i + 1..self.areas.len() {
                if let Some(r) = self.areas[i].rect.intersection(&self.areas[j].rect)
                    && r.width_m() >= 1.6
                    && r.height_m() >= 1.6
                {
                    let c = r.centre();
                    let mut points = vec![c];
                    if r.width_m() >= 4.0 && r.width_m() >= r.height_m() {
                        points.push(Point2::new(r.x0_m + 1.0, c.y));
                        points.push(Point2::new(r.x1_m - 1.0, c.y));
                    } else if r.height_m() >= 4.0 {
                        points.push(Point2::new(c.x, r.y0_m + 1.0));
                        points.push(Point2::new(c.x, r.y1_m - 1.0));
                    }
                    self.links.push(Link {
                        areas: [i, j],
                        points,
                    });
                }
            }
        }
        (dx, dy)
    }

    /// Image size in pixels.
    pub fn size_px(&self) -> (usize, usize) {
        (
            (self.width_m * PX_PER_M).round() as usize,
            (self.height_m * PX_PER_M).round() as usize,
        )
    }

    /// The free cells, row-major from the BOTTOM row up (`free[j·w + i]`), of the areas and
    /// doors whose flag is set (all when `None`), without clutter.
    pub fn free_mask(&self, areas: Option<&[bool]>, doors: Option<&[bool]>) -> Vec<bool> {
        let (w, h) = self.size_px();
        let mut free = vec![false; w * h];
        let mut carve = |r: &Rect| {
            let (i0, i1) = cells(r.x0_m, r.x1_m, w);
            let (j0, j1) = cells(r.y0_m, r.y1_m, h);
            for j in j0..j1 {
                free[j * w + i0..j * w + i1].fill(true);
            }
        };
        for (k, a) in self.areas.iter().enumerate() {
            if areas.is_none_or(|f| f[k]) {
                carve(&a.rect);
            }
        }
        for (k, d) in self.doors.iter().enumerate() {
            if doors.is_none_or(|f| f[k]) {
                carve(&d.rect);
            }
        }
        free
    }

    /// The walls as the world sees them: every area and door carved out, the clutter
    /// put back; row-major from the bottom row up, `true` = wall.
    pub fn wall_grid(&self) -> Vec<bool> {
        let (w, h) = self.size_px();
        let mut wall: Vec<bool> = self.free_mask(None, None).iter().map(|f| !f).collect();
        for c in &self.clutter {
            match c {
                Clutter::Box(r) => {
                    let (i0, i1) = cells(r.x0_m, r.x1_m, w);
                    let (j0, j1) = cells(r.y0_m, r.y1_m, h);
                    for j in j0..j1 {
                        wall[j * w + i0..j * w + i1].fill(true);
                    }
                }
                Clutter::Pillar { centre, radius_m } => {
                    let (i0, i1) =
                        cells(centre.x - radius_m, centre.x + radius_m + RESOLUTION_M, w);
                    let (j0, j1) =
                        cells(centre.y - radius_m, centre.y + radius_m + RESOLUTION_M, h);
                    for j in j0..j1 {
                        for i in i0..i1 {
                            let p = Point2::new(
                                (i as f64 + 0.5) / PX_PER_M,
                                (j as f64 + 0.5) / PX_PER_M,
                            );
                            if p.distance(centre) <= *radius_m {
                                wall[j * w + i] = true;
                            }
                        }
                    }
                }
            }
        }
        wall
    }

    /// `world.png`: walls and clutter black, free space white, image rows top-down.
    pub fn world_image(&self) -> GrayImage {
        let (w, h) = self.size_px();
        let wall = self.wall_grid();
        GrayImage::from_fn(w as u32, h as u32, |u, v| {
            let j = h - 1 - v as usize;
            Luma([if wall[j * w + u as usize] { 0 } else { 255 }])
        })
    }
}

/// The cell range `[lo, hi)` covering `[a_m, b_m)`, clamped to `0..n`.
fn cells(a_m: f64, b_m: f64, n: usize) -> (usize, usize) {
    let lo = (a_m * PX_PER_M).round().clamp(0.0, n as f64) as usize;
    let hi = (b_m * PX_PER_M).round().clamp(0.0, n as f64) as usize;
    (lo, hi.max(lo))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_door_spans_the_wall_and_its_approaches_lie_on_its_centre_line() {
        // A corridor 2 m wide, a room above it behind a 0.2 m wall.
        let corridor = Rect::new(0.0, 0.0, 20.0, 2.0);
        let room = Rect::new(5.0, 2.2, 9.0, 7.2);
        let (door, [a, b]) = Floor::door_between(&corridor, &room, 6.0, 1.0).unwrap();
        assert_eq!(door, Rect::new(5.5, 2.0, 6.5, 2.2));
        assert_eq!(
            a,
            Point2::new(6.0, 1.0),
            "corridor side: on its centre line"
        );
        assert_eq!(b, Point2::new(6.0, 3.7), "room side: 1.5 m in");
        // Too close to the room's corner for the jamb.
        assert!(Floor::door_between(&corridor, &room, 5.6, 1.0).is_none());
        // Not neighbours.
        assert!(Floor::door_between(&corridor, &Rect::new(5.0, 4.0, 9.0, 8.0), 6.0, 1.0).is_none());
    }

    #[test]
    fn overlapping_pieces_link_and_the_image_is_carved() {
        let mut f = Floor::new(0.2);
        f.add_area(Rect::new(0.0, 0.0, 10.0, 2.0), AreaKind::Corridor);
        f.add_area(Rect::new(8.0, 0.0, 10.0, 10.0), AreaKind::Corridor);
        f.finish(1.0);
        assert_eq!(f.links.len(), 1);
        assert_eq!(f.links[0].points, vec![Point2::new(10.0, 2.0)]);
        assert_eq!((f.width_m, f.height_m), (12.0, 12.0));
        let img = f.world_image();
        assert_eq!(img.dimensions(), (240, 240));
        // (2, 2) m is in the corridor, (2, 6) m is wall; image rows are top-down.
        assert_eq!(img.get_pixel(40, 240 - 1 - 40).0[0], 255);
        assert_eq!(img.get_pixel(40, 240 - 1 - 120).0[0], 0);
    }
}
