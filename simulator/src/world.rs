//! The truth world: an occupancy image turned into a grid of wall cells, and exact ray
//! casting through it.
//!
//! This is the bottom of the simulator: the LiDAR model casts its beams here, the scenario
//! loader checks the start pose and the path legs against it, and the renderer draws it.
//!
//! # Frames
//!
//! The world frame has its origin at the image's bottom-left corner, x to the right and y up,
//! `resolution_m` meters per pixel. Cell `(i, j)` (column `i` from the left, row `j` from the
//! bottom) covers `[i·r, (i+1)·r) × [j·r, (j+1)·r)`. Image row `v` (from the top) is grid row
//! `j = height − 1 − v`. Everything outside the image is wall, so every ray ends.

use crate::error::SimError;
use sketchslam_types::Point2;
use std::path::Path;

/// Pixels darker than this (8-bit luma) are walls.
pub const WALL_THRESHOLD: u8 = 128;

/// A grid of wall / free cells in the world frame.
#[derive(Debug, Clone)]
pub struct World {
    width: usize,
    height: usize,
    resolution_m: f64,
    /// The grid with a one-cell wall border, row-major from the bottom row up: cell
    /// `(i, j)` is `padded[(j + 1)·(width + 2) + i + 1]`. The border stands for "outside is
    /// wall" and lets the ray walk index without bounds tests on `i` and `j`.
    padded: Vec<bool>,
}

/// Why a world could not be built from its parts.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum WorldError {
    /// The image could not be opened or decoded.
    #[error("{0}")]
    Decode(String),
    /// Zero width or height.
    #[error("the image is empty ({width}x{height} pixels)")]
    Empty {
        /// Width in pixels.
        width: usize,
        /// Height in pixels.
        height: usize,
    },
    /// The resolution is not a positive finite number.
    #[error("resolution must be a positive finite number of meters per pixel, got {0}")]
    Resolution(f64),
    /// `walls.len() != width·height`.
    #[error("{len} cells given for a {width}x{height} grid")]
    Size {
        /// Width in cells.
        width: usize,
        /// Height in cells.
        height: usize,
        /// Number of cells given.
        len: usize,
    },
}

impl World {
    /// Loads a world from an image file (PNG or JPEG): luma below [`WALL_THRESHOLD`] is wall.
    pub fn load(path: &Path, resolution_m: f64) -> Result<World, WorldError> {
        let img = decode_luma(path)?;
        let (w, h) = (img.width() as usize, img.height() as usize);
        let walls = img.pixels().map(|p| p.0[0] < WALL_THRESHOLD).collect();
        World::from_walls(w, h, resolution_m, walls)
    }

    /// A world from `width × height` cells, `walls` row-major with row 0 at the TOP (image
    /// order), so tests can write grids as they look.
    pub fn from_walls(
        width: usize,
        height: usize,
        resolution_m: f64,
        walls: Vec<bool>,
    ) -> Result<World, WorldError> {
        if !(resolution_m.is_finite() && resolution_m > 0.0) {
            return Err(WorldError::Resolution(resolution_m));
        }
        if width == 0 || height == 0 {
            return Err(WorldError::Empty { width, height });
        }
        if walls.len() != width * height {
            return Err(WorldError::Size {
                width,
                height,
                len: walls.len(),
            });
        }
        // Flip rows so that grid row j grows with y, and add the wall border.
        let stride = width + 2;
        let mut padded = Vec::with_capacity(stride * (height + 2));
        padded.resize(stride, true);
        for row in walls.chunks_exact(width).rev() {
            padded.push(true);
            padded.extend_from_slice(row);
            padded.push(true);
        }
        padded.resize(stride * (height + 2), true);
        Ok(World {
            width,
            height,
            resolution_m,
            padded,
        })
    }

    /// Width in cells (pixels).
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in cells (pixels).
    pub fn height(&self) -> usize {
        self.height
    }

    /// Meters per cell.
    pub fn resolution_m(&self) -> f64 {
        self.resolution_m
    }

    /// Width and height of the world in meters.
    pub fn size_m(&self) -> (f64, f64) {
        (
            self.width as f64 * self.resolution_m,
            self.height as f64 * self.resolution_m,
        )
    }

    /// True when `p` lies inside the image (borders included on the low side).
    pub fn contains(&self, p: Point2) -> bool {
        let (w, h) = self.size_m();
        p.x.is_finite() && p.y.is_finite() && p.x >= 0.0 && p.y >= 0.0 && p.x < w && p.y < h
    }

