//! How likely a scan is from a particle on the drawing: MCL's observation model.
//!
//! Where in the pipeline: inside [`super::mcl::SketchMcl::update`], once per particle and
//! scan. Two models, chosen by [`super::mcl::MclConfig::observation`]:
//!
//! - [`ObservationModel::RayCast`], the paper's eq. (3): each beam's pseudo-range `l` is
//!   ray-traced on the drawing's lines from the particle, and
//!   `p(r | x) = z_hit · N(r; s·l, σ(r)²) + z_rand / r_max`.
//!   Symmetric: a return short of the drawn wall (a chair, a person) and one beyond it
//!   (seen through a drawn wall) both fall to the floor. Cost: one cast per beam.
//! - [`ObservationModel::LikelihoodField`], after Thrun, Burgard & Fox, *Probabilistic
//!   Robotics* §6.4, with the particle's own scale `s` (meters per pixel): the beam's end
//!   `e = (u, v) + (r / s)·(cos φ, −sin φ)`, `φ = θ + α`, is looked up in the drawing's
//!   distance field, `d = s · D(e)` meters, and
//!
//!   `p(r | x) = z_hit · N(d; 0, σ(r)²) + z_miss / r_max`,
//!
//!   where `z_miss` tells apart the two ways a return can miss every drawn wall. An end
//!   more than `3σ(r)` from every line is *unexplained*; the ray from the particle to
//!   `r − 3σ(r)` is then traced: when it crosses a drawn line, the return was seen through
//!   a drawn wall (`z_miss = z_seen_through`: a door drawn closed, or the particle on the
//!   wrong side of a wall), otherwise it stopped short in the drawing's free space
//!   (`z_miss = z_rand`: furniture, people, walls nobody drew). So the model is tolerant
//!   of clutter, which no drawing shows, and strict about seeing through what is drawn.
//!   It is smooth in the pose (a beam's end slides along a wall, where the cast range
//!   jumps at every door and corner). Cost: one distance lookup per beam, and one cast
//!   for the unexplained beams only (a converged cloud in a drawn room: few).
//!
//! `σ(r) = sigma_range_m + sigma_range_rel · r` in both: the drawing's error, which grows
//! with the distance drawn. Pure: values in, values out.

use super::mcl::MclConfig;
use crate::sketch::SketchPose;
use crate::sketch::raycast::SketchRaycaster;

/// A beam end farther than this many `σ(r)` from every drawn line is unexplained by the
/// drawing (the Gaussian has fallen below 1.1 % of its peak).
pub const UNEXPLAINED_SIGMAS: f64 = 3.0;

/// Which observation model MCL weighs its particles with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ObservationModel {
    /// The paper's eq. (3): ray-traced pseudo-ranges (the default: with the likelihood
    /// field, MCL is better on six of the eight shared drawings and costs a fifth, but
    /// eq. (5)'s heading pull, which reads MCL, broke paper-env2 D's map, 0.015 → 0.134 m;
    /// README, "MCL's observation model").
    #[default]
    RayCast,
    /// The drawing's distance field at the beam's end, strict about returns seen
    /// through a drawn wall.
    LikelihoodField,
}

/// One used beam of a scan: its angle in the scanner frame, its range and `σ(r)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Beam {
    /// Angle from the scanner's heading, radians (counter-clockwise).
    pub angle_rad: f64,
    /// Measured range, meters.
    pub range_m: f64,
    /// `σ(r)`, meters.
    pub sigma_m: f64,
    /// `(cos α, sin α)`, so a particle's beam direction is one rotation, not a `sin_cos`.
    cos_sin: (f64, f64),
}

impl Beam {
    /// The beam of range `range_m` at `angle_rad` with `σ(r)` from `config`.
    pub fn new(angle_rad: f64, range_m: f64, config: &MclConfig) -> Self {
        Self {
            angle_rad,
            range_m,
            sigma_m: config.sigma_at_m(range_m),
            cos_sin: (angle_rad.cos(), angle_rad.sin()),
        }
    }
}

