//! Monte Carlo localization on the hand-drawn map with the drawing's scale per particle
//! (Akiba et al. §3.1, after Behzadian et al. 2015, "Monte Carlo localization in
//! hand-drawn maps").
//!
//! Where in the pipeline: step 2 of every scan of a `sketch` session. Odometry moves the
//! particle cloud ([`SketchMcl::predict`], eq. 1–2), the scan weighs it against pseudo-ranges
//! ray-traced on the sketch's lines ([`SketchMcl::update`], eq. 3), and the estimate
//! ([`SketchMcl::estimate`]) feeds the line observation probability (eq. 4). The
//! observation model is [`super::observation_model`]'s: eq. (3) or the drawing's
//! likelihood field. When the
//! estimate breaks down, [`crate::localization::recovery`] builds a new cloud and
//! [`SketchMcl::restart_with`] counts it.
//!
//! A particle is `(u, v, θ, s)`: a pose on the drawing in pixels and the drawing's scale
//! `s` (meters per pixel) around it. A drawing's proportions are wrong in places, so `s`
//! is per particle and random-walks as the robot travels.
//!
//! Costs per call, `N` particles, `B` used beams, `C` the cost of one ray cast
//! (see [`crate::sketch::raycast`]): `predict` O(N), `update` O(N·B·C + N) with eq. (3),
//! O(N·B + N·B_u·C) with the likelihood field (`B_u` the beams it cannot explain), plus
//! B casts for the score; `estimate` O(N).

use super::observation_model::{Beam, ObservationModel};
use crate::EngineError;
use crate::sketch::SketchPose;
use crate::sketch::raycast::SketchRaycaster;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal, StandardNormal};
use sketchslam_types::{Pose2, Scan, wrap_angle};

/// Parameters of MCL on the sketch. Lengths in meters are in the world (sensor) frame.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MclConfig {
    /// Number of particles (500: the paper's order of magnitude; enough for a start
    /// known within ~1 m, ~10° and ~±30 % of scale).
    pub particles: usize,
    /// Beams of each scan used in eq. (3), evenly spaced over the scan (60).
    pub beams_used: usize,
    /// Constant part of the range sd σ(r) of eq. (3), meters (0.25: the LiDAR's own few
    /// centimetres are negligible against a drawing's errors).
    pub sigma_range_m: f64,
    /// Range-proportional part of σ(r): σ(r) = `sigma_range_m` + `sigma_range_rel`·r (0.05:
    /// a drawing's length errors grow with the distance drawn).
    pub sigma_range_rel: f64,
    /// Weight of the Gaussian in the per-beam mixture (0.8).
    pub z_hit: f64,
    /// Weight of the uniform over [0, range_max] in the per-beam mixture (0.2): a wall missing
    /// from the drawing, a door drawn closed or a person cannot zero a particle.
    pub z_rand: f64,
    /// Exponent applied to the product of the beam likelihoods (0.2): beams are strongly
    /// correlated through the drawing's errors, so 60 beams carry the evidence of ~12.
    pub likelihood_exponent: f64,
    /// Range cap used when the scan's `range_max_m` is not a positive finite number, meters.
    pub fallback_range_max_m: f64,
    /// Translation noise sd per meter travelled (0.1).
    pub trans_noise_per_m: f64,
    /// Translation noise sd per radian turned, meters (0.02).
    pub trans_noise_per_rad: f64,
    /// Rotation noise sd per radian turned (0.05).
    pub rot_noise_per_rad: f64,
    /// Rotation noise sd per meter travelled, radians (0.02: drawn walls are not straight
    /// nor square, so the heading on the drawing drifts as the robot goes).
    pub rot_noise_per_m: f64,
    /// Translation noise sd added to every prediction, meters (0.002).
    pub min_trans_noise_m: f64,
    /// Rotation noise sd added to every prediction, radians (0.002).
    pub min_rot_noise_rad: f64,
    /// Random walk of ln s per √meter travelled (0.02: ~2 % of scale change per √m).
    pub scale_walk_per_sqrt_m: f64,
    /// Random walk of ln s at every prediction (0.0005).
    pub min_scale_walk: f64,
    /// Scale bounds relative to the start guess: s stays in [guess/k, guess·k] (k = 4).
    pub scale_bound_factor: f64,
    /// Resample when the effective sample size falls below this fraction of N (0.5).
    pub resample_ess_fraction: f64,
    /// A particle closer than this to a line stands in a wall, pixels (1.0).
    pub wall_clearance_px: f64,
    /// Log-weight added to a particle standing in a wall (−8); three times it outside the
    /// image.
    pub wall_log_penalty: f64,
    /// How a scan weighs a particle ([`ObservationModel`]): the paper's ray-traced eq. (3)
    /// (default) or the drawing's likelihood field.
    #[serde(default)]
    pub observation: ObservationModel,
    /// Likelihood field: weight of the floor for a return seen through a drawn wall
    /// (0.02: one beam in fifty passes a door drawn closed or a gap between strokes), against
    /// `z_rand` for one that stops short in the drawing's free space.
    #[serde(default = "default_z_seen_through")]
    pub z_seen_through: f64,
}

