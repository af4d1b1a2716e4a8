//! The one mapping between the HTTP API's enums and the engine's: [`MappingMethod`] and
//! [`Method`], [`DrawingObservationModel`] and [`ObservationModel`], [`DrawingLocalization`]
//! and [`SketchHeadingView`].
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
}