impl ObservationModel {
    /// `Σ_i ln p(r_i | x)` of the particle `pose` (inside the drawing's image) over
    /// `beams`; `range_max_m` is the scanner's range, whose inverse scales the floors.
    /// O(beams) lookups and casts as the module says.
    pub fn log_likelihood(
        self,
        pose: &SketchPose,
        beams: &[Beam],
        raycaster: &SketchRaycaster,
        config: &MclConfig,
        range_max_m: f64,
    ) -> f64 {
        let floor = config.z_rand / range_max_m;
        let norm = |sigma: f64| config.z_hit / (sigma * std::f64::consts::TAU.sqrt());
        let view = ParticleView::new(pose, raycaster, range_max_m);
        match self {
            ObservationModel::RayCast => beams
                .iter()
                .map(|b| {
                    // No line within r_max: e = ∞, only the floor is left.
                    let e = view.range_error(b);
                    (norm(b.sigma_m) * (-0.5 * e * e).exp() + floor).ln()
                })
                .sum(),
            ObservationModel::LikelihoodField => {
                let through = config.z_seen_through / range_max_m;
                // The product of the beams' likelihoods, one logarithm per particle: each
                // factor lies in [floor, peak], so 60 beams stay far inside f64's range;
                // the product is logged and restarted every `LOG_EVERY` beams all the same.
                let (mut ll, mut product) = (0.0, 1.0);
                for (k, b) in beams.iter().enumerate() {
                    let e = view.end_error(b);
                    // Beyond 6σ the Gaussian is below 10⁻⁷ of its peak: left out.
                    let hit = if e < 6.0 {
                        norm(b.sigma_m) * (-0.5 * e * e).exp()
                    } else {
                        0.0
                    };
                    let miss = if e > UNEXPLAINED_SIGMAS && sees_through(pose, b, raycaster) {
                        through
                    } else {
                        floor
                    };
                    product *= hit + miss;
                    if (k + 1) % LOG_EVERY == 0 {
                        ll += product.ln();
                        product = 1.0;
                    }
                }
                ll + product.ln()
            }
        }
    }

    /// Mean per-beam agreement, 0..1, of the pose with the scan: the Gaussian part of
    /// `p(r | x)` over its peak — `exp(−(r − s·l)² / (2σ²))` with eq. (3) (0 when the ray
    /// hits no line), `exp(−d² / (2σ²))` with the likelihood field, 0 for a return it
    /// counts as seen through a drawn wall. ≈ 1 when the scan lies on the drawing, → 0
    /// when the pose is lost: MCL's score, which its breakdown detector reads (a model
    /// judged by the other's score looks lost where it is not). One cast per beam.
    pub fn agreement(
        self,
        pose: &SketchPose,
        beams: &[Beam],
        raycaster: &SketchRaycaster,
        range_max_m: f64,
    ) -> f64 {
        if beams.is_empty() {
            return 0.0;
        }
        let view = ParticleView::new(pose, raycaster, range_max_m);
        let sum: f64 = beams
            .iter()
            .map(|b| {
                let e = match self {
                    ObservationModel::RayCast => view.range_error(b),
                    ObservationModel::LikelihoodField => {
                        let e = view.end_error(b);
                        if e.is_finite() && !sees_through(pose, b, raycaster) {
                            e
                        } else {
                            f64::INFINITY
                        }
                    }
                };
                (-0.5 * e * e).exp()
            })
            .sum();
        sum / beams.len() as f64
    }
}

/// One particle's beams on the drawing: the standardized error `e` of a beam under each
/// model, which both the likelihood and the score read.
struct ParticleView<'a> {
    pose: &'a SketchPose,
    raycaster: &'a SketchRaycaster,
    /// `r_max / s`, pixels.
    max_px: f64,
    /// `(cos θ, sin θ)` of the particle's heading.
    cos_sin: (f64, f64),
}

