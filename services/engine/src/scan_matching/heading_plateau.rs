//! How well a correlative match pins its heading down: the spread of the headings whose
//! best score reaches a fraction of the top, the angular twin of
//! [`LikelihoodField::translation_covariance`].
//!
//! Sits after the correlative search in the loop-closure step
//! ([`crate::back_end::loop_closure`]): a loop edge's heading variance is read from the
//! match itself instead of being set once for every match.
//!
//! Method: the score is read from the field interpolated bilinearly
//! ([`LikelihoodField::likelihood_bilinear`]), so that turns and shifts smaller than a cell
//! change it (read cell by cell, a room's score stays flat over ±0.6° of turn: a point 3 m
//! out moves half a cell). From the match `(t*, θ*)` the headings `θ* + k·s` are stepped
//! outward, `s` a quarter of the search's own angular step (Hess et al. 2016, eq. 7: the
//! farthest point moves about one cell). At each heading the translation is re-optimized
//! by a hill climb in quarter-cell steps from the previous heading's best shift — rotating
//! a scan about its sensor moves its points' centroid, which a shift undoes; what no shift
//! undoes is what pins the heading. A side stops at the first heading whose best score
//! falls below `fraction` of the top. The kept headings, weighted uniformly, give
//!
//! ```text
//! σ²_θ = Var(kept headings) + s²/12,
//! ```
//!
//! one step's own rounding included, as [`super::correlative::plateau_spread`] adds one
//! cell's. For points on a straight wall at along-wall distances `x` from the foot of the
//! sensor's perpendicular, a turn by `δ` moves each point off the wall by `δ·x`, so the
//! score falls by `≈ δ²·E[x²] / 2σ²_k` (`σ_k` the field's kernel) and the plateau reaches
//! `δ = σ_k √(2(1 − fraction) / E[x²])`: the longer the wall seen, the tighter the heading.
//!
//! Cost: O(a · c · 9 · n) for `a` headings kept, `c` climbing moves each (one or two once
//! the shift follows) and `n` points.

use super::correlative::{LikelihoodField, angular_step_rad};
use sketchslam_types::{Point2, Pose2};

/// At most this many hill-climbing moves per heading.
const MAX_CLIMB_MOVES: usize = 64;

/// Headings stepped per step of the search's own, and shifts per cell (module doc).
const SUBSTEPS: f64 = 4.0;

impl LikelihoodField {
    /// The heading variance (rad²) of `points` matched at `best`: the spread of the
    /// headings within ±`max_rad` of its own whose best score, translation re-optimized,
    /// reaches `fraction` of the top, plus one angular step's own variance (module doc).
    /// Without a finite point: the variance of a uniform heading over ±`max_rad`.
    pub fn heading_variance(
        &self,
        points: &[Point2],
        best: &Pose2,
        max_rad: f64,
        fraction: f64,
    ) -> f64 {
        let points: Vec<Point2> = points
            .iter()
            .copied()
            .filter(|p| p.x.is_finite() && p.y.is_finite())
            .collect();
        let max_rad = max_rad.max(0.0);
        if points.is_empty() || !best.is_finite() {
            return (2.0 * max_rad).powi(2) / 12.0;
        }
        let res = self.config().resolution_m;
        let step_rad = angular_step_rad(&points, res) / SUBSTEPS;
        let steps = (max_rad / step_rad).ceil() as i64;
        let at = |k: i64, from: (f64, f64)| {
            let pose = Pose2::new(best.x, best.y, best.heading_rad + k as f64 * step_rad);
            let placed: Vec<Point2> = points.iter().map(|p| pose.transform_point(p)).collect();
            self.climb(&placed, from, res / SUBSTEPS)
        };
        let (s0, shift0) = at(0, (0.0, 0.0));
        let mut top = s0;
        let mut kept = vec![(0i64, s0)];
        for side in [-1i64, 1] {
            let mut shift = shift0;
            for k in 1..=steps {
                let (s, moved) = at(side * k, shift);
                if s < fraction * top {
                    break;
                }
                top = top.max(s);
                shift = moved;
                kept.push((side * k, s));
            }
        }
        let threshold = fraction * top;
        let near: Vec<f64> = kept
            .iter()
            .filter(|(_, s)| *s >= threshold)
            .map(|&(k, _)| k as f64 * step_rad)
            .collect();
        let n = near.len().max(1) as f64;
        let mean = near.iter().sum::<f64>() / n;
        let spread = near.iter().map(|a| (a - mean).powi(2)).sum::<f64>() / n;
        spread + step_rad * step_rad / 12.0
    }

