//! The drawn segments bucketed on a grid of the drawing, so that the fit's association
//! ([`super::fit`]) reads only the segments that can lie within its gate of a point instead
//! of every drawn line.
//!
//! Sits inside [`super::fit::fit_warp`], built once per fit. A cell of side `c` lists every
//! segment whose distance from the cell's centre is at most `reach + c/√2`, so a point in
//! the cell finds every segment within `reach` of it in the cell's list (triangle
//! inequality). Points outside the grid (the segments' box grown by `reach`) lie farther
//! than `reach` from every segment.
//!
//! Cost: O(L · (ℓ + 2r)² / c²) to build (L segments of length ℓ, r the reach), with `c = r`
//! a few cells per unit of segment length; a lookup is O(1) plus its list.

use super::fit::{Segment, bounds};
use sketchslam_types::Point2;

/// Segment indices per cell.
pub(super) struct SegmentGrid {
    origin_px: Point2,
    cell_px: f64,
    columns: usize,
    rows: usize,
    cells: Vec<Vec<u32>>,
}

impl SegmentGrid {
    /// Buckets `segments` for lookups within `reach_px` (pixels, drawing frame). `None`
    /// without segments or with a reach that is not a positive number.
    pub(super) fn new(segments: &[Segment], reach_px: f64) -> Option<Self> {
        if segments.is_empty() || !(reach_px > 0.0 && reach_px.is_finite()) {
            return None;
        }
        let (lo, hi) = bounds(segments.iter().flat_map(|s| [s.a, s.b]));
        // At most 512 cells a side: a wider floor gets larger cells.
        let span = (hi.x - lo.x).max(hi.y - lo.y) + 2.0 * reach_px;
        let cell_px = reach_px.max(span / 512.0);
        let origin_px = Point2::new(lo.x - reach_px, lo.y - reach_px);
        let columns = ((hi.x - lo.x + 2.0 * reach_px) / cell_px).ceil() as usize + 1;
        let rows = ((hi.y - lo.y + 2.0 * reach_px) / cell_px).ceil() as usize + 1;
        let mut cells = vec![Vec::new(); columns * rows];
        let grow = reach_px + cell_px * std::f64::consts::FRAC_1_SQRT_2;
        for (index, s) in segments.iter().enumerate() {
            let cell = |v: f64, o: f64, n: usize| {
                (((v - o) / cell_px).floor().max(0.0) as usize).min(n - 1)
            };
            let (i0, i1) = (
                cell(s.a.x.min(s.b.x) - grow, origin_px.x, columns),
                cell(s.a.x.max(s.b.x) + grow, origin_px.x, columns),
            );
            let (j0, j1) = (
                cell(s.a.y.min(s.b.y) - grow, origin_px.y, rows),
                cell(s.a.y.max(s.b.y) + grow, origin_px.y, rows),
            );
            for j in j0..=j1 {
                for i in i0..=i1 {
                    let centre = Point2::new(
                        origin_px.x + (i as f64 + 0.5) * cell_px,
                        origin_px.y + (j as f64 + 0.5) * cell_px,
                    );
                    if centre.distance(&s.foot(centre)) <= grow {
                        cells[j * columns + i].push(index as u32);
                    }
                }
            }
        }
        Some(Self {
            origin_px,
            cell_px,
            columns,
            rows,
            cells,
        })
    }

    /// The segments that may lie within the reach of `p` (a superset of those that do);
    /// empty outside the grid.
    pub(super) fn near(&self, p: Point2) -> &[u32] {
        let fx = (p.x - self.origin_px.x) / self.cell_px;
        let fy = (p.y - self.origin_px.y) / self.cell_px;
        if !(fx >= 0.0 && fy >= 0.0) {
            return &[];
        }
        let (i, j) = (fx as usize, fy as usize);
        if i >= self.columns || j >= self.rows {
            return &[];
        }
        &self.cells[j * self.columns + i]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::rngs::StdRng;
    use rand::{Rng, SeedableRng};

    fn segment(a: Point2, b: Point2) -> Segment {
        Segment::between(a, b).expect("distinct ends")
    }

    #[test]
    fn every_segment_within_the_reach_is_listed() {
        let mut rng = StdRng::seed_from_u64(7);
        let mut p = || Point2::new(rng.random_range(0.0..400.0), rng.random_range(-300.0..0.0));
        let segments: Vec<Segment> = (0..60).map(|_| segment(p(), p())).collect();
        let reach = 30.0;
        let grid = SegmentGrid::new(&segments, reach).unwrap();
        let mut rng = StdRng::seed_from_u64(8);
        for _ in 0..5000 {
            let q = Point2::new(
                rng.random_range(-60.0..460.0),
                rng.random_range(-360.0..60.0),
            );
            let near = grid.near(q);
            for (k, s) in segments.iter().enumerate() {
                if q.distance(&s.foot(q)) <= reach {
                    assert!(near.contains(&(k as u32)), "{q:?}: segment {k} missing");
                }
            }
        }
    }

    #[test]
    fn a_point_far_from_every_segment_lists_none_of_them_near() {
        let segments = vec![segment(Point2::new(0.0, 0.0), Point2::new(100.0, 0.0))];
        let grid = SegmentGrid::new(&segments, 10.0).unwrap();
        assert!(grid.near(Point2::new(50.0, 200.0)).is_empty());
        assert!(grid.near(Point2::new(-500.0, 0.0)).is_empty());
        assert_eq!(grid.near(Point2::new(50.0, 5.0)), &[0]);
    }
}
