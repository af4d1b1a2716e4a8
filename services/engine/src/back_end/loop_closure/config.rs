//! The loop closer's settings: keyframe spacing, the search for loops, their consistency
//! tests and the graph's noise model, each default with what it was measured against.
//!
//! Read by [`super::LoopCloser`]; the switches that are off by default say why.

use crate::back_end::pose_graph::OptimizeConfig;
use crate::scan_matching::correlative::{CorrelativeConfig, SearchWindow};
use crate::scan_matching::icp::IcpConfig;

/// Settings of the loop-closure back end.
#[derive(Debug, Clone, PartialEq)]
pub struct LoopClosureConfig {
    /// A new keyframe after this much travel, meters...
    pub keyframe_distance_m: f64,
    /// ...or this much turn, radians.
    pub keyframe_angle_rad: f64,
    /// Route length between two keyframes before a match between them is a loop, meters.
    pub min_travel_m: f64,
    /// Candidate keyframes lie within this distance of the new keyframe's estimate, meters
    /// (plus however much the search window has grown beyond `window.linear_m`).
    pub search_radius_m: f64,
    /// Candidates tried per new keyframe, nearest first (or most plausibly at the same
    /// place first, see `plausible_first`).
    pub max_candidates: usize,
    /// Order the candidates by the Mahalanobis distance of "at the same place",
    /// `d² / (σ²_drift + loop_sigma_m²)`, instead of the distance `d` alone: `σ²_drift` is
    /// the position variance the route between the candidate and the new keyframe can
    /// have drifted (through the last loops when that is tighter, `drift_since`). A pass
    /// long unclosed 3 m away is then tried before the pass just behind 0.3 m away that
    /// its own loops already tie, and the loop found tells the graph the most. Default
    /// false, measured 2026-12-03 (`graph`): paper-env2 0.041 → 0.029 m, Intel 0.081 →
    /// 0.075 m, CSAIL 0.049 → 0.047 m, all three generated worlds where closing made the
    /// map worse than not closing are mended (cheap hall 18 0.073 → 0.031 m), but two
    /// others turn so, school 0.077 → 0.089 m and on the 30 generated worlds 9 maps worse
    /// against 4 better,
    /// cheap corridor 17 doubled (0.050 → 0.231 m, completeness 0.51): the loosely tied
    /// pass is also where a look-alike passes the chain test. With
    /// `score_observed_only` too: paper-env2 0.018 m and school 0.044 m, but Intel 0.519 m,
    /// CSAIL 0.618 m and cheap hall 24 0.107 m.
    pub plausible_first: bool,
    /// Keyframes on each side of a candidate that join its local map.
    pub local_map_keyframes: usize,
    /// Correlative search window around the estimate, right after a loop closed.
    pub window: SearchWindow,
    /// The window's linear half-width grows by this share of the route travelled since
    /// the last loop closed: the front end's drift grows with distance, and a window
    /// narrower than the drift finds no match at all, m/m.
    pub window_growth_per_m: f64,
    /// The window's linear half-width stops growing here, meters (the search's cost
    /// grows with its area).
    pub max_window_m: f64,
    /// Likelihood field of the correlative search.
    pub correlative: CorrelativeConfig,
    /// Least mean likelihood (0..1) of an accepted loop match.
    pub min_score: f64,
    /// Translations scoring at least this share of the best make up a match's
    /// uncertainty region ([`crate::scan_matching::correlative::LikelihoodField::translation_covariance`]).
    pub plateau_fraction: f64,
    /// Give up a loop edge's weakest direction when the match's score plateau is wider
    /// there than the likelihood kernel (`correlative.sigma_m`) and the scan reaches
    /// beyond the reference along it (`overlap_driven_direction`): such a hump then
    /// holds the heading and the position across a corridor, not along it; the
    /// consistency tests still weigh the match as its plateau claims. Default false,
    /// measured 2026-12-03 (`graph`): paper-env2 0.041 → 0.007 m and school 0.077 →
    /// 0.056 m, but the Intel log 0.081 → 0.212 m and CSAIL 0.049 → 0.057 m, and on the
    /// 30 generated worlds the cheap-LiDAR ones lose the along-corridor pull of loops
    /// that were right (hall 12 0.011 → 0.041 m): a short-range scan overhangs its
    /// reference on most revisits, so overhang alone does not tell a biased top.
    pub unpin_featureless_direction: bool,
    /// Re-place each correlative match by its score over what the reference looked at
    /// only ([`crate::scan_matching::observed_region`]): the middle of that score's
    /// plateau among the poses that would pass `min_score` on their own, with the
    /// plateau's covariance. A scan reaching beyond its reference (a corridor seen from
    /// its other end) is then held by what both saw, not pulled toward more overlap.
    /// Default false, measured 2026-12-03 (`graph`): paper-env2 0.041 → 0.041 m, school
    /// 0.077 → 0.038 m, Intel 0.081 → 0.076 m, but CSAIL 0.049 → 0.403 m (the return to
    /// the start at the log's end is never tried: the drift left before it puts the
    /// nearest candidate on the last pass) and on the 30 generated worlds the worst map
    /// 0.073 → 0.151 m (cheap hall 24), with 241 loops off the truth in the cheap-LiDAR
    /// worlds against 204: with a 12 m scanner the plateau's middle is off more often
    /// than the plain top.
    pub score_observed_only: bool,
    /// A loop gives up each position direction along which its standard deviation is
    /// above this times the chain's — what the route between its ends can have drifted,
    /// through the last loops when that is tighter (`drift_since`) — and its heading when
    /// that is, in the test against the chain and in its graph edge alike
    /// ([`crate::back_end::closure_consistency::given_up_to_chain`]; the module doc there,
    /// "What a loop adds"). 1: the match says less there than the graph already knows, and
    /// its top along a wide plateau carries a bias its covariance does not. `None` keeps
    /// every direction. Default `None`, measured 2026-12-07 (`graph`, release, in-process,
    /// with the anchored keyframe step it is meant for): on the 60 generated worlds map
    /// error median / p90 / worst 0.013 / 0.057 / 0.224 → 0.016 / 0.052 / 0.202 m, ATE worst
    /// 0.933 → 0.889 m, completeness worst 0.362 → 0.605, closing worse than open 8 → 8;
    /// good office 43, bent by 401 right loops and a dozen 0.15–1.5 m or 1.4–2.8° off, back
    /// to its open map (0.049 → 0.014 m); CSAIL 0.047 m on all five frame turns (0.045–0.047;
    /// without, 0.158 at 0°), paper-env2 0.017 → 0.006 m, Intel 0.073 → 0.074 m, but school
    /// 0.044 → 0.086 m and good corridor 50 0.015 → 0.141 m (completeness 0.69): where the
    /// chain claims less drift than the front end makes, the right loops' correction is
    /// given up and the wrong ones are not tested. Tried with the given-up loops neither
    /// vouching nor routing the chain tests (`docs/experiments/give-up-not-routed.diff`):
    /// worse (worst 0.738 m, paper-env2 0.071 m, school 0.107 m). On the default summed
    /// step: 0.014 / 0.063 / 0.696 → 0.015 / 0.064 / 0.248 m, closing worse 9 → 10, CSAIL
    /// 0.045–0.046 m on all five turns, Intel 0.074 → 0.077 m.
    pub give_up_beyond_chain: Option<f64>,
    /// The shape of the chain's uncertainty in the test of a loop against it
    /// ([`ChainShape`]). Default `Isotropic`, measured 2026-12-08 (`graph`, release,
    /// in-process; README, "The chain's whole covariance"): `Full` with the set loop
    /// heading changes little (seeds 31–60 map error 0.018 / 0.088 / 0.696 → 0.018 / 0.098 /
    /// 0.696 m; cheap corridor 41 0.222 → 0.196 m, its wrong loops still pass on a chain
    /// whose summed heading variance reaches 5.3° and swings the end 2 m); with
    /// `PlateauWithinSet` it mends corridor 41 (0.241 → 0.048 m; seeds 31–60 0.013 / 0.042 /
    /// 0.241 → 0.013 / 0.048 / 0.211 m, ATE worst 1.585 → 0.734 m) but breaks the good
    /// corridors 38 (0.017 → 0.108 m) and 26 (0.031 → 0.093 m), whose front end slides
    /// along the axis at a dead end: tight along the axis, the chain refuses the right
    /// loops that would take the slide out; and with it paper-env2's drawing E 0.014 →
    /// 0.099 m and the MIT CSAIL log 0.046 [0.044–0.051] → 0.076 [0.046–0.105] m over five
    /// frame turns.
    pub chain_shape: ChainShape,
    /// A match whose uncertainty region is wider than this (standard deviation along its
    /// weakest direction) pins nothing down and is dropped, meters.
    pub max_match_sigma_m: f64,
    /// ICP refining a loop match.
    pub icp: IcpConfig,
    /// Standard deviation of a sequential edge: this plus `sequential_sigma_per_m` per
    /// meter of the step, meters.
    pub sequential_sigma_m: f64,
    /// Growth of the sequential sigma per meter travelled.
    pub sequential_sigma_per_m: f64,
    /// Heading standard deviation of a sequential edge, radians.
    pub sequential_sigma_rad: f64,
    /// Where a sequential edge's covariance comes from: the a-priori figures above on
    /// every step, or the front end's own covariance of the step when it gave one
    /// ([`SequentialNoise`]). Default `FrontEnd`, measured 2026-12-04 (`graph`, release,
    /// in-process) against `APriori`: on the 30 generated worlds map error median / p90 /
    /// worst 0.012 / 0.050 / 0.073 → 0.014 / 0.036 / 0.078 m, worlds closing worse than
    /// open 3 → 0; with the frame turned 10° 0.013 / 0.062 / 0.112 → 0.011 / 0.051 / 0.088
    /// m, worst completeness 0.772 → 0.898, closing worse 5 → 4; paper-env2 0.041 → 0.034,
    /// school 0.077 → 0.045, Intel relations 0.081 → 0.076, CSAIL 0.049 → 0.051 m,
    /// paper-env1 0.004 → 0.005 m. With each return weighted by how many share its
    /// reference point (a looser, better calibrated covariance): cheap hall 24 doubles
    /// (completeness 0.39) and CSAIL 0.550 m — the looser the chain, the more look-alike
    /// loops its consistency tests let through.
    pub sequential_noise: SequentialNoise,
    /// Standard deviation of a loop edge, meters.
    pub loop_sigma_m: f64,
    /// Heading standard deviation of a loop edge, radians (with `loop_heading` `Set`; the
    /// bound of `PlateauWithinSet`).
    pub loop_sigma_rad: f64,
    /// Where a loop edge's heading deviation comes from ([`LoopHeadingSigma`]). Default
    /// `Set`. Measured 2026-12-07 (`graph`, seeds 1–30; README, "A loop's heading from its
    /// match"): `PlateauWithinSet` 0.014 / 0.046 / 0.073 → 0.012 / 0.031 / 0.075 m, 10
    /// worlds better and 2 worse, paper-env2 0.034 → 0.012 m, school 0.045 → 0.049 m,
    /// CSAIL 0.049 [0.046–0.083] → 0.046 [0.044–0.051] m over five frame turns, Intel
    /// 0.074 m both; `Plateau` worse (worst 0.098 m, completeness 0.72). On 60 worlds
    /// `PlateauWithinSet` 0.014 / 0.063 / 0.696 → 0.012 / 0.042 / 0.241 m, closing worse 9
    /// → 4, but `sketch` on school's rough drawing 0.040 → 0.097 m: not the default. That
    /// doubling is block Jacobi's unfinished solve (every loop in the graph right; the
    /// chain preconditioner gives 0.024 m, squeezed 0.012 m), but with the chain CSAIL
    /// breaks on two frame turns of five (0.228, 0.101 m) and the worst generated world is
    /// 0.166 m (README, "School's doubling is the block-Jacobi solve stopping short").
    pub loop_heading: LoopHeadingSigma,
    /// Huber width of loop edges on the Mahalanobis distance.
    pub loop_huber: f64,
    /// Standard deviation of a keyframe's heading prior from the drawing's wall families
    /// ([`crate::back_end::heading_prior`]: each family held where the route first saw it),
    /// radians; `None` leaves priors out (only `sketch` sessions have a drawing to take
    /// them from). 2° by default: a family of walls runs straight across a floor to a
    /// degree or two, and a scan's long lines measure its direction to a fraction of that.
    /// Measured 2026-12-06 on 30 generated worlds (`sketch`, drawing A): map error median /
    /// p90 / worst 0.013 / 0.062 / 0.072 → 0.010 / 0.028 / 0.058 m (`graph` 0.014 / 0.046 /
    /// 0.073), 19 maps better and 6 worse, live ATE median 0.188 → 0.099 m (`graph` 0.158)
    /// but cheap corridor 17's 0.357 → 1.284 m; paper-env2 and school (three seeds) maps
    /// 0.015 / 0.035 / 0.007 → 0.013 / 0.011 / 0.010 m and 0.061 / 0.061 → 0.040 / 0.024 m;
    /// Intel relations 0.073–0.074 m as without. Taken against the drawing's own axes
    /// instead, the mark's error and the drawn angles' bent the map (Intel person-1 0.136 →
    /// 0.910 m when first tried; paper-env2 D 0.015 → 0.027 m).
    pub heading_prior_sigma_rad: Option<f64>,
    /// Huber width of heading priors on the Mahalanobis distance.
    pub heading_prior_huber: f64,
    /// With heading priors pending, the graph is optimized every this many keyframes.
    pub optimize_every_keyframes: usize,
    /// Keyframe points are thinned to one per square of this side, meters.
    pub voxel_m: f64,
    /// Gauss–Newton settings.
    pub optimize: OptimizeConfig,
    /// χ² bound (3 degrees of freedom) of the consistency tests of a matched loop against
    /// the odometry chain and against another loop
    /// ([`crate::back_end::closure_consistency`]). Default 11.34, the 99 % quantile: a right
    /// loop fails one test in a hundred.
    pub consistency_chi2: f64,
    /// A matched loop enters the graph once this many loops, itself included, agree
    /// pairwise; one that agrees with a loop already in the graph near it needs only that
    /// one. Default 3: in a row of identical rooms one look-alike match is common, three
    /// matches from different keyframes that agree on one wrong place are not.
    pub min_consistent_loops: usize,
    /// A loop already in the graph vouches for a new one only when their references' local
    /// maps share no keyframe (`|from₁ − from₂| > 2 · local_map_keyframes`): matches against
    /// the same stretch of the old pass share its bias, so one agreeing with the other is
    /// no evidence. Default false, measured 2026-12-03 (`graph`): school 0.077 → 0.013 m,
    /// Intel 0.081 → 0.078 m, CSAIL and paper-env1 unchanged, but paper-env2 0.041 → 0.051
    /// m and on the 30 generated worlds 6 maps worse against 4 better (median 0.012 →
    /// 0.016 m, worst 0.073 → 0.079 m, worst completeness 0.879 → 0.836: cheap hall 24),
    /// cheap hall 18, the creep this was for, unchanged (0.079 m): waiting loops that share
    /// one reference's bias still agree with each other in threes.
    pub independent_vouching: bool,
    /// A matched loop waits this many keyframes for others to agree with it, then is
    /// rejected. Default 20 (10 m of route at the default keyframe spacing).
    pub pending_keyframes: usize,
    /// After an optimization, a loop edge whose squared Mahalanobis error is above this
    /// times the loops' variance factor (`variance_factor`: their median strain over
    /// χ²(3)'s) disagrees with the rest of the graph and is taken out again (16.27 is the
    /// 99.9 % χ² quantile of 3 degrees of freedom). Default `None`, measured:
    /// - 2026-12-02, against the a-priori bound alone: the Intel log's relations 0.086 →
    ///   0.325 m (the sequential edges' a-priori noise is tighter than a real front end's
    ///   drift, so right loops over a long chain leave); on 16 generated worlds one map
    ///   changed, by 2 cm.
    /// - 2026-12-03, scaled by the variance factor (`graph`): on 30 generated worlds one
    ///   map better (cheap corridor 11, 0.073 → 0.051 m) and none worse, the shared worlds
    ///   unchanged, but the Intel log 0.081 → 0.316 m and CSAIL 0.049 → 0.160 m: on a log
    ///   of one scan a second the right loops' strain is heavy-tailed, and the worst right
    ///   loop stands out against the median one as a wrong loop would.
    ///
    /// It stays for graphs whose noise model is trusted.
    pub residual_chi2: Option<f64>,
    /// Match each loop back — the older keyframe's scan against the local map of the newer
    /// one and the route before it — and refuse it unless that match scores and the two
    /// agree ([`crate::back_end::closure_consistency::two_way_distance_sq`] within
    /// `consistency_chi2`). Default false, measured 2026-12-04 (`graph`), with the newer
    /// side's map over `4 · local_map_keyframes` keyframes (about 8 m of route): on the 30
    /// generated worlds 8 maps better against 4 worse, cheap hall 18 mended (0.073 →
    /// 0.033 m, open 0.039 m: an early loop 0.13 m off that the newer side cannot match
    /// back), no world closed worse than open by more than 5 mm, but cheap corridor 23
    /// doubles (0.041 → 0.077 m, completeness 0.879 → 0.771) and cheap hall 24 loses
    /// completeness (0.970 → 0.852): a 12 m scanner's older view is often not in the newer
    /// side's map, and the right loops refused with it held those corridors. Shared:
    /// school 0.077 → 0.034 m, paper-env2 0.041 → 0.043 m, paper-env1 0.004 m and Intel
    /// 0.081 → 0.080 m unchanged, but CSAIL 0.049 → 0.183 m. Over half as much route
    /// (`2 ·`): 7 better, 5 worse, paper-env2 0.069 m.
    pub two_way_check: bool,
}

