//! Scoring the pose on the drawing: a scenario's `sketch-truth.toml` says how each drawing
//! was made from the world, so the true pose can be carried onto the drawing and compared
//! with the pose the session gave there. Only the evaluation reads that file; the mapping
//! service never does.
//!
//! The file's formula: a world point `(x, y)` (meters) lands at pixel
//!
//! `u = fx(x) / s + 10`, `v = H − 10 − fy(y) / s`, `H = ceil(fy(Y) / s) + 20`
//!
//! where `s` is the drawing's nominal meters per pixel, `Y` the world's height and `fx`, `fy`
//! piecewise linear through the knots `[world m, drawn m]` (extended beyond the end knots along
//! the end segments). A world heading `θ` becomes `atan2(fy'(y) sin θ, fx'(x) cos θ)` on the
//! drawing, counter-clockwise from +u as the drawing is seen. A photographed drawing was then
//! turned by `rotate_deg` counter-clockwise about the canvas centre, the canvas enlarged to hold
//! it (width `W = ceil(fx(X) / s) + 20` before the turn): pixels and headings turn with it. The
//! hand's wobble (a few pixels) is not in the formula, so a perfect estimate scores a few pixels.
//!
//! Errors are reported in pixels and in meters at the nominal scale (`px · s`, "meters
//! equivalent"), as issue-independent figures: median and 95th percentile, the share of poses
//! within 1 m-equivalent, and the median heading error.

use crate::metrics::StampedPose;
use anyhow::{Context, Result, bail, ensure};
use serde::Deserialize;
use sketchslam_engine::sketch::SketchPose;
use sketchslam_types::{Pose2, wrap_angle};
use std::path::Path;

/// The file beside `scenario.toml`.
pub const SKETCH_TRUTH_FILE: &str = "sketch-truth.toml";

