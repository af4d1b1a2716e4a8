//! The robot's route through a generated floor: a tour of stops (corridor ends, ring
//! corners, room centres) joined by the shortest way through doors and links.
//!
//! A layout lists its [`Stop`]s in driving order; [`build`] joins them with
//! [`Portals::path`] (Dijkstra over the door approach points and link points, straight
//! within an area, which is convex), skips optional stops that would push the length past
//! [`MAX_LENGTH_M`], drives back to the first stop, and drives the tour again while the
//! route is shorter than [`MIN_LENGTH_M`] (revisits). [`check_clearance`] then verifies the
//! result on the rasterized world, which is what the scenario loader sees.

use super::floor::Floor;
use super::rect::PX_PER_M;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use sketchslam_types::{Point2, Pose2};

/// Free space every leg keeps from any wall or clutter, meters.
pub const CLEARANCE_M: f64 = 0.35;
/// Shortest accepted route, meters.
pub const MIN_LENGTH_M: f64 = 150.0;
/// Longest accepted route, meters.
pub const MAX_LENGTH_M: f64 = 350.0;
/// Optional stops are skipped when they would take the route past this, meters.
const BUDGET_M: f64 = 330.0;

/// A place the tour goes to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stop {
    /// The area holding the point.
    pub area: usize,
    /// The point (deep enough inside its area for a straight leg to any other point of it).
    pub point: Point2,
    /// Optional stops (room visits) may be left out to keep the length in range.
    pub optional: bool,
}

impl Stop {
    /// A stop the tour always makes.
    pub fn must(area: usize, point: Point2) -> Stop {
        Stop {
            area,
            point,
            optional: false,
        }
    }

    /// A stop the tour makes when the length allows and the dice say so.
    pub fn may(area: usize, point: Point2) -> Stop {
        Stop {
            area,
            point,
            optional: true,
        }
    }
}

/// The route: a start pose and the waypoints after it.
#[derive(Debug, Clone, PartialEq)]
pub struct Route {
    /// Start pose, facing the first waypoint.
    pub start: Pose2,
    /// Waypoints driven in order (no two consecutive ones equal, none equal to the start).
    pub waypoints: Vec<Point2>,
    /// Total length of the legs, meters.
    pub length_m: f64,
}

/// The ways between areas: one node per door side and per link.
pub struct Portals {
    /// Node point and the areas it belongs to.
    nodes: Vec<(Point2, [usize; 2])>,
    /// Pairs of nodes joined across a door.
    crossings: Vec<(usize, usize)>,
}

impl Portals {
    /// The portals of `floor`.
    pub fn new(floor: &Floor) -> Portals {
        let mut nodes = Vec::new();
        let mut crossings = Vec::new();
        for d in &floor.doors {
            nodes.push((d.approach[0], [d.areas[0]; 2]));
            nodes.push((d.approach[1], [d.areas[1]; 2]));
            crossings.push((nodes.len() - 2, nodes.len() - 1));
        }
        for l in &floor.links {
            nodes.extend(l.points.iter().map(|&p| (p, l.areas)));
        }
        Portals { nodes, crossings }
    }

    /// The shortest way from `from` to `to`: the points after `from.point`, ending with
    /// `to.point`, and its length. `None` when `to` cannot be reached.
    pub fn path(&self, from: &Stop, to: &Stop) -> Option<(Vec<Point2>, f64)> {
        if from.area == to.area {
            return Some((vec![to.point], from.point.distance(&to.point)));
        }
        // Nodes: the portals, then the source and the target.
        let n = self.nodes.len();
        let (src, dst) = (n, n + 1);
        let point = |k: usize| match k {
            _ if k == src => from.point,
            _ if k == dst => to.point,
            _ => self.nodes[k].0,
        };
        let areas = |k: usize| match k {
            _ if k == src => [from.area; 2],
            _ if k == dst => [to.area; 2],
            _ => self.nodes[k].1,
        };
        let share = |a: [usize; 2], b: [usize; 2]| a.iter().any(|x| b.contains(x));
        let mut dist = vec![f64::INFINITY; n + 2];
        let mut prev = vec![usize::MAX; n + 2];
        let mut done = vec![false; n + 2];
        dist[src] = 0.0;
        loop {
            let k = (0..n + 2)
                .filter(|&k| !done[k] && dist[k].is_finite())
                .min_by(|&a, &b| dist[a].total_cmp(&dist[b]))?;
            if k == dst {
                break;
            }
            done[k] = true;
            for j in 0..n + 2 {
                if done[j] || j == src {
                    continue;
                }
                let joined = share(areas(k), areas(j))
                    || self
                        .crossings
                        .iter()
                        .any(|&(a, b)| (a == k && b == j) || (a == j && b == k));
                if joined {
                    let d = dist[k] + point(k).distance(&point(j));
                    if d < dist[j] {
                        dist[j] = d;
                        prev[j] = k;
                    }
                }
            }
        }
        let mut points = Vec::new();
        let mut k = dst;
        while k != src {
            points.push(point(k));
            k = prev[k];
        }
        points.reverse();
        Some((points, dist[dst]))
    }
}