impl<'a> ParticleView<'a> {
    fn new(pose: &'a SketchPose, raycaster: &'a SketchRaycaster, range_max_m: f64) -> Self {
        let (sin, cos) = pose.heading_rad.sin_cos();
        Self {
            pose,
            raycaster,
            max_px: range_max_m / pose.meters_per_pixel,
            cos_sin: (cos, sin),
        }
    }

    /// Eq. (3): `(r − s·l) / σ(r)`, `l` the range ray-traced on the drawing; `∞` when the
    /// ray hits no line within `r_max`. One cast.
    fn range_error(&self, b: &Beam) -> f64 {
        let p = self.pose;
        match self
            .raycaster
            .cast(p.u_px, p.v_px, p.heading_rad + b.angle_rad, self.max_px)
        {
            Some(hit) => (b.range_m - p.meters_per_pixel * hit.range_px) / b.sigma_m,
            None => f64::INFINITY,
        }
    }

    /// The likelihood field: `s · D(e) / σ(r)`, `D(e)` the drawing's distance field at the
    /// beam's end `e = (u, v) + (r / s)·(cos φ, −sin φ)`; `∞` outside the image. Four
    /// lookups (the direction is one rotation of the beam's precomputed `(cos α, sin α)`).
    fn end_error(&self, b: &Beam) -> f64 {
        let p = self.pose;
        let ((cos_h, sin_h), (ca, sa)) = (self.cos_sin, b.cos_sin);
        let (cos, sin) = (cos_h * ca - sin_h * sa, sin_h * ca + cos_h * sa);
        let reach_px = b.range_m / p.meters_per_pixel;
        let (eu, ev) = (p.u_px + reach_px * cos, p.v_px - reach_px * sin);
        p.meters_per_pixel * self.raycaster.interpolated_distance_px(eu, ev) / b.sigma_m
    }
}

/// Beams whose likelihoods are multiplied before one logarithm is taken.
const LOG_EVERY: usize = 32;