fn default_z_seen_through() -> f64 {
    0.02
}

impl Default for MclConfig {
    fn default() -> Self {
        Self {
            particles: 500,
            beams_used: 60,
            sigma_range_m: 0.1,
            sigma_range_rel: 0.05,
            z_hit: 0.8,
            z_rand: 0.2,
            likelihood_exponent: 0.2,
            fallback_range_max_m: 30.0,
            trans_noise_per_m: 0.1,
            trans_noise_per_rad: 0.02,
            rot_noise_per_rad: 0.05,
            rot_noise_per_m: 0.02,
            min_trans_noise_m: 0.002,
            min_rot_noise_rad: 0.002,
            scale_walk_per_sqrt_m: 0.02,
            min_scale_walk: 0.0005,
            scale_bound_factor: 4.0,
            resample_ess_fraction: 0.5,
            wall_clearance_px: 1.0,
            wall_log_penalty: -8.0,
            observation: ObservationModel::default(),
            z_seen_through: default_z_seen_through(),
        }
    }
}

impl MclConfig {
    /// Range sd σ(r) of eq. (3) for a measured range `r`, meters.
    pub fn sigma_at_m(&self, range_m: f64) -> f64 {
        (self.sigma_range_m + self.sigma_range_rel * range_m.abs()).max(1e-6)
    }

    fn validate(&self) -> Result<(), EngineError> {
        let bad = |name: &'static str, reason: &str| {
            Err(EngineError::InvalidParameter {
                name,
                reason: reason.to_string(),
            })
        };
        if self.particles == 0 {
            return bad("particles", "must be at least 1");
        }
        if self.beams_used == 0 {
            return bad("beams_used", "must be at least 1");
        }
        let nonneg = [
            ("sigma_range_m", self.sigma_range_m),
            ("sigma_range_rel", self.sigma_range_rel),
            ("z_hit", self.z_hit),
            ("z_rand", self.z_rand),
            ("likelihood_exponent", self.likelihood_exponent),
            ("trans_noise_per_m", self.trans_noise_per_m),
            ("trans_noise_per_rad", self.trans_noise_per_rad),
            ("rot_noise_per_rad", self.rot_noise_per_rad),
            ("rot_noise_per_m", self.rot_noise_per_m),
            ("min_trans_noise_m", self.min_trans_noise_m),
            ("min_rot_noise_rad", self.min_rot_noise_rad),
            ("scale_walk_per_sqrt_m", self.scale_walk_per_sqrt_m),
            ("min_scale_walk", self.min_scale_walk),
            ("resample_ess_fraction", self.resample_ess_fraction),
            ("wall_clearance_px", self.wall_clearance_px),
        ];
        for (name, v) in nonneg {
            if !(v.is_finite() && v >= 0.0) {
                return bad(name, "must be a finite number ≥ 0");
            }
        }
        if self.sigma_range_m + self.sigma_range_rel <= 0.0 {
            return bad("sigma_range_m", "σ(r) must be positive");
        }
        if self.z_rand <= 0.0 {
            return bad("z_rand", "must be > 0 (robust floor)");
        }
        if !(self.z_seen_through.is_finite() && self.z_seen_through > 0.0) {
            return bad(
                "z_seen_through",
                "must be a finite number > 0 (robust floor)",
            );
        }
        if !(self.fallback_range_max_m.is_finite() && self.fallback_range_max_m > 0.0) {
            return bad("fallback_range_max_m", "must be a finite number > 0");
        }
        if !(self.scale_bound_factor.is_finite() && self.scale_bound_factor > 1.0) {
            return bad("scale_bound_factor", "must be a finite number > 1");
        }
        if !(self.wall_log_penalty.is_finite() && self.wall_log_penalty <= 0.0) {
            return bad("wall_log_penalty", "must be a finite number ≤ 0");
        }
        Ok(())
    }
}

