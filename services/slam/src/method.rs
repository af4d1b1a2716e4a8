//! The one mapping between the HTTP API's enums and the engine's: [`MappingMethod`] and
//! [`Method`], [`DrawingObservationModel`] and [`ObservationModel`], [`DrawingLocalization`]
//! and [`SketchHeadingView`], and the odometry's noise model, [`OdometryNoise`] both sides.
//!
//! It sits in the runtime because the runtime is the one crate that sees both sides: the
//! engine must not depend on the API crate and the API crate must not depend on the engine.
//! (Rust's orphan rule forbids `impl From<MappingMethod> for Method` here, as both types
//! are foreign, hence two functions per pair.) The registry turns a session request into
//! engine settings with the `engine_*` functions and reports them back with the `api_*`
//! ones; tests, benchmarks and `evaluate` go the API's way with the `api_*` ones. Each pair
//! agrees with the wire names of its two enums.

use sketchslam_api::{DrawingLocalization, DrawingObservationModel, MappingMethod};
use sketchslam_engine::localization::observation_model::ObservationModel;
use sketchslam_engine::mapper::{Method, SketchHeadingView};
use sketchslam_engine::scan_matching::odometry_noise::OdometryNoise;

/// The engine's method for an API request's method.
pub fn engine_method(method: MappingMethod) -> Method {
    match method {
        MappingMethod::Sketch => Method::Sketch,
        MappingMethod::Icp => Method::Icp,
        MappingMethod::Graph => Method::Graph,
        MappingMethod::Odometry => Method::Odometry,
    }
}

/// The API's method for an engine method.
pub fn api_method(method: Method) -> MappingMethod {
    match method {
        Method::Odometry => MappingMethod::Odometry,
        Method::Icp => MappingMethod::Icp,
        Method::Graph => MappingMethod::Graph,
        Method::Sketch => MappingMethod::Sketch,
    }
}

/// The engine's observation model of MCL for the API's.
pub fn engine_observation(model: DrawingObservationModel) -> ObservationModel {
    match model {
        DrawingObservationModel::LikelihoodField => ObservationModel::LikelihoodField,
        DrawingObservationModel::RayCast => ObservationModel::RayCast,
    }
}

/// The API's observation model of MCL for the engine's.
pub fn api_observation(model: ObservationModel) -> DrawingObservationModel {
    match model {
        ObservationModel::LikelihoodField => DrawingObservationModel::LikelihoodField,
        ObservationModel::RayCast => DrawingObservationModel::RayCast,
    }
}

/// The engine's view of eq. (5) for the API's drawing localization.
pub fn engine_heading_view(localization: DrawingLocalization) -> SketchHeadingView {
    match localization {
        DrawingLocalization::Mcl => SketchHeadingView::Mcl,
        DrawingLocalization::Warp => SketchHeadingView::Warp,
    }
}

/// The API's drawing localization for the engine's view of eq. (5).
pub fn api_drawing_localization(view: SketchHeadingView) -> DrawingLocalization {
    match view {
        SketchHeadingView::Mcl => DrawingLocalization::Mcl,
        SketchHeadingView::Warp => DrawingLocalization::Warp,
    }
}

/// The engine's odometry noise model for a request's: each factor the request gives,
/// `default`'s for the others.
pub fn engine_odometry_noise(
    asked: &sketchslam_api::OdometryNoise,
    default: OdometryNoise,
) -> OdometryNoise {
    OdometryNoise {
        rot_per_rad: asked.heading_sd_per_rad.unwrap_or(default.rot_per_rad),
        rot_per_m: asked.heading_sd_rad_per_m.unwrap_or(default.rot_per_m),
        trans_per_m: asked.position_sd_per_m.unwrap_or(default.trans_per_m),
        trans_per_rad: asked.position_sd_m_per_rad.unwrap_or(default.trans_per_rad),
    }
}

/// The API's odometry noise model for the engine's, every factor filled in.
pub fn api_odometry_noise(noise: &OdometryNoise) -> sketchslam_api::OdometryNoise {
    sketchslam_api::OdometryNoise {
        heading_sd_per_rad: Some(noise.rot_per_rad),
        heading_sd_rad_per_m: Some(noise.rot_per_m),
        position_sd_per_m: Some(noise.trans_per_m),
        position_sd_m_per_rad: Some(noise.trans_per_rad),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_mapping_is_one_to_one_and_keeps_the_names() {
        for method in Method::ALL {
            let api = api_method(method);
            assert_eq!(api.as_str(), method.as_str());
            assert_eq!(engine_method(api), method);
        }
    }

    /// The wire name of a serde enum value.
    fn name(value: impl serde::Serialize) -> serde_json::Value {
        serde_json::to_value(value).unwrap()
    }

    #[test]
    fn the_drawing_settings_map_one_to_one_and_keep_the_names() {
        for model in [ObservationModel::RayCast, ObservationModel::LikelihoodField] {
            let api = api_observation(model);
            assert_eq!(name(api), name(model));
            assert_eq!(engine_observation(api), model);
        }
        for view in [SketchHeadingView::Mcl, SketchHeadingView::Warp] {
            let api = api_drawing_localization(view);
            assert_eq!(name(api), name(view));
            assert_eq!(engine_heading_view(api), view);
        }
    }

    #[test]
    fn an_odometry_noise_model_fills_what_the_request_leaves_out_and_round_trips() {
        let default = OdometryNoise::default();
        let asked = sketchslam_api::OdometryNoise {
            position_sd_per_m: Some(0.04),
            ..Default::default()
        };
        let engine = engine_odometry_noise(&asked, default);
        assert_eq!(
            engine,
            OdometryNoise {
                trans_per_m: 0.04,
                ..default
            }
        );
        assert_eq!(
            engine_odometry_noise(&api_odometry_noise(&engine), default),
            engine
        );
        let filled = api_odometry_noise(&engine);
        assert!(filled.fields().iter().all(|(_, v)| v.is_some()));
    }
}