    /// The best smooth score of the `placed` points over shifts reached by climbing, in
    /// steps of `step_m`, from `from` to the best of its eight neighbours while that
    /// improves; and that shift.
    fn climb(&self, placed: &[Point2], from: (f64, f64), step_m: f64) -> (f64, (f64, f64)) {
        let score = |(dx, dy): (f64, f64)| {
            placed
                .iter()
                .map(|p| self.likelihood_bilinear(Point2::new(p.x + dx, p.y + dy)))
                .sum::<f64>()
                / placed.len().max(1) as f64
        };
        let mut at = from;
        let mut best = score(at);
        for _ in 0..MAX_CLIMB_MOVES {
            let mut next = None;
            for dy in -1..=1 {
                for dx in -1..=1 {
                    if dx == 0 && dy == 0 {
                        continue;
                    }
                    let shift = (at.0 + dx as f64 * step_m, at.1 + dy as f64 * step_m);
                    let s = score(shift);
                    if s > next.map_or(best, |(b, _)| b) {
                        next = Some((s, shift));
                    }
                }
            }
            match next {
                Some((s, moved)) => (best, at) = (s, moved),
                None => break,
            }
        }
        (best, at)
    }
}

#[cfg(test)]
mod tests {
    use super::super::correlative::tests::room;
    use super::super::correlative::{CorrelativeConfig, voxel_filter};
    use super::*;

    /// Points every 2 cm along the wall y = 1 from x = −`half_m` to `half_m`.
    fn wall(half_m: f64) -> Vec<Point2> {
        let n = (2.0 * half_m / 0.02).round() as usize;
        (0..=n)
            .map(|i| Point2::new(-half_m + 0.02 * i as f64, 1.0))
            .collect()
    }

    /// Hand-worked (module doc): a wall seen over x ∈ [−L, L] has E[x²] = L²/3, so with
    /// the kernel σ = 0.1 m and fraction 0.95 the plateau reaches
    /// δ = 0.1·√(0.1·3/L²) = 0.0548/L rad, and a uniform spread over ±δ has σ = δ/√3:
    /// 6.3 mrad (0.36°) for L = 5 m, twice that for L = 2.5 m. The cells' rounding and the
    /// step's own variance add a little; the halved wall must come out about twice as
    /// loose.
    #[test]
    fn a_longer_wall_pins_the_heading_tighter_as_worked_by_hand() {
        let sigma = |half_m: f64| {
            let reference = wall(half_m);
            let field = LikelihoodField::new(&reference, CorrelativeConfig::default());
            field
                .heading_variance(&reference, &Pose2::IDENTITY, 0.2, 0.95)
                .sqrt()
        };
        let (long, short) = (sigma(5.0), sigma(2.5));
        assert!((0.004..0.010).contains(&long), "{long}");
        assert!((0.008..0.020).contains(&short), "{short}");
        let ratio = short / long;
        assert!((1.5..2.6).contains(&ratio), "{long} {short} {ratio}");
    }

    /// A turn about the sensor that a shift undoes is not counted: seen from off its
    /// middle, the room's scan moves its centroid as it turns, and the walls still pin the
    /// heading to about a degree (0.82°: its walls' along-wall lever arms are short, and the
    /// kernel σ = 0.1 m is wide against them). The same room and view three times larger:
    /// every lever arm triples, so by the module doc's formula the plateau is a third as
    /// wide.
    #[test]
    fn a_room_three_times_larger_pins_the_heading_three_times_tighter() {
        let sigma_deg = |scale: f64| {
            let room: Vec<Point2> = room()
                .iter()
                .map(|p| Point2::new(scale * p.x, scale * p.y))
                .collect();
            let field = LikelihoodField::new(&room, CorrelativeConfig::default());
            let seen_from = Pose2::new(-2.0 * scale, -scale, 0.3);
            let scan: Vec<Point2> = room
                .iter()
                .map(|p| seen_from.inverse_transform_point(p))
                .collect();
            let scan = voxel_filter(&scan, 0.05);
            field
                .heading_variance(&scan, &seen_from, 0.2, 0.95)
                .sqrt()
                .to_degrees()
        };
        let (small, large) = (sigma_deg(1.0), sigma_deg(3.0));
        assert!((0.4..1.5).contains(&small), "{small}");
        let ratio = small / large;
        assert!((2.2..3.8).contains(&ratio), "{small} {large} {ratio}");
    }

    #[test]
    fn nothing_to_match_gives_the_whole_window() {
        let field = LikelihoodField::new(&room(), CorrelativeConfig::default());
        let v = field.heading_variance(&[], &Pose2::IDENTITY, 0.1, 0.95);
        assert!((v - 0.2f64 * 0.2 / 12.0).abs() < 1e-12, "{v}");
    }
}
