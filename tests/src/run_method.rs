//! What a run maps with: an engine method, and for the methods that close loops, the option
//! of leaving them open (`graph-open`: the same front end with no back end), so a table can
//! show what closing loops adds — or costs.

use sketchslam_engine::back_end::loop_closure::{ChainShape, LoopClosureConfig, LoopHeadingSigma};
use sketchslam_engine::back_end::pose_graph::{OptimizeConfig, Preconditioning};
use sketchslam_engine::localization::mcl::MclConfig;
use sketchslam_engine::localization::observation_model::ObservationModel;
use sketchslam_engine::mapper::{KeyframeStepModel, MapperConfig, Method, SketchHeadingView};
use sketchslam_engine::scan_matching::odometry_noise::OdometryNoise;
use sketchslam_simulator::scenario::OdometryConfig;
use sketchslam_types::Pose2;
use std::fmt;
use std::str::FromStr;

/// Suffix of a method name that leaves loops open.
const OPEN_SUFFIX: &str = "-open";

/// An engine method and whether its back end closes loops.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunMethod {
    /// The engine's method.
    pub method: Method,
    /// False: the mapper runs without loop closure (`MapperConfig::loop_closure = None`).
    pub loop_closure: bool,
    /// Where the LiDAR sits on the robot (the stream's, not the method's: set from the
    /// scenario by the runs; zero by default).
    pub lidar_mount: Pose2,
    /// Tell the mapper the simulated robot's own wheel error model ([`wheel_model`] of the
    /// scenario's `[odometry]`) instead of the service's default, as a user who knows their
    /// robot would (`evaluate --own-wheels`). False by default; logs keep the default.
    pub own_wheels: bool,
    /// The wheel model the mapper is told (`MapperConfig::odometry_noise`) when set: set
    /// from the scenario by the runs when [`Self::own_wheels`]; the engine's default
    /// otherwise.
    pub odometry_noise: Option<OdometryNoise>,
    /// The map frame turned from the robot's start heading, radians
    /// (`MapperConfig::frame_turn_rad`; methods without a drawing only). Zero by default.
    pub frame_turn_rad: f64,
    /// `sketch` runs in-process: keep each live fit of W with the map of its moment
    /// (`crate::live_warp::write_live_fits`), for `bench-warp`. False by default.
    pub keep_live_warps: bool,
    /// `sketch` runs in-process: replay the service's warp worker to score the live pose
    /// on the drawing (`crate::live_warp`; a fit every 10 keyframes, most of a generated
    /// world's run time). True by default.
    pub live_warp: bool,
    /// `sketch` runs: how MCL on the drawing weighs a scan (`MclConfig::observation`; the
    /// engine's default unless asked).
    pub mcl_observation: ObservationModel,
    /// `sketch` runs: where eq. (5) reads the drawn walls in view
    /// (`MapperConfig::sketch_heading_view`; the engine's default unless asked).
    pub sketch_heading_view: SketchHeadingView,
    /// `sketch` runs: eq. (5)'s heading gain (`MapperConfig::sketch_heading_gain`) when
    /// set, the engine's default otherwise. 0 leaves the drawing out of the map.
    pub sketch_heading_gain: Option<f64>,
    /// `sketch` runs: the keyframes' heading prior from the drawing's wall directions
    /// (`LoopClosureConfig::heading_prior_sigma_rad`) when set (0: none), the engine's
    /// default otherwise.
    pub wall_heading_prior_rad: Option<f64>,
    /// `sketch` runs: whether the start heading is read from the first scan's walls
    /// (`MapperConfig::sketch_start_from_walls`) when set, the engine's default otherwise.
    pub sketch_start_from_walls: Option<bool>,
    /// The engine's seed (`MapperConfig::seed`) instead of the scenario's, when set: how
    /// much a result owes to the random draws (MCL, RANSAC) rather than to the method.
    pub engine_seed: Option<u64>,
    /// Methods that close loops: how the pose graph's solves are preconditioned
    /// (`OptimizeConfig::preconditioning`) when set, the engine's default otherwise.
    pub preconditioning: Option<Preconditioning>,
    /// Keyframe ICP of `graph` and `sketch`: hold the odometry's prediction along the
    /// translation directions faced by fewer returns than this
    /// (`MapperConfig::icp_min_constraining_points`) when set (0: never), the engine's
    /// default otherwise.
    pub icp_hold_min_points: Option<f64>,
    /// With `icp_hold_min_points`: hold only slides beyond this many sigmas of the
    /// odometry's error over the step (`MapperConfig::icp_hold_beyond_sigmas`) when set.
    pub icp_hold_beyond_sigmas: Option<f64>,
    /// With `icp_hold_beyond_sigmas`: judged over the stretch since the last scan ICP
    /// placed in every direction (`MapperConfig::icp_hold_over_stretch`) when true.
    pub icp_hold_over_stretch: bool,
    /// `graph` and `sketch`: how the scans' covariances between two keyframes make the
    /// step's (`MapperConfig::keyframe_step`) when set, the engine's default otherwise.
    pub keyframe_step: Option<KeyframeStepModel>,
    /// Methods that close loops: a loop gives up the position directions and the heading
    /// where it is looser than this times the chain (`LoopClosureConfig::give_up_beyond_chain`) when
    /// set (0: never), the engine's default otherwise.
    pub give_up_beyond_chain: Option<f64>,
    /// Methods that close loops: where a loop edge's heading deviation comes from
    /// (`LoopClosureConfig::loop_heading`) when set, the engine's default otherwise.
    pub loop_heading: Option<LoopHeadingSigma>,
    /// Methods that close loops: the shape of the chain's uncertainty in the test of a
    /// loop against it (`LoopClosureConfig::chain_shape`) when set, the engine's default
    /// otherwise.
    pub chain_shape: Option<ChainShape>,
    /// `evaluate --repeat`: sample `k` of the run turns the map frame by a further
    /// [`crate::samples::sample_turn_deg`]`(k)` (methods without a drawing) and adds `k` to
    /// the engine's seed. 0, the plain run, by default.
    pub sample: usize,
}