/// How far the starting cloud spreads around the start a person marked (1 sd).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StartSpread {
    /// Position sd per axis, meters (0.5: the mark is within ~1 m).
    pub position_sd_m: f64,
    /// Heading sd, radians (0.1 ≈ 6°: within ~10°).
    pub heading_sd_rad: f64,
    /// Relative sd of the scale, as sd of ln s (0.15: the guess within ~±30 %).
    pub scale_sd_rel: f64,
}

impl Default for StartSpread {
    fn default() -> Self {
        Self {
            position_sd_m: 0.5,
            heading_sd_rad: 0.1,
            scale_sd_rel: 0.15,
        }
    }
}

/// One hypothesis: a pose on the drawing with the drawing's scale, and its weight.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Particle {
    /// Pose on the drawing (pixels, radians) and scale (meters per pixel).
    pub pose: SketchPose,
    /// Normalized weight (the cloud's weights sum to 1).
    pub weight: f64,
}

/// What one [`SketchMcl::update`] did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UpdateOutcome {
    /// Returned beams that entered eq. (3); 0 means the scan was not used.
    pub beams: usize,
    /// Effective sample size after weighting, before any resampling.
    pub ess: f64,
    /// True when the cloud was resampled.
    pub resampled: bool,
    /// Localization score of the estimate, 0..1 (see [`SketchMcl::score`]).
    pub score: f64,
}

/// MCL on a sketch with a per-particle scale.
#[derive(Debug, Clone)]
pub struct SketchMcl {
    config: MclConfig,
    particles: Vec<Particle>,
    scale_min: f64,
    scale_max: f64,
    score: f64,
    recoveries: usize,
    /// Drives systematic resampling; seeded from the constructor's `rng` (deterministic).
    resample_rng: ChaCha8Rng,
}