/// Margin the drawings were made with, pixels.
const MARGIN_PX: f64 = 10.0;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct TruthFile {
    world_size_m: [f64; 2],
    sketch: Vec<TruthSketch>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct TruthSketch {
    name: String,
    fx: Vec<[f64; 2]>,
    fy: Vec<[f64; 2]>,
    meters_per_pixel: f64,
    #[serde(default)]
    rotate_deg: f64,
}

/// How one drawing was made from the world.
#[derive(Debug, Clone, PartialEq)]
pub struct DrawingTruth {
    /// The drawing's name in the scenario.
    pub name: String,
    fx: Vec<[f64; 2]>,
    fy: Vec<[f64; 2]>,
    /// Nominal scale, meters per pixel.
    pub meters_per_pixel: f64,
    rotate_rad: f64,
    /// Canvas before the turn, pixels.
    width_px: f64,
    height_px: f64,
}

/// Piecewise linear `f(x)` through `knots` (sorted by x), and its slope at `x`.
fn piecewise(knots: &[[f64; 2]], x: f64) -> (f64, f64) {
    let last = knots.len() - 2;
    let k = knots[..=last]
        .iter()
        .rposition(|k| k[0] <= x)
        .unwrap_or(0)
        .min(last);
    let ([x0, y0], [x1, y1]) = (knots[k], knots[k + 1]);
    let slope = (y1 - y0) / (x1 - x0);
    (y0 + slope * (x - x0), slope)
}

impl DrawingTruth {
    /// The drawing called `name` in `scenario_dir`'s `sketch-truth.toml`; `None` when the
    /// scenario has no such file or the file does not list the drawing.
    pub fn load(scenario_dir: &Path, name: &str) -> Result<Option<DrawingTruth>> {
        let path = scenario_dir.join(SKETCH_TRUTH_FILE);
        if !path.is_file() {
            return Ok(None);
        }
        let text = std::fs::read_to_string(&path)
            .with_context(|| format!("reading {}", path.display()))?;
        let file: TruthFile =
            toml::from_str(&text).with_context(|| format!("parsing {}", path.display()))?;
        let Some(s) = file.sketch.into_iter().find(|s| s.name == name) else {
            return Ok(None);
        };
        for (axis, knots) in [("fx", &s.fx), ("fy", &s.fy)] {
            ensure!(
                knots.len() >= 2 && knots.windows(2).all(|w| w[1][0] > w[0][0]),
                "{}: sketch {name:?}: {axis} needs two or more knots in increasing x",
                path.display()
            );
        }
        if !(s.meters_per_pixel.is_finite() && s.meters_per_pixel > 0.0) {
            bail!(
                "{}: sketch {name:?}: meters_per_pixel must be > 0",
                path.display()
            );
        }
        let mpp = s.meters_per_pixel;
        let [w_m, h_m] = file.world_size_m;
        Ok(Some(DrawingTruth {
            width_px: (piecewise(&s.fx, w_m).0 / mpp).ceil() + 2.0 * MARGIN_PX,
            height_px: (piecewise(&s.fy, h_m).0 / mpp).ceil() + 2.0 * MARGIN_PX,
            name: s.name,
            fx: s.fx,
            fy: s.fy,
            meters_per_pixel: mpp,
            rotate_rad: s.rotate_deg.to_radians(),
        }))
    }

    /// The world pose `pose` (meters, world frame) on the drawing: pixel and heading (the
    /// returned scale is the nominal one).
    pub fn world_to_drawing(&self, pose: &Pose2) -> SketchPose {
        let s = self.meters_per_pixel;
        let (fx, dfx) = piecewise(&self.fx, pose.x);
        let (fy, dfy) = piecewise(&self.fy, pose.y);
        let (mut u, mut v) = (fx / s + MARGIN_PX, self.height_px - MARGIN_PX - fy / s);
        let mut heading =
            (dfy * pose.heading_rad.sin()).atan2(dfx * pose.heading_rad.cos()) + self.rotate_rad;
        if self.rotate_rad != 0.0 {
            // Counter-clockwise as seen, v down: about the old centre, into the new canvas.
            let (c, si) = (self.rotate_rad.cos(), self.rotate_rad.sin());
            let (w, h) = (self.width_px, self.height_px);
            // (less a hair, so that a quarter turn's cos ≈ 6e-17 does not add a pixel)
            let (new_w, new_h) = (
                (w * c.abs() + h * si.abs() - 1e-9).ceil(),
                (w * si.abs() + h * c.abs() - 1e-9).ceil(),
            );
            let (du, dv) = (u - 0.5 * w, v - 0.5 * h);
            u = 0.5 * new_w + du * c + dv * si;
            v = 0.5 * new_h - du * si + dv * c;
        }
        heading = wrap_angle(heading);
        SketchPose {
            u_px: u,
            v_px: v,
            heading_rad: heading,
            meters_per_pixel: s,
        }
    }
}

/// How well the poses on the drawing follow the truth carried there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SketchPoseScore {
    /// Median position error, meters at the drawing's nominal scale.
    pub median_m: f64,
    /// 95th percentile of the position error, meters at the nominal scale.
    pub p95_m: f64,
    /// Share of poses within 1 m-equivalent of the truth.
    pub within_1m: f64,
    /// Median absolute heading error, degrees.
    pub heading_median_deg: f64,
    /// Poses scored.
    pub poses: usize,
}

/// Scores the estimated drawing poses `estimate[i]` against the world truth `truth[i]`
/// (same scans, same order) carried onto `drawing`; `None` without a pose to score.
pub fn score_sketch_poses(
    truth: &[StampedPose],
    estimate: &[SketchPose],
    drawing: &DrawingTruth,
) -> Option<SketchPoseScore> {
    let mut position_m = Vec::with_capacity(estimate.len());
    let mut heading_deg = Vec::with_capacity(estimate.len());
    for (t, e) in truth.iter().zip(estimate) {
        let on = drawing.world_to_drawing(&t.pose);
        let px = (e.u_px - on.u_px).hypot(e.v_px - on.v_px);
        if px.is_finite() {
            position_m.push(px * drawing.meters_per_pixel);
            heading_deg.push(
                wrap_angle(e.heading_rad - on.heading_rad)
                    .abs()
                    .to_degrees(),
            );
        }
    }
    if position_m.is_empty() {
        return None;
    }
    let n = position_m.len();
    let within = position_m.iter().filter(|&&m| m <= 1.0).count() as f64 / n as f64;
    position_m.sort_by(f64::total_cmp);
    heading_deg.sort_by(f64::total_cmp);
    Some(SketchPoseScore {
        median_m: position_m[n / 2],
        p95_m: position_m[(n * 95 / 100).min(n - 1)],
        within_1m: within,
        heading_median_deg: heading_deg[n / 2],
        poses: n,
    })
}