impl From<Method> for RunMethod {
    fn from(method: Method) -> Self {
        RunMethod {
            method,
            loop_closure: true,
            lidar_mount: Pose2::IDENTITY,
            own_wheels: false,
            odometry_noise: None,
            frame_turn_rad: 0.0,
            keep_live_warps: false,
            live_warp: true,
            mcl_observation: ObservationModel::default(),
            sketch_heading_view: SketchHeadingView::default(),
            sketch_heading_gain: None,
            sketch_start_from_walls: None,
            wall_heading_prior_rad: None,
            engine_seed: None,
            preconditioning: None,
            icp_hold_min_points: None,
            icp_hold_beyond_sigmas: None,
            icp_hold_over_stretch: false,
            keyframe_step: None,
            give_up_beyond_chain: None,
            loop_heading: None,
            chain_shape: None,
            sample: 0,
        }
    }
}

impl RunMethod {
    /// This run on a simulated robot with wheels `odometry`: their [`wheel_model`] told to
    /// the mapper when [`Self::own_wheels`], as given otherwise.
    pub fn on_wheels(self, odometry: &OdometryConfig) -> Self {
        Self {
            odometry_noise: if self.own_wheels {
                Some(wheel_model(odometry))
            } else {
                self.odometry_noise
            },
            ..self
        }
    }

    /// The mapper's settings for this run, seeded with `seed`.
    pub fn config(&self, seed: u64) -> MapperConfig {
        let defaults = MapperConfig::default();
        MapperConfig {
            seed: self.engine_seed.unwrap_or(seed) + self.sample as u64,
            mcl: MclConfig {
                observation: self.mcl_observation,
                ..defaults.mcl.clone()
            },
            loop_closure: defaults
                .loop_closure
                .filter(|_| self.loop_closure)
                .map(|closure| LoopClosureConfig {
                    heading_prior_sigma_rad: match self.wall_heading_prior_rad {
                        Some(sigma_rad) if sigma_rad > 0.0 => Some(sigma_rad),
                        Some(_) => None,
                        None => closure.heading_prior_sigma_rad,
                    },
                    give_up_beyond_chain: match self.give_up_beyond_chain {
                        Some(ratio) if ratio > 0.0 => Some(ratio),
                        Some(_) => None,
                        None => closure.give_up_beyond_chain,
                    },
                    loop_heading: self.loop_heading.unwrap_or(closure.loop_heading),
                    chain_shape: self.chain_shape.unwrap_or(closure.chain_shape),
                    optimize: OptimizeConfig {
                        preconditioning: self
                            .preconditioning
                            .unwrap_or(closure.optimize.preconditioning),
                        ..closure.optimize
                    },
                    ..closure
                }),
            icp_min_constraining_points: match self.icp_hold_min_points {
                Some(points) if points > 0.0 => Some(points),
                Some(_) => None,
                None => defaults.icp_min_constraining_points,
            },
            icp_hold_beyond_sigmas: self
                .icp_hold_beyond_sigmas
                .or(defaults.icp_hold_beyond_sigmas),
            icp_hold_over_stretch: self.icp_hold_over_stretch || defaults.icp_hold_over_stretch,
            keyframe_step: self.keyframe_step.unwrap_or(defaults.keyframe_step),
            lidar_mount: self.lidar_mount,
            odometry_noise: self.odometry_noise.or(defaults.odometry_noise),
            frame_turn_rad: self.frame_turn_rad
                + crate::samples::sample_turn_deg(self.sample).to_radians(),
            sketch_heading_view: self.sketch_heading_view,
            sketch_heading_gain: self
                .sketch_heading_gain
                .unwrap_or(defaults.sketch_heading_gain),
            sketch_start_from_walls: self
                .sketch_start_from_walls
                .unwrap_or(defaults.sketch_start_from_walls),
            ..defaults
        }
    }
}

