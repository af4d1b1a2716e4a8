//! The map drawn over the drawing through the warp W: what a user looks at to see whether
//! the service understood their drawing (and what `sketch-overlay.png` will serve).
//!
//! Sits after [`super::fit`]: the drawing's strokes in light grey, the map's occupied cells
//! carried onto the drawing through W in red, a trajectory through W in blue. O(cells +
//! poses + image).

use super::warp::Warp;
use crate::sketch::Sketch;
use crate::sketch::overlay::strokes_on_white;
use image::{Rgb, RgbImage};
use sketchslam_types::{Point2, Pose2};

const STROKE: Rgb<u8> = Rgb([205, 205, 205]);
const WALL: Rgb<u8> = Rgb([210, 30, 30]);
const ROUTE: Rgb<u8> = Rgb([30, 60, 220]);

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