/// The poses on the drawing `published` (stamp in seconds, in stamp order) that have a
/// truth row of the same stamp (to a microsecond), paired with it: the scans a live
/// client saw a pose for. Unmatched rows on either side are left out.
pub fn pair_by_stamp(
    truth: &[StampedPose],
    published: &[(f64, SketchPose)],
) -> (Vec<StampedPose>, Vec<SketchPose>) {
    const TOL_S: f64 = 1e-6;
    let (mut t, mut e) = (Vec::new(), Vec::new());
    let mut i = 0;
    for (stamp, pose) in published {
        while i < truth.len() && truth[i].t_s < stamp - TOL_S {
            i += 1;
        }
        if i < truth.len() && (truth[i].t_s - stamp).abs() <= TOL_S {
            t.push(truth[i]);
            e.push(*pose);
        }
    }
    (t, e)
}

/// Scores poses on the drawing `cfg_name` (stamp in seconds, in stamp order) against the
/// truth of the same stamps, when the scenario in `scenario_dir` says how that drawing was
/// made; `None` when it does not, or without a pose to score.
pub fn score_published_poses(
    scenario_dir: &Path,
    cfg_name: &str,
    truth: &[StampedPose],
    published: &[(f64, SketchPose)],
) -> Result<Option<SketchPoseScore>> {
    // Scoring only: the session never saw this file.
    let Some(drawing) = DrawingTruth::load(scenario_dir, cfg_name)? else {
        return Ok(None);
    };
    let (truth, estimate) = pair_by_stamp(truth, published);
    Ok(score_sketch_poses(&truth, &estimate, &drawing))
}