    /// True when the cell `(i, j)` (column from the left, row from the bottom) is a wall;
    /// cells outside the grid are walls.
    pub fn is_wall_cell(&self, i: i64, j: i64) -> bool {
        if i < 0 || j < 0 || i >= self.width as i64 || j >= self.height as i64 {
            return true;
        }
        self.padded[self.padded_index(i, j)]
    }

    /// True when the point `p` (meters, world frame) is in a wall cell, outside the world, or
    /// not finite.
    pub fn is_wall(&self, p: Point2) -> bool {
        if !self.contains(p) {
            return true;
        }
        let (i, j) = self.cell_of(p);
        self.is_wall_cell(i, j)
    }

    /// Index in `padded` of the in-grid cell `(i, j)`.
    fn padded_index(&self, i: i64, j: i64) -> usize {
        (j + 1) as usize * (self.width + 2) + (i + 1) as usize
    }

    /// The cell holding `p`, which must be finite.
    fn cell_of(&self, p: Point2) -> (i64, i64) {
        (
            (p.x / self.resolution_m).floor() as i64,
            (p.y / self.resolution_m).floor() as i64,
        )
    }

    /// Distance in meters from `origin` along the direction `angle_rad` (counter-clockwise
    /// from +x) to the first boundary of a wall cell, or `None` when it is beyond
    /// `max_range_m`. An origin inside a wall (or outside the world) gives `Some(0.0)`.
    ///
    /// # Algorithm
    ///
    /// Exact grid traversal, J. Amanatides and A. Woo, "A Fast Voxel Traversal Algorithm for
    /// Ray Tracing", Eurographics 1987. In cell units the ray is `o + t·d` with
    /// `d = (cos α, sin α)`, so `t` is the travelled length. With the current cell `(i, j)`,
    /// the steps `s = (sign dₓ, sign d_y)`, and
    ///
    /// ```text
    /// t_max_x   = (i + [sₓ > 0] − oₓ) / dₓ        (ray length to the next vertical line)
    /// t_delta_x = 1 / |dₓ|                        (ray length between vertical lines)
    /// ```
    ///
    /// (likewise in y), each iteration crosses whichever grid line is nearer
    /// (`min(t_max_x, t_max_y)`), moves one cell in that axis and adds `t_delta` to its
    /// `t_max`. The first wall cell entered ends the walk at `t = min` of the previous step:
    /// the exact distance to the wall's boundary, not a sampled approximation. When the ray
    /// passes exactly through a cell corner, the x neighbour is visited first.
    ///
    /// Cost: O(n) with `n ≤ |Δi| + |Δj| + 1 ≤ √2·max_range / resolution + 2` cells visited,
    /// two comparisons and one addition each; no allocation.
    pub fn cast(&self, origin: Point2, angle_rad: f64, max_range_m: f64) -> Option<f64> {
        let (dx, dy) = (angle_rad.cos(), angle_rad.sin());
        self.first_wall_along(origin, dx, dy, max_range_m)
    }

    /// The first point of the segment `a → b` that lies in a wall cell (or outside the
    /// world), or `None` when the whole segment is free. Same traversal and cost as
    /// [`World::cast`], with `max_range = |b − a|`.
    pub fn segment_hits_wall(&self, a: Point2, b: Point2) -> Option<Point2> {
        if self.is_wall(a) {
            return Some(a);
        }
        if !(b.x.is_finite() && b.y.is_finite()) {
            return Some(a);
        }
        let len_m = a.distance(&b);
        if len_m == 0.0 {
            return None;
        }
        let (dx, dy) = ((b.x - a.x) / len_m, (b.y - a.y) / len_m);
        let t_m = self.first_wall_along(a, dx, dy, len_m)?;
        Some(Point2::new(a.x + dx * t_m, a.y + dy * t_m))
    }

    /// The Amanatides-Woo walk shared by [`World::cast`] and [`World::segment_hits_wall`]:
    /// `(dx, dy)` is a unit direction, lengths in meters. Returns the length to the first
    /// wall cell's boundary when it is `≤ max_range_m`.
    fn first_wall_along(&self, origin: Point2, dx: f64, dy: f64, max_range_m: f64) -> Option<f64> {
        if !(dx.is_finite() && dy.is_finite() && max_range_m >= 0.0) {
            return None;
        }
        if self.is_wall(origin) {
            return Some(0.0);
        }
        // Work in cell units: t counts cells of length 1 along the unit direction.
        let r = self.resolution_m;
        let (ox, oy) = (origin.x / r, origin.y / r);
        let max_t = max_range_m / r;
        let (i, j) = (ox.floor() as i64, oy.floor() as i64);

        let (step_i, mut t_max_x, t_delta_x) = axis_setup(ox, i, dx);
        let (step_j, mut t_max_y, t_delta_y) = axis_setup(oy, j, dy);
        // Walk the padded index directly: ±1 per column, ±stride per row. The origin is
        // in the grid (checked above) and the walk stops at the wall border at the latest,
        // so the index stays inside `padded`.
        let step_x = step_i as isize;
        let step_y = step_j as isize * (self.width + 2) as isize;
        let mut index = self.padded_index(i, j);

        loop {
            let t = if t_max_x <= t_max_y {
                let t = t_max_x;
                index = index.wrapping_add_signed(step_x);
                t_max_x += t_delta_x;
                t
            } else {
                let t = t_max_y;
                index = index.wrapping_add_signed(step_y);
                t_max_y += t_delta_y;
                t
            };
            if t > max_t {
                return None;
            }
            // `get` keeps a logic error from becoming a panic: off the grid is wall.
            if self.padded.get(index).copied().unwrap_or(true) {
                return Some(t * r);
            }
        }
    }
}