/// The error model of a simulated robot's wheels in the mapper's terms (Thrun's α's,
/// standard deviations per meter and per radian): the simulator's error after a meter is
/// `N(bias, noise²)` ([`OdometryConfig`]), so its σ over a meter is bounded by
/// `|bias| + noise`, and likewise per radian turned. The simulator has no cross terms (a
/// turn's error does not depend on the travel, nor the other way); they get 0.01, a
/// hundredth of a meter or radian, for what the model leaves out.
pub fn wheel_model(odometry: &OdometryConfig) -> OdometryNoise {
    const CROSS: f64 = 0.01;
    OdometryNoise {
        rot_per_rad: odometry.rot_bias.abs() + odometry.rot_noise,
        rot_per_m: CROSS,
        trans_per_m: odometry.trans_bias.abs() + odometry.trans_noise,
        trans_per_rad: CROSS,
    }
}

impl fmt::Display for RunMethod {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.loop_closure {
            write!(f, "{}", self.method)
        } else {
            write!(f, "{}{OPEN_SUFFIX}", self.method)
        }
    }
}

impl FromStr for RunMethod {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let (name, loop_closure) = match s.strip_suffix(OPEN_SUFFIX) {
            Some(name) => (name, false),
            None => (s, true),
        };
        let method: Method = name.parse().map_err(|e| format!("{e}"))?;
        if !loop_closure && !matches!(method, Method::Graph | Method::Sketch) {
            return Err(format!(
                "{s:?}: only graph and sketch close loops, so only they have an -open variant"
            ));
        }
        Ok(RunMethod {
            loop_closure,
            ..RunMethod::from(method)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_open_needs_a_back_end() {
        for name in [
            "odometry",
            "icp",
            "graph",
            "sketch",
            "graph-open",
            "sketch-open",
        ] {
            let m: RunMethod = name.parse().unwrap();
            assert_eq!(m.to_string(), name);
        }
        let open: RunMethod = "graph-open".parse().unwrap();
        assert!(open.config(3).loop_closure.is_none());
        assert!(
            RunMethod::from(Method::Graph)
                .config(3)
                .loop_closure
                .is_some()
        );
        assert!("icp-open".parse::<RunMethod>().is_err());
        assert!("nonsense".parse::<RunMethod>().is_err());
    }

    #[test]
    fn a_robots_own_wheels_are_told_to_the_mapper() {
        // school's worn wheels: 3 % scale bias and 0.05 m after a meter; 2 % and 0.05 rad
        // after a radian.
        let school = OdometryConfig {
            rate_hz: 50.0,
            trans_noise: 0.05,
            rot_noise: 0.05,
            trans_bias: 0.03,
            rot_bias: -0.02,
        };
        let model = wheel_model(&school);
        assert!((model.trans_per_m - 0.08).abs() < 1e-12, "{model:?}");
        assert!((model.rot_per_rad - 0.07).abs() < 1e-12, "{model:?}");
        assert_eq!((model.rot_per_m, model.trans_per_rad), (0.01, 0.01));
        let told = RunMethod {
            odometry_noise: Some(model),
            ..Method::Graph.into()
        };
        assert_eq!(told.config(1).odometry_noise, Some(model));
        // Asked for (`--own-wheels`), a run on these wheels tells the mapper; not asked, not.
        let asked = RunMethod {
            own_wheels: true,
            ..Method::Graph.into()
        };
        assert_eq!(asked.on_wheels(&school).odometry_noise, Some(model));
        assert_eq!(
            RunMethod::from(Method::Graph)
                .on_wheels(&school)
                .odometry_noise,
            None
        );
        let plain = RunMethod::from(Method::Graph).config(1).odometry_noise;
        assert_eq!(plain, MapperConfig::default().odometry_noise);
    }

    #[test]
    fn a_sample_turns_the_frame_and_moves_the_seed() {
        let mut m = RunMethod::from(Method::Graph);
        m.frame_turn_rad = 10f64.to_radians();
        let plain = m.config(3);
        assert_eq!(plain.seed, 3);
        assert!((plain.frame_turn_rad - 10f64.to_radians()).abs() < 1e-12);
        m.sample = 2;
        let second = m.config(3);
        assert_eq!(second.seed, 5);
        assert!((second.frame_turn_rad - 9f64.to_radians()).abs() < 1e-12);
        m.engine_seed = Some(40);
        assert_eq!(m.config(3).seed, 42);
    }

    #[test]
    fn the_keyframe_step_model_asked_for_reaches_the_mapper() {
        let mut m = RunMethod::from(Method::Graph);
        assert_eq!(
            m.config(1).keyframe_step,
            MapperConfig::default().keyframe_step
        );
        for asked in [
            KeyframeStepModel::Summed,
            KeyframeStepModel::Anchored,
            KeyframeStepModel::MeasuredHeading,
        ] {
            m.keyframe_step = Some(asked);
            assert_eq!(m.config(1).keyframe_step, asked);
        }
    }

    #[test]
    fn the_give_up_ratio_asked_for_reaches_the_loop_closer() {
        let ratio = |m: &RunMethod| m.config(1).loop_closure.map(|c| c.give_up_beyond_chain);
        let mut m = RunMethod::from(Method::Graph);
        assert_eq!(
            ratio(&m),
            Some(LoopClosureConfig::default().give_up_beyond_chain)
        );
        m.give_up_beyond_chain = Some(2.0);
        assert_eq!(ratio(&m), Some(Some(2.0)));
        m.give_up_beyond_chain = Some(0.0);
        assert_eq!(ratio(&m), Some(None));
    }

    #[test]
    fn the_loop_heading_asked_for_reaches_the_loop_closer() {
        let heading = |m: &RunMethod| m.config(1).loop_closure.map(|c| c.loop_heading);
        let mut m = RunMethod::from(Method::Graph);
        assert_eq!(heading(&m), Some(LoopClosureConfig::default().loop_heading));
        for asked in [
            LoopHeadingSigma::Plateau,
            LoopHeadingSigma::PlateauWithinSet,
        ] {
            m.loop_heading = Some(asked);
            assert_eq!(heading(&m), Some(asked));
        }
    }

    #[test]
    fn the_chain_shape_asked_for_reaches_the_loop_closer() {
        let shape = |m: &RunMethod| m.config(1).loop_closure.map(|c| c.chain_shape);
        let mut m = RunMethod::from(Method::Graph);
        assert_eq!(shape(&m), Some(LoopClosureConfig::default().chain_shape));
        m.chain_shape = Some(ChainShape::Full);
        assert_eq!(shape(&m), Some(ChainShape::Full));
    }

    #[test]
    fn the_preconditioning_asked_for_reaches_the_pose_graph() {
        let solve = |m: &RunMethod| m.config(1).loop_closure.map(|c| c.optimize.preconditioning);
        let mut m: RunMethod = "graph".parse().unwrap();
        let default = LoopClosureConfig::default().optimize.preconditioning;
        assert_eq!(solve(&m), Some(default));
        for asked in [Preconditioning::BlockJacobi, Preconditioning::Chain] {
            m.preconditioning = Some(asked);
            assert_eq!(solve(&m), Some(asked));
        }
    }

    #[test]
    fn the_icp_hold_asked_for_reaches_the_front_end() {
        let hold = |m: &RunMethod| m.config(1).icp_min_constraining_points;
        let mut m: RunMethod = "graph".parse().unwrap();
        assert_eq!(
            hold(&m),
            MapperConfig::default().icp_min_constraining_points
        );
        m.icp_hold_min_points = Some(20.0);
        assert_eq!(hold(&m), Some(20.0));
        // 0 takes ICP's pose as it converged.
        m.icp_hold_min_points = Some(0.0);
        assert_eq!(hold(&m), None);
        let beyond = |m: &RunMethod| m.config(1).icp_hold_beyond_sigmas;
        m.icp_hold_beyond_sigmas = Some(3.0);
        assert_eq!(beyond(&m), Some(3.0));
        assert!(!m.config(1).icp_hold_over_stretch);
        m.icp_hold_over_stretch = true;
        assert!(m.config(1).icp_hold_over_stretch);
    }

    #[test]
    fn a_wall_heading_prior_reaches_the_back_end_and_only_one() {
        let prior = |m: &RunMethod| m.config(1).loop_closure.map(|c| c.heading_prior_sigma_rad);
        let mut m: RunMethod = "sketch".parse().unwrap();
        let default = LoopClosureConfig::default().heading_prior_sigma_rad;
        assert!(default.is_some(), "on by default");
        assert_eq!(prior(&m), Some(default));
        m.wall_heading_prior_rad = Some(0.03);
        assert_eq!(prior(&m), Some(Some(0.03)));
        // 0 leaves them out.
        m.wall_heading_prior_rad = Some(0.0);
        assert_eq!(prior(&m), Some(None));
        // Without loop closure there is no back end to hold it.
        let mut open: RunMethod = "sketch-open".parse().unwrap();
        open.wall_heading_prior_rad = Some(0.03);
        assert_eq!(prior(&open), None);
    }
}