/// Scores a `sketch` run's published poses on the drawing `cfg_name` against the truth,
/// when the scenario in `scenario_dir` says how that drawing was made; writes the figures
/// into `result` (left `None` otherwise).
pub fn fill_sketch_pose_scores(
    result: &mut crate::run::RunResult,
    scenario_dir: &Path,
    cfg_name: &str,
    truth: &[StampedPose],
    published: &[(f64, SketchPose)],
) -> Result<()> {
    if let Some(score) = score_published_poses(scenario_dir, cfg_name, truth, published)? {
        result.sketch_pose_median_m = Some(score.median_m);
        result.sketch_pose_p95_m = Some(score.p95_m);
        result.sketch_pose_within_1m = Some(score.within_1m);
        result.sketch_heading_median_deg = Some(score.heading_median_deg);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    /// paper-env1's sketch B, as its `sketch-truth.toml` gives it: the west 16 m drawn 11 m
    /// wide, the rest true to scale, at 0.1 m per pixel.
    fn sketch_b() -> DrawingTruth {
        let fx = vec![[0.0, 0.0], [16.0, 11.0], [50.0, 45.0]];
        let fy = vec![[0.0, 0.0], [36.0, 36.0]];
        DrawingTruth {
            name: "B".into(),
            width_px: (45.0f64 / 0.1).ceil() + 20.0,
            height_px: (36.0f64 / 0.1).ceil() + 20.0,
            fx,
            fy,
            meters_per_pixel: 0.1,
            rotate_rad: 0.0,
        }
    }

    #[test]
    fn a_corner_and_headings_of_paper_env1_sketch_b_by_hand() {
        let b = sketch_b();
        // The knot corner (16, 36): fx = 11 m → u = 110 + 10; H = 360 + 20, v = 380 − 10 − 360.
        let p = b.world_to_drawing(&Pose2::new(16.0, 36.0, 0.0));
        assert!(
            (p.u_px - 120.0).abs() < 1e-9 && (p.v_px - 10.0).abs() < 1e-9,
            "{p:?}"
        );
        // The origin: u = 10, v = 370.
        let p = b.world_to_drawing(&Pose2::new(0.0, 0.0, 0.0));
        assert!(
            (p.u_px - 10.0).abs() < 1e-9 && (p.v_px - 370.0).abs() < 1e-9,
            "{p:?}"
        );
        // East of the knot the scale is 1: (30, 0) → fx = 11 + 14 = 25 m → u = 260.
        let p = b.world_to_drawing(&Pose2::new(30.0, 0.0, FRAC_PI_2));
        assert!((p.u_px - 260.0).abs() < 1e-9);
        assert!(
            (p.heading_rad - FRAC_PI_2).abs() < 1e-12,
            "north stays north"
        );
        // West of it x is squeezed by 11/16: a 45° heading turns to atan2(1, 11/16) = 55.49°.
        let p = b.world_to_drawing(&Pose2::new(8.0, 10.0, 45f64.to_radians()));
        assert!(
            (p.heading_rad.to_degrees() - 55.491_477).abs() < 1e-4,
            "{p:?}"
        );
    }

    #[test]
    fn the_truth_scores_zero_and_a_shift_scores_its_size() {
        let b = sketch_b();
        let truth: Vec<StampedPose> = (0..20)
            .map(|i| StampedPose {
                t_s: i as f64,
                pose: Pose2::new(20.0 + i as f64, 5.0, 0.3),
            })
            .collect();
        let exact: Vec<SketchPose> = truth.iter().map(|t| b.world_to_drawing(&t.pose)).collect();
        let s = score_sketch_poses(&truth, &exact, &b).unwrap();
        assert_eq!((s.median_m, s.within_1m, s.poses), (0.0, 1.0, 20));
        // 15 px east at 0.1 m/px: 1.5 m-equivalent everywhere, none within 1 m.
        let shifted: Vec<SketchPose> = exact
            .iter()
            .map(|p| SketchPose {
                u_px: p.u_px + 15.0,
                ..*p
            })
            .collect();
        let s = score_sketch_poses(&truth, &shifted, &b).unwrap();
        assert!(
            (s.median_m - 1.5).abs() < 1e-9 && s.within_1m == 0.0,
            "{s:?}"
        );
    }

    #[test]
    fn a_turned_photograph_turns_pixels_about_the_centre() {
        let mut b = sketch_b();
        b.rotate_rad = FRAC_PI_2;
        // The centre of the old canvas (w 470, h 380) lands at the centre of the new one
        // (w 380, h 470); a point right of the centre goes above it (v smaller).
        let (w, h) = (b.width_px, b.height_px);
        let flat = sketch_b();
        let a = flat.world_to_drawing(&Pose2::new(30.0, 18.0, 0.0));
        let t = b.world_to_drawing(&Pose2::new(30.0, 18.0, 0.0));
        let (du, dv) = (a.u_px - 0.5 * w, a.v_px - 0.5 * h);
        assert!((t.u_px - (0.5 * h + dv)).abs() < 1e-9, "{t:?}");
        assert!((t.v_px - (0.5 * w - du)).abs() < 1e-9, "{t:?}");
        assert!((t.heading_rad - FRAC_PI_2).abs() < 1e-12);
    }

    /// On the shared scenarios, the robot's true start carried onto each drawing lands
    /// within a few pixels of where a person marked it (the marks are rough on purpose).
    #[test]
    fn true_starts_land_near_the_marked_starts_on_every_shared_drawing() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/scenarios");
        let mut checked = 0;
        for name in ["paper-env1", "paper-env2", "school"] {
            let dir = root.join(name);
            if !dir.join(SKETCH_TRUTH_FILE).is_file() {
                println!("note: {} is absent", dir.display());
                continue;
            }
            let scenario = sketchslam_simulator::Scenario::load(&dir).unwrap();
            for cfg in &scenario.sketches {
                let truth = DrawingTruth::load(&dir, &cfg.name).unwrap().unwrap();
                let on = truth.world_to_drawing(&scenario.robot.start);
                let off_px = (on.u_px - cfg.start_u_px).hypot(on.v_px - cfg.start_v_px);
                assert!(off_px < 8.0, "{name} {}: {off_px:.1} px off", cfg.name);
                let dh = wrap_angle(on.heading_rad - cfg.start_heading_rad).to_degrees();
                assert!(dh.abs() < 10.0, "{name} {}: heading {dh:.1}° off", cfg.name);
                checked += 1;
            }
        }
        println!("{checked} drawings checked");
    }
}