impl SketchMcl {
    /// A cloud of `config.particles` around `start` (pose marked by a person and the scale
    /// they guessed), Gaussian in position (meters converted with the guessed scale) and
    /// heading, log-normal in scale.
    ///
    /// Errors: invalid config, non-finite start, a non-positive scale guess, or a spread
    /// that is negative or not finite.
    pub fn new(
        config: MclConfig,
        start: SketchPose,
        spread: StartSpread,
        rng: &mut impl Rng,
    ) -> Result<Self, EngineError> {
        config.validate()?;
        validate_pose(&start)?;
        for (name, v) in [
            ("position_sd_m", spread.position_sd_m),
            ("heading_sd_rad", spread.heading_sd_rad),
            ("scale_sd_rel", spread.scale_sd_rel),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(EngineError::InvalidParameter {
                    name,
                    reason: format!("must be a finite number ≥ 0, got {v}"),
                });
            }
        }
        let s0 = start.meters_per_pixel;
        let pos_sd_px = spread.position_sd_m / s0;
        let w = 1.0 / config.particles as f64;
        let particles = (0..config.particles)
            .map(|_| {
                let g = |rng: &mut _| -> f64 { StandardNormal.sample(rng) };
                Particle {
                    pose: SketchPose {
                        u_px: start.u_px + pos_sd_px * g(rng),
                        v_px: start.v_px + pos_sd_px * g(rng),
                        heading_rad: wrap_angle(start.heading_rad + spread.heading_sd_rad * g(rng)),
                        meters_per_pixel: s0 * (spread.scale_sd_rel * g(rng)).exp(),
                    },
                    weight: w,
                }
            })
            .collect();
        let k = config.scale_bound_factor;
        Ok(Self {
            config,
            particles,
            scale_min: s0 / k,
            scale_max: s0 * k,
            score: 0.0,
            recoveries: 0,
            resample_rng: ChaCha8Rng::seed_from_u64(rng.random()),
        })
    }

    /// The configuration.
    pub fn config(&self) -> &MclConfig {
        &self.config
    }

    /// The particles (weights normalized).
    pub fn particles(&self) -> &[Particle] {
        &self.particles
    }

    /// How many times the cloud was rebuilt by a recovery ([`SketchMcl::restart_with`]).
    pub fn recoveries(&self) -> usize {
        self.recoveries
    }

    /// Localization score of the estimate after the last update, 0..1: the mean over the
    /// used returned beams of the observation model's agreement at the estimate
    /// ([`ObservationModel::agreement`]: `exp(−(r_i − s·l_i)² / (2σ(r_i)²))` with eq. (3),
    /// `exp(−d_i² / (2σ(r_i)²))` with the likelihood field; a beam the drawing does not
    /// explain scores 0), so each model judges its own estimate. ≈ 1 when the scan matches the drawing, → 0 when
    /// the estimate is lost. 0 before the first update.
    pub fn score(&self) -> f64 {
        self.score
    }

    /// Replaces the cloud (weights renormalized; particles with a non-finite pose or a
    /// non-positive scale are dropped; scales clamped to the configured bounds). Returns
    /// false and changes nothing when none is valid. Not counted as a recovery: for tests
    /// and for restoring a saved state.
    pub fn set_particles(&mut self, particles: Vec<Particle>) -> bool {
        let mut particles: Vec<Particle> = particles
            .into_iter()
            .filter(|p| validate_pose(&p.pose).is_ok())
            .map(|mut p| {
                p.pose.meters_per_pixel = p
                    .pose
                    .meters_per_pixel
                    .clamp(self.scale_min, self.scale_max);
                p.pose.heading_rad = wrap_angle(p.pose.heading_rad);
                if !(p.weight.is_finite() && p.weight >= 0.0) {
                    p.weight = 0.0;
                }
                p
            })
            .collect();
        if particles.is_empty() {
            return false;
        }
        let total: f64 = particles.iter().map(|p| p.weight).sum();
        let n = particles.len() as f64;
        for p in &mut particles {
            p.weight = if total > 0.0 && total.is_finite() {
                p.weight / total
            } else {
                1.0 / n
            };
        }
        self.particles = particles;
        true
    }

    /// Replaces the cloud with one built by a recovery (section 3.2, see
    /// [`crate::localization::recovery::recover`]) and counts the recovery. Returns false (and
    /// changes nothing) when no particle is valid.
    pub fn restart_with(&mut self, particles: Vec<Particle>) -> bool {
        let applied = self.set_particles(particles);
        if applied {
            self.recoveries += 1;
            self.score = 0.0;
        }
        applied
    }

    /// Motion update, eq. (1)–(2): every particle moves by the robot-frame odometry
    /// increment `odom_delta` (meters: x forward, y left; radians) converted to pixels
    /// with its own scale,
    ///
    /// `u' = u + (cos θ·Δx' − sin θ·Δy') / s`, `v' = v − (sin θ·Δx' + cos θ·Δy') / s`,
    /// `θ' = θ + Δθ'`,
    ///
    /// where `Δx' = Δx + ε_t`, `Δy' = Δy + ε_t`, `Δθ' = Δθ + ε_r` with zero-mean Gaussian
    /// noise proportional to the motion: `sd(ε_t) = t₀ + a·d + b·|Δθ|`,
    /// `sd(ε_r) = r₀ + c·|Δθ| + e·d`, `d = √(Δx² + Δy²)`. The scale random-walks:
    /// `s' = s·exp(ε_s)`, `sd(ε_s) = s₀ + k·√d`, kept within the configured bounds.
    /// A non-finite increment counts as no motion.
    pub fn predict(&mut self, odom_delta: Pose2, rng: &mut impl Rng) {
        let (dx, dy, dth) = if odom_delta.is_finite() {
            (
                odom_delta.x,
                odom_delta.y,
                wrap_angle(odom_delta.heading_rad),
            )
        } else {
            (0.0, 0.0, 0.0)
        };
        let c = &self.config;
        let d = dx.hypot(dy);
        let sd_t =
            c.min_trans_noise_m + c.trans_noise_per_m * d + c.trans_noise_per_rad * dth.abs();
        let sd_r = c.min_rot_noise_rad + c.rot_noise_per_rad * dth.abs() + c.rot_noise_per_m * d;
        let sd_s = c.min_scale_walk + c.scale_walk_per_sqrt_m * d.sqrt();
        for p in &mut self.particles {
            let mut g = || -> f64 { StandardNormal.sample(rng) };
            let (ex, ey, er, es) = (g(), g(), g(), g());
            let moved = p
                .pose
                .advanced(dx + sd_t * ex, dy + sd_t * ey, dth + sd_r * er);
            p.pose = SketchPose {
                meters_per_pixel: (p.pose.meters_per_pixel * (sd_s * es).exp())
                    .clamp(self.scale_min, self.scale_max),
                ..moved
            };
        }
    }

    /// Measurement update: for each particle `(u, v, θ, s)` and each used beam `i` (an
    /// evenly spaced subset of `beams_used` beams; no-returns skipped), `p(r_i | x)` by the
    /// configured [`ObservationModel`] — the paper's eq. (3),
    ///
    /// `p(r_i | x) = z_hit · N(r_i; s·l_i, σ(r_i)²) + z_rand / r_max`
    ///
    /// with `l_i` ray-traced on the sketch from `(u, v)` at `θ + α_i`, or the likelihood
    /// field at the beam's end. The
    /// particle's log weight grows by `γ · Σ_i ln p(r_i | x)` (γ = `likelihood_exponent`),
    /// plus `wall_log_penalty` when it stands within `wall_clearance_px` of a line, or
    /// 3 × `wall_log_penalty` (and only floors) when it is outside the image.
    /// Weights are normalized in log space; when the effective sample size
    /// `1 / Σ w²` falls below `resample_ess_fraction · N` the cloud is resampled
    /// (low-variance / systematic). Then the score of the estimate is computed.
    ///
    /// A scan without any usable return changes nothing (`beams == 0`).
    pub fn update(&mut self, scan: &Scan, raycaster: &SketchRaycaster) -> UpdateOutcome {
        let beam_data = beam_data(scan, &self.config);
        if beam_data.is_empty() {
            return UpdateOutcome {
                beams: 0,
                ess: self.effective_sample_size(),
                resampled: false,
                score: self.score,
            };
        }
        let c = &self.config;
        let range_max_m = scan.range_max_m_or(c.fallback_range_max_m);
        let floor = c.z_rand / range_max_m;
        let mut log_w: Vec<f64> = Vec::with_capacity(self.particles.len());
        for p in &self.particles {
            let pose = &p.pose;
            let (ll, penalty) = if !raycaster.contains(pose.u_px, pose.v_px) {
                (
                    beam_data.len() as f64 * floor.ln(),
                    3.0 * c.wall_log_penalty,
                )
            } else {
                let in_wall =
                    raycaster.distance_to_wall_px(pose.u_px, pose.v_px) < c.wall_clearance_px;
                (
                    c.observation
                        .log_likelihood(pose, &beam_data, raycaster, c, range_max_m),
                    if in_wall { c.wall_log_penalty } else { 0.0 },
                )
            };
            log_w.push(p.weight.max(1e-300).ln() + c.likelihood_exponent * ll + penalty);
        }
        let max_lw = log_w.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let mut total = 0.0;
        for (p, lw) in self.particles.iter_mut().zip(&log_w) {
            p.weight = if max_lw.is_finite() {
                (lw - max_lw).exp()
            } else {
                1.0
            };
            total += p.weight;
        }
        let n = self.particles.len() as f64;
        for p in &mut self.particles {
            p.weight = if total > 0.0 && total.is_finite() {
                p.weight / total
            } else {
                1.0 / n
            };
        }
        let ess = self.effective_sample_size();
        let resampled = ess < self.config.resample_ess_fraction * n;
        if resampled {
            self.resample();
        }
        let est = self.estimate();
        self.score = pose_score(&est, &beam_data, raycaster, range_max_m, &self.config);
        UpdateOutcome {
            beams: beam_data.len(),
            ess,
            resampled,
            score: self.score,
        }
    }

    /// Low-variance (systematic) resampling: one uniform offset, N evenly spaced pointers
    /// into the cumulative weights. O(N).
    fn resample(&mut self) {
        let n = self.particles.len();
        let step = 1.0 / n as f64;
        let mut pointer: f64 = self.resample_rng.random::<f64>() * step;
        let mut cumulative = self.particles[0].weight;
        let mut k = 0;
        let mut out = Vec::with_capacity(n);
        for _ in 0..n {
            while pointer > cumulative && k + 1 < n {
                k += 1;
                cumulative += self.particles[k].weight;
            }
            out.push(Particle {
                pose: self.particles[k].pose,
                weight: step,
            });
            pointer += step;
        }
        self.particles = out;
    }

    /// Effective sample size `1 / Σ w_i²`, 1..N.
    pub fn effective_sample_size(&self) -> f64 {
        let s: f64 = self.particles.iter().map(|p| p.weight * p.weight).sum();
        if s > 0.0 { 1.0 / s } else { 0.0 }
    }

    /// The weighted mean pose: arithmetic mean of `u`, `v`; circular mean of the heading
    /// (`atan2(Σ w sin θ, Σ w cos θ)`); geometric mean of the scale (`exp Σ w ln s`). O(N).
    pub fn estimate(&self) -> SketchPose {
        let (mut u, mut v, mut sn, mut cs, mut ls) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for p in &self.particles {
            let w = p.weight;
            u += w * p.pose.u_px;
            v += w * p.pose.v_px;
            sn += w * p.pose.heading_rad.sin();
            cs += w * p.pose.heading_rad.cos();
            ls += w * p.pose.meters_per_pixel.ln();
        }
        SketchPose {
            u_px: u,
            v_px: v,
            heading_rad: sn.atan2(cs),
            meters_per_pixel: ls.exp(),
        }
    }

    /// The score (as [`SketchMcl::score`]) of any pose against `scan`, using this
    /// configuration's beam subset and σ(r). `beams_used` casts.
    pub fn score_pose(&self, pose: &SketchPose, scan: &Scan, raycaster: &SketchRaycaster) -> f64 {
        let range_max_m = scan.range_max_m_or(self.config.fallback_range_max_m);
        pose_score(
            pose,
            &beam_data(scan, &self.config),
            raycaster,
            range_max_m,
            &self.config,
        )
    }
}