impl Default for LoopClosureConfig {
    fn default() -> Self {
        Self {
            keyframe_distance_m: 0.5,
            keyframe_angle_rad: 20f64.to_radians(),
            min_travel_m: 8.0,
            search_radius_m: 4.0,
            max_candidates: 1,
            plausible_first: false,
            local_map_keyframes: 4,
            window: SearchWindow {
                linear_m: 1.5,
                angular_rad: 12f64.to_radians(),
            },
            window_growth_per_m: 0.1,
            max_window_m: 3.0,
            correlative: CorrelativeConfig::default(),
            min_score: 0.6,
            plateau_fraction: 0.95,
            unpin_featureless_direction: false,
            score_observed_only: false,
            give_up_beyond_chain: None,
            chain_shape: ChainShape::Isotropic,
            max_match_sigma_m: 0.5,
            icp: IcpConfig::default(),
            sequential_sigma_m: 0.02,
            sequential_sigma_per_m: 0.02,
            sequential_sigma_rad: 0.5f64.to_radians(),
            sequential_noise: SequentialNoise::FrontEnd,
            loop_sigma_m: 0.05,
            loop_sigma_rad: 1f64.to_radians(),
            loop_heading: LoopHeadingSigma::Set,
            loop_huber: 2.0,
            heading_prior_sigma_rad: Some(2f64.to_radians()),
            heading_prior_huber: 2.0,
            optimize_every_keyframes: 10,
            voxel_m: 0.05,
            optimize: OptimizeConfig::default(),
            consistency_chi2: 11.34,
            min_consistent_loops: 3,
            independent_vouching: false,
            pending_keyframes: 20,
            residual_chi2: None,
            two_way_check: false,
        }
    }
}