/// Builds the tour through `stops` (the first is the start and the end), visiting each
/// optional stop with probability `visit_p` while the length budget allows.
pub fn build(
    floor: &Floor,
    stops: &[Stop],
    visit_p: f64,
    rng: &mut ChaCha8Rng,
) -> Result<Route, String> {
    let portals = Portals::new(floor);
    let cost = |a: &Stop, b: &Stop| -> Result<f64, String> {
        portals
            .path(a, b)
            .map(|p| p.1)
            .ok_or_else(|| format!("no way from area {} to area {}", a.area, b.area))
    };
    let first = *stops.first().ok_or("no stops")?;
    // One lap: the stops after the first, then back to the first.
    let lap: Vec<Stop> = stops[1..].iter().copied().chain([first]).collect();
    // rest[k]: length of the mandatory stops of the lap from its k-th entry on (from the
    // previous mandatory stop at k, i.e. what remains once at mandatory stop k).
    let mandatory: Vec<usize> = (0..lap.len()).filter(|&k| !lap[k].optional).collect();
    let mut rest = vec![0.0; lap.len()];
    for w in mandatory.windows(2).rev() {
        rest[w[0]] = rest[w[1]] + cost(&lap[w[0]], &lap[w[1]])?;
    }
    let mut points = vec![first.point];
    let mut length_m = 0.0;
    let mut cur = first;
    for lap_no in 0..4 {
        let p = visit_p / (1.0 + lap_no as f64);
        for (k, stop) in lap.iter().enumerate() {
            if stop.optional {
                let next = *mandatory
                    .iter()
                    .find(|&&m| m > k)
                    .ok_or("the lap ends with an optional stop")?;
                let extra = cost(&cur, stop)? + cost(stop, &lap[next])? + rest[next];
                if length_m + extra > BUDGET_M || !rng.random_bool(p) {
                    continue;
                }
            }
            let (way, len) = portals
                .path(&cur, stop)
                .ok_or_else(|| format!("no way from area {} to area {}", cur.area, stop.area))?;
            points.extend(way);
            length_m += len;
            cur = *stop;
        }
        if length_m >= MIN_LENGTH_M {
            break;
        }
    }
    // Centimetres, as scenario.toml prints them: the checked route is the written one.
    for p in &mut points {
        *p = Point2::new((p.x * 100.0).round() / 100.0, (p.y * 100.0).round() / 100.0);
    }
    points.dedup_by(|a, b| a.distance(b) < 1e-6);
    // Straight-on waypoints are harmless, but drop them: fewer turns to simulate.
    let mut kept: Vec<Point2> = Vec::with_capacity(points.len());
    for p in points {
        if kept.len() >= 2 {
            let (a, b) = (kept[kept.len() - 2], kept[kept.len() - 1]);
            let cross = (b.x - a.x) * (p.y - b.y) - (b.y - a.y) * (p.x - b.x);
            let dot = (b.x - a.x) * (p.x - b.x) + (b.y - a.y) * (p.y - b.y);
            if cross.abs() < 1e-9 && dot > 0.0 {
                kept.pop();
            }
        }
        kept.push(p);
    }
    if !(MIN_LENGTH_M..=MAX_LENGTH_M).contains(&length_m) {
        return Err(format!(
            "route length {length_m:.1} m is outside [{MIN_LENGTH_M}, {MAX_LENGTH_M}] m"
        ));
    }
    let start = kept[0];
    let waypoints: Vec<Point2> = kept[1..].to_vec();
    let to = waypoints.first().ok_or("the route has no leg")?;
    let heading_deg = ((to.y - start.y).atan2(to.x - start.x).to_degrees() * 10.0).round() / 10.0;
    let heading_rad = heading_deg.to_radians();
    let length_m = kept.windows(2).map(|w| w[0].distance(&w[1])).sum::<f64>();
    Ok(Route {
        start: Pose2::new(start.x, start.y, heading_rad),
        waypoints,
        length_m,
    })
}