/// Mean per-beam agreement of `pose` with the scan's used `beams`, by the configured
/// observation model ([`ObservationModel::agreement`]); 0 when `beams` is empty or the pose
/// is outside the image.
fn pose_score(
    pose: &SketchPose,
    beams: &[Beam],
    raycaster: &SketchRaycaster,
    range_max_m: f64,
    config: &MclConfig,
) -> f64 {
    if beams.is_empty() || validate_pose(pose).is_err() || !raycaster.contains(pose.u_px, pose.v_px)
    {
        return 0.0;
    }
    config
        .observation
        .agreement(pose, beams, raycaster, range_max_m)
}

/// The used beams of `scan` (`used_beams`) with their σ(r).
fn beam_data(scan: &Scan, config: &MclConfig) -> Vec<Beam> {
    used_beams(scan, config.beams_used)
        .into_iter()
        .map(|i| Beam::new(scan.beam_angle_rad(i), scan.ranges_m[i] as f64, config))
        .collect()
}

/// Indices of up to `count` beams evenly spaced over the scan (`⌊(k + ½)·n / count⌋`),
/// keeping only real returns. O(count).
pub fn used_beams(scan: &Scan, count: usize) -> Vec<usize> {
    let n = scan.ranges_m.len();
    if n == 0 || count == 0 {
        return Vec::new();
    }
    let m = count.min(n);
    let mut out: Vec<usize> = (0..m)
        .map(|k| (((k as f64 + 0.5) * n as f64 / m as f64) as usize).min(n - 1))
        .filter(|&i| scan.is_return(i))
        .collect();
    out.dedup();
    out
}