/// Where a loop edge's heading deviation comes from
/// ([`LoopClosureConfig::loop_heading`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LoopHeadingSigma {
    /// `loop_sigma_rad` for every loop.
    #[default]
    Set,
    /// The match's own: its heading plateau
    /// ([`crate::scan_matching::heading_plateau`]) plus `loop_sigma_m` at the scan points'
    /// rms range. A hall seen 20 m out pins the heading to a tenth of a degree, a room seen
    /// up close to about a degree or more.
    Plateau,
    /// The tighter of the two: both bound how far a match's heading is off (the plateau
    /// is what the likelihood field resolves, wider than ICP's refinement in a small room;
    /// `loop_sigma_rad` what the matcher's loops were measured off by, within 0.5° for
    /// 401 of 413 on a good scanner), so the plateau may tighten the set figure where the
    /// scan's lever arms resolve the heading better, never loosen it.
    PlateauWithinSet,
}

/// The shape of the chain's uncertainty in the test of a loop against it
/// ([`LoopClosureConfig::chain_shape`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ChainShape {
    /// Every step's widest position variance, and its heading's swing, in every direction
    /// ([`crate::back_end::closure_consistency::chain_variance`]): errs towards accepting.
    #[default]
    Isotropic,
    /// Each step's whole covariance carried to the loop's end, the heading's swing across
    /// the lever only ([`crate::back_end::closure_consistency::chain_covariance`]): a
    /// corridor's chain is loose along the axis only by what the front end left
    /// unmeasured there.
    Full,
}

/// Where the sequential edges' covariance comes from
/// ([`LoopClosureConfig::sequential_noise`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SequentialNoise {
    /// `sequential_sigma_m + sequential_sigma_per_m · l` in position and
    /// `sequential_sigma_rad` in heading on every step, whatever the front end saw.
    APriori,
    /// The covariance the front end reported for the step's scans, summed (keyframe ICP:
    /// `rms² H⁻¹` of each scan's match, the odometry's along what a scan does not measure;
    /// [`crate::scan_matching::icp::IcpResult::covariance`]); the a-priori figures where it
    /// gave none. A step down a featureless corridor is then loose along it and tight
    /// across, a step in a cluttered room tight, a step of a cheap scanner looser than one
    /// of a good one — in the graph's edges and in the consistency tests alike.
    FrontEnd,
}