/// Whether the beam `b` from the particle at `pose` crosses a drawn line before
/// `r − 3σ(r)`: a return seen through a drawn wall. One cast, up to that range.
fn sees_through(pose: &SketchPose, b: &Beam, raycaster: &SketchRaycaster) -> bool {
    let short_px = (b.range_m - UNEXPLAINED_SIGMAS * b.sigma_m) / pose.meters_per_pixel;
    short_px > 0.0
        && raycaster
            .cast(
                pose.u_px,
                pose.v_px,
                pose.heading_rad + b.angle_rad,
                short_px,
            )
            .is_some()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sketch::{Sketch, SketchLine};
    use sketchslam_types::Point2;

    /// A 100 × 100 px drawing with one vertical wall at u = 60.5, on the centres of its
    /// pixels, where the distance field is exact (0.1 m per pixel).
    fn wall_at_60() -> SketchRaycaster {
        let sketch = Sketch {
            width_px: 100,
            height_px: 100,
            strokes: fixedbitset::FixedBitSet::with_capacity(100 * 100),
            lines: vec![SketchLine::new(
                0,
                Point2::new(60.5, 5.0),
                Point2::new(60.5, 95.0),
            )],
        };
        SketchRaycaster::new(&sketch)
    }

    fn pose(u_px: f64) -> SketchPose {
        SketchPose {
            u_px,
            v_px: 50.0,
            heading_rad: 0.0,
            meters_per_pixel: 0.1,
        }
    }

    fn config() -> MclConfig {
        MclConfig {
            sigma_range_m: 0.1,
            sigma_range_rel: 0.0,
            ..MclConfig::default()
        }
    }

    fn lik(model: ObservationModel, at_u: f64, range_m: f64) -> f64 {
        let c = config();
        let beams = [Beam::new(0.0, range_m, &c)];
        model
            .log_likelihood(&pose(at_u), &beams, &wall_at_60(), &c, 20.0)
            .exp()
    }

    #[test]
    fn a_return_on_the_wall_scores_the_gaussian_peak_in_both_models() {
        // From u = 20.5 the wall is 40 px = 4 m ahead; σ = 0.1 m.
        let peak = 0.8 / (0.1 * std::f64::consts::TAU.sqrt()) + 0.2 / 20.0;
        for model in [ObservationModel::RayCast, ObservationModel::LikelihoodField] {
            assert!((lik(model, 20.5, 4.0) - peak).abs() < 1e-6, "{model:?}");
        }
        // 1σ off: the Gaussian at one sigma, plus the floor.
        let one_sigma = 0.8 / (0.1 * std::f64::consts::TAU.sqrt()) * (-0.5f64).exp() + 0.01;
        assert!((lik(ObservationModel::LikelihoodField, 20.5, 3.9) - one_sigma).abs() < 1e-6);
    }

    #[test]
    fn the_field_tells_a_short_return_from_one_seen_through_a_drawn_wall() {
        let c = config();
        // 2 m short of the wall: clutter, the floor z_rand / r_max.
        let short = lik(ObservationModel::LikelihoodField, 20.5, 2.0);
        assert!((short - c.z_rand / 20.0).abs() < 1e-9);
        // 2 m beyond it: seen through, z_seen_through / r_max.
        let through = lik(ObservationModel::LikelihoodField, 20.5, 6.0);
        assert!((through - c.z_seen_through / 20.0).abs() < 1e-9);
        assert!(through < short);
        // The paper's model cannot tell them apart.
        let (rc_short, rc_through) = (
            lik(ObservationModel::RayCast, 20.5, 2.0),
            lik(ObservationModel::RayCast, 20.5, 6.0),
        );
        assert!((rc_short - rc_through).abs() < 1e-9);
    }

    #[test]
    fn the_score_is_each_models_own_agreement() {
        let c = config();
        let rc = wall_at_60();
        let agreement = |model: ObservationModel, range_m: f64| {
            model.agreement(&pose(20.5), &[Beam::new(0.0, range_m, &c)], &rc, 20.0)
        };
        for model in [ObservationModel::RayCast, ObservationModel::LikelihoodField] {
            assert!((agreement(model, 4.0) - 1.0).abs() < 1e-9, "{model:?}");
            assert!(
                (agreement(model, 3.9) - (-0.5f64).exp()).abs() < 1e-6,
                "{model:?}"
            );
            // Clutter 2 m short of the wall agrees with neither.
            assert!(agreement(model, 2.0) < 1e-12, "{model:?}");
        }
        // A return 2 m beyond the wall: 20 px from it, and seen through it.
        assert!(agreement(ObservationModel::LikelihoodField, 6.0) < 1e-12);
        // Two beams, one on the wall and one clutter: the mean.
        let two = [Beam::new(0.0, 4.0, &c), Beam::new(0.0, 2.0, &c)];
        let mean = ObservationModel::LikelihoodField.agreement(&pose(20.5), &two, &rc, 20.0);
        assert!((mean - 0.5).abs() < 1e-9);
    }

    #[test]
    fn the_beam_end_scales_with_the_particles_own_scale() {
        // At 0.05 m per pixel a 2 m return reaches 40 px: onto the wall from u = 20.5.
        let c = config();
        let beams = [Beam::new(0.0, 2.0, &c)];
        let fine = SketchPose {
            meters_per_pixel: 0.05,
            ..pose(20.5)
        };
        let ll = ObservationModel::LikelihoodField.log_likelihood(
            &fine,
            &beams,
            &wall_at_60(),
            &c,
            20.0,
        );
        let peak = 0.8 / (0.1 * std::f64::consts::TAU.sqrt()) + 0.01;
        assert!((ll.exp() - peak).abs() < 1e-6);
    }
}