fn validate_pose(p: &SketchPose) -> Result<(), EngineError> {
    if !(p.u_px.is_finite() && p.v_px.is_finite() && p.heading_rad.is_finite()) {
        return Err(EngineError::InvalidParameter {
            name: "start",
            reason: "pose must be finite".into(),
        });
    }
    if !(p.meters_per_pixel.is_finite() && p.meters_per_pixel > 0.0) {
        return Err(EngineError::InvalidParameter {
            name: "meters_per_pixel",
            reason: format!("must be a finite number > 0, got {}", p.meters_per_pixel),
        });
    }
    Ok(())
}

/// Draws a zero-mean Gaussian with sd `sd` (0 when `sd` is not a positive finite number).
pub(crate) fn gaussian(rng: &mut impl Rng, sd: f64) -> f64 {
    match Normal::new(0.0, sd) {
        Ok(n) if sd > 0.0 => n.sample(rng),
        _ => 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_chacha::ChaCha8Rng;

    fn start() -> SketchPose {
        SketchPose {
            u_px: 50.0,
            v_px: 50.0,
            heading_rad: 0.0,
            meters_per_pixel: 0.05,
        }
    }

    #[test]
    fn rejects_bad_start_and_config() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let mut bad = start();
        bad.meters_per_pixel = 0.0;
        assert!(
            SketchMcl::new(MclConfig::default(), bad, StartSpread::default(), &mut rng).is_err()
        );
        bad = start();
        bad.u_px = f64::NAN;
        assert!(
            SketchMcl::new(MclConfig::default(), bad, StartSpread::default(), &mut rng).is_err()
        );
        let cfg = MclConfig {
            particles: 0,
            ..MclConfig::default()
        };
        assert!(SketchMcl::new(cfg, start(), StartSpread::default(), &mut rng).is_err());
    }

    #[test]
    fn predict_scales_motion_by_particle_scale() {
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let cfg = MclConfig {
            particles: 3,
            trans_noise_per_m: 0.0,
            rot_noise_per_m: 0.0,
            min_trans_noise_m: 0.0,
            min_rot_noise_rad: 0.0,
            min_scale_walk: 0.0,
            scale_walk_per_sqrt_m: 0.0,
            ..MclConfig::default()
        };
        let spread = StartSpread {
            position_sd_m: 0.0,
            heading_sd_rad: 0.0,
            scale_sd_rel: 0.0,
        };
        let mut mcl = SketchMcl::new(cfg, start(), spread, &mut rng).unwrap();
        mcl.predict(Pose2::new(1.0, 0.0, 0.0), &mut rng);
        let e = mcl.estimate();
        assert!((e.u_px - 70.0).abs() < 1e-9 && (e.v_px - 50.0).abs() < 1e-9);
        mcl.predict(Pose2::new(f64::NAN, 0.0, 0.0), &mut rng);
        assert!(mcl.estimate().u_px.is_finite());
    }

    #[test]
    fn used_beams_are_even_and_skip_no_returns() {
        let scan = Scan {
            header: sketchslam_types::ScanHeader {
                range_min_m: 0.1,
                range_max_m: 10.0,
                beam_count: 10,
                ..Default::default()
            },
            ranges_m: vec![
                1.0,
                f32::NAN,
                1.0,
                1.0,
                1.0,
                1.0,
                1.0,
                f32::INFINITY,
                1.0,
                1.0,
            ],
        };
        assert_eq!(used_beams(&scan, 5), vec![3, 5, 9]);
        assert_eq!(used_beams(&scan, 100).len(), 8);
    }
}