/// Checks that every leg of `route` keeps [`CLEARANCE_M`] from every wall cell of
/// `wall` (row-major from the bottom, `w × h` cells of the world grid), sampling each leg
/// every 2.5 cm. The error names the leg and the place.
pub fn check_clearance(route: &Route, wall: &[bool], w: usize, h: usize) -> Result<(), String> {
    let r_cells = (CLEARANCE_M * PX_PER_M).ceil() as i64 + 1;
    let blocked = |p: Point2| -> bool {
        let (ci, cj) = (
            (p.x * PX_PER_M).floor() as i64,
            (p.y * PX_PER_M).floor() as i64,
        );
        for j in cj - r_cells..=cj + r_cells {
            for i in ci - r_cells..=ci + r_cells {
                let wall_here = i < 0
                    || j < 0
                    || i >= w as i64
                    || j >= h as i64
                    || wall[j as usize * w + i as usize];
                if !wall_here {
                    continue;
                }
                // Distance from p to the cell's square.
                let (x0, y0) = (i as f64 / PX_PER_M, j as f64 / PX_PER_M);
                let dx = (x0 - p.x).max(p.x - (x0 + 1.0 / PX_PER_M)).max(0.0);
                let dy = (y0 - p.y).max(p.y - (y0 + 1.0 / PX_PER_M)).max(0.0);
                if dx.hypot(dy) < CLEARANCE_M {
                    return true;
                }
            }
        }
        false
    };
    let mut from = route.start.position();
    for (k, &to) in route.waypoints.iter().enumerate() {
        let n = (from.distance(&to) / 0.025).ceil().max(1.0) as usize;
        for s in 0..=n {
            let t = s as f64 / n as f64;
            let p = Point2::new(from.x + t * (to.x - from.x), from.y + t * (to.y - from.y));
            if blocked(p) {
                return Err(format!(
                    "leg {k} from ({:.2}, {:.2}) to ({:.2}, {:.2}) comes within {CLEARANCE_M} m of a wall at ({:.2}, {:.2})",
                    from.x, from.y, to.x, to.y, p.x, p.y
                ));
            }
        }
        from = to;
    }
    Ok(())
}

/// The legs of `route` as point pairs.
pub fn legs(route: &Route) -> Vec<(Point2, Point2)> {
    let mut from = route.start.position();
    route
        .waypoints
        .iter()
        .map(|&to| {
            let leg = (from, to);
            from = to;
            leg
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generate::floor::AreaKind;
    use crate::generate::rect::Rect;

    /// A corridor with two rooms above it, each behind a door.
    fn two_rooms() -> Floor {
        let mut f = Floor::new(0.2);
        let c = f.add_area(Rect::new(0.0, 0.0, 20.0, 2.0), AreaKind::Corridor);
        let a = f.add_area(Rect::new(2.0, 2.2, 6.0, 7.0), AreaKind::Room);
        let b = f.add_area(Rect::new(12.0, 2.2, 16.0, 7.0), AreaKind::Room);
        f.add_door(c, a, 3.0, 1.0).unwrap();
        f.add_door(c, b, 14.0, 1.0).unwrap();
        f
    }

    #[test]
    fn the_way_between_rooms_goes_out_one_door_along_the_corridor_and_in_the_other() {
        let f = two_rooms();
        let p = Portals::new(&f);
        let from = Stop::must(1, Point2::new(4.0, 5.0));
        let to = Stop::must(2, Point2::new(14.0, 5.0));
        let (way, len) = p.path(&from, &to).unwrap();
        let expect = [
            Point2::new(3.0, 3.7),
            Point2::new(3.0, 1.0),
            Point2::new(14.0, 1.0),
            Point2::new(14.0, 3.7),
            Point2::new(14.0, 5.0),
        ];
        assert_eq!(way, expect);
        let mut l = from.point.distance(&expect[0]);
        for w in expect.windows(2) {
            l += w[0].distance(&w[1]);
        }
        assert!((len - l).abs() < 1e-9);
    }

    #[test]
    fn a_short_tour_is_driven_again_until_it_is_long_enough() {
        let f = two_rooms();
        let stops = [
            Stop::must(0, Point2::new(1.0, 1.0)),
            Stop::may(1, Point2::new(4.0, 5.0)),
            Stop::must(0, Point2::new(19.0, 1.0)),
        ];
        let mut rng = rand::SeedableRng::seed_from_u64(1);
        // One lap is ~45 m: four laps, each out to the far end and back.
        let route = build(&f, &stops, 1.0, &mut rng).unwrap();
        assert!(
            (MIN_LENGTH_M..=MAX_LENGTH_M).contains(&route.length_m),
            "{route:?}"
        );
        let far = route
            .waypoints
            .iter()
            .filter(|p| **p == Point2::new(19.0, 1.0))
            .count();
        assert_eq!(far, 4, "{route:?}");
        assert_eq!(
            route.waypoints.last(),
            Some(&Point2::new(1.0, 1.0)),
            "back at the start"
        );
        // A tour that cannot reach the length in four laps fails clearly.
        let short = [stops[0], Stop::must(0, Point2::new(5.0, 1.0))];
        let err = build(&f, &short, 1.0, &mut rng).unwrap_err();
        assert!(err.contains("outside [150, 350]"), "{err}");
    }
}