/// For one axis: the cell step (±1), the ray length to the first grid line crossed, and the
/// ray length between grid lines. A direction component of zero never crosses a line.
fn axis_setup(o: f64, cell: i64, d: f64) -> (i64, f64, f64) {
    if d > 0.0 {
        (1, ((cell + 1) as f64 - o) / d, 1.0 / d)
    } else if d < 0.0 {
        (-1, (cell as f64 - o) / d, -1.0 / d)
    } else {
        (0, f64::INFINITY, f64::INFINITY)
    }
}

/// Opens and decodes a PNG or JPEG (format guessed from the content) as 8-bit luma.
pub(crate) fn decode_luma(path: &Path) -> Result<image::GrayImage, WorldError> {
    let reader = image::ImageReader::open(path)
        .map_err(|e| WorldError::Decode(format!("cannot open: {e}")))?
        .with_guessed_format()
        .map_err(|e| WorldError::Decode(format!("cannot read: {e}")))?;
    let img = reader
        .decode()
        .map_err(|e| WorldError::Decode(format!("does not decode as PNG or JPEG: {e}")))?;
    Ok(img.to_luma8())
}

/// Loads a world for code paths that report [`SimError`] (the key is `world.image`).
pub(crate) fn load_for(
    scenario_file: &Path,
    line: Option<usize>,
    image: &Path,
    resolution_m: f64,
) -> Result<World, SimError> {
    World::load(image, resolution_m).map_err(|e| SimError::Image {
        file: scenario_file.to_path_buf(),
        line,
        key: "world.image".into(),
        image: image.to_path_buf(),
        message: e.to_string(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 4×3 cells of 1 m, wall only at the top-right (image row 0, column 3).
    fn tiny() -> World {
        let mut walls = vec![false; 12];
        walls[3] = true;
        World::from_walls(4, 3, 1.0, walls).unwrap()
    }

    #[test]
    fn rows_are_flipped_to_y_up() {
        let w = tiny();
        assert!(w.is_wall(Point2::new(3.5, 2.5)));
        assert!(!w.is_wall(Point2::new(3.5, 0.5)));
        assert!(w.is_wall(Point2::new(-0.1, 1.0)));
        assert!(w.is_wall(Point2::new(1.0, 3.0)));
        assert!(w.is_wall(Point2::new(f64::NAN, 1.0)));
    }

    #[test]
    fn bad_parts_are_errors() {
        assert!(World::from_walls(0, 3, 1.0, vec![]).is_err());
        assert!(World::from_walls(2, 2, -1.0, vec![false; 4]).is_err());
        assert!(World::from_walls(2, 2, 1.0, vec![false; 3]).is_err());
    }

    #[test]
    fn rays_stop_at_the_image_border() {
        let w = tiny();
        // From (0.5, 0.5) straight right: no wall in row 0, the border at x = 4.
        let r = w.cast(Point2::new(0.5, 0.5), 0.0, 100.0).unwrap();
        assert!((r - 3.5).abs() < 1e-12);
        assert_eq!(w.cast(Point2::new(0.5, 0.5), 0.0, 3.0), None);
        // Up along column 3 hits the wall cell at y = 2.
        let r = w.cast(Point2::new(3.5, 0.25), std::f64::consts::FRAC_PI_2, 10.0);
        assert!((r.unwrap() - 1.75).abs() < 1e-12);
    }

    #[test]
    fn segments() {
        let w = tiny();
        assert_eq!(
            w.segment_hits_wall(Point2::new(0.5, 0.5), Point2::new(3.5, 1.5)),
            None
        );
        let hit = w
            .segment_hits_wall(Point2::new(3.5, 0.5), Point2::new(3.5, 2.5))
            .unwrap();
        assert!((hit.y - 2.0).abs() < 1e-12 && (hit.x - 3.5).abs() < 1e-12);
    }
}
