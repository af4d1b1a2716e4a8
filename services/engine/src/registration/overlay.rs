//! The map drawn over the drawing through the warp W, and the drawing over the map through
//! W⁻¹: what a user looks at to see whether the service understood their drawing
//! (`sketch-overlay.png`), and where the drawing says the rooms not yet visited are
//! (`sketch-in-map.png`).
//!
//! Sits after [`super::fit`]. On the drawing: its strokes in light grey, the map's occupied
//! cells carried onto it through W in red, a trajectory through W in blue. On the map: the
//! occupancy grid (free white, unknown grey, occupied black) on a canvas that also covers the
//! drawing's lines, which are drawn through W⁻¹ in blue. O(cells + poses + image).

use super::warp::Warp;
use crate::mapping::grid::OccupancyGrid;
use crate::sketch::Sketch;
use crate::sketch::overlay::strokes_on_white;
use image::{Rgb, RgbImage};
use sketchslam_types::{Point2, Pose2};

const STROKE: Rgb<u8> = Rgb([205, 205, 205]);
const WALL: Rgb<u8> = Rgb([210, 30, 30]);
const ROUTE: Rgb<u8> = Rgb([30, 60, 220]);
const DRAWN: Rgb<u8> = Rgb([40, 90, 230]);
const FREE: Rgb<u8> = Rgb([255, 255, 255]);
const UNKNOWN: Rgb<u8> = Rgb([205, 205, 205]);
const OCCUPIED: Rgb<u8> = Rgb([0, 0, 0]);

/// The map picture's longest side at most, pixels (a coarser pixel than the grid's cell
/// beyond it).
const MAX_MAP_SIDE_PX: f64 = 2048.0;
/// Margin around what the map picture shows, meters.
const MAP_MARGIN_M: f64 = 1.0;

/// The drawing's size, with `walls` (map meters) and `route` (map poses) drawn on it through
/// `warp`; what falls outside the image is left out.
pub fn render_map_on_drawing(
    sketch: &Sketch,
    warp: &Warp,
    walls: &[Point2],
    route: &[Pose2],
) -> RgbImage {
    let (w, h) = (sketch.width_px, sketch.height_px);
    let mut img = strokes_on_white(sketch, STROKE);
    let mut put = |p: Point2, colour: Rgb<u8>| {
        if p.x.is_finite() && p.y.is_finite() && p.x >= 0.0 && p.y >= 0.0 {
            let (x, y) = (p.x as u32, p.y as u32);
            if x < w && y < h {
                img.put_pixel(x, y, colour);
            }
        }
    };
    for p in walls {
        put(warp.to_pixel(*p), WALL);
    }
    for pose in route {
        put(warp.to_pixel(pose.position()), ROUTE);
    }
    img
}

/// The grid with the drawing's `lines` (map meters, polylines from
/// [`super::DrawingRegistration::lines_in_map`]) drawn over it, on a canvas covering both
/// (top row = largest y, as `map.png`), one pixel per grid cell unless that would exceed
/// `MAX_MAP_SIDE_PX` (2048).
pub fn render_drawing_on_map(grid: &OccupancyGrid, lines: &[Vec<Point2>]) -> RgbImage {
    let r = grid.resolution_m();
    let o = grid.origin();
    let mut lo = o;
    let mut hi = Point2::new(
        o.x + grid.width() as f64 * r,
        o.y + grid.height() as f64 * r,
    );
    for p in lines
        .iter()
        .flatten()
        .filter(|p| p.x.is_finite() && p.y.is_finite())
    {
        lo = Point2::new(lo.x.min(p.x), lo.y.min(p.y));
        hi = Point2::new(hi.x.max(p.x), hi.y.max(p.y));
    }
    let (lo, hi) = (
        Point2::new(lo.x - MAP_MARGIN_M, lo.y - MAP_MARGIN_M),
        Point2::new(hi.x + MAP_MARGIN_M, hi.y + MAP_MARGIN_M),
    );
    let extent = (hi.x - lo.x).max(hi.y - lo.y);
    let px_m = r.max(extent / MAX_MAP_SIDE_PX);
    let (w, h) = (
        ((hi.x - lo.x) / px_m).ceil().max(1.0) as u32,
        ((hi.y - lo.y) / px_m).ceil().max(1.0) as u32,
    );
    // Pixel (x, y) shows map point (lo.x + (x + ½)·px, hi.y − (y + ½)·px).
    let mut img = RgbImage::from_fn(w, h, |x, y| {
        let p = Point2::new(
            lo.x + (x as f64 + 0.5) * px_m,
            hi.y - (y as f64 + 0.5) * px_m,
        );
        match grid.cell_of(p) {
            Some((c, row)) if grid.is_occupied(c, row) => OCCUPIED,
            Some((c, row)) if grid.is_free(c, row) => FREE,
            _ => UNKNOWN,
        }
    });
    let to_px = |p: Point2| ((p.x - lo.x) / px_m, (hi.y - p.y) / px_m);
    for line in lines {
        for pair in line.windows(2) {
            let ((x0, y0), (x1, y1)) = (to_px(pair[0]), to_px(pair[1]));
            let n = (x1 - x0).abs().max((y1 - y0).abs()).ceil().clamp(1.0, 1e5) as usize;
            for i in 0..=n {
                let t = i as f64 / n as f64;
                let (x, y) = (x0 + t * (x1 - x0), y0 + t * (y1 - y0));
                if x >= 0.0 && y >= 0.0 && (x as u32) < w && (y as u32) < h {
                    img.put_pixel(x as u32, y as u32, DRAWN);
                }
            }
        }
    }
    img
}
