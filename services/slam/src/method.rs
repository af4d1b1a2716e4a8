//! The one mapping between the HTTP API's [`MappingMethod`] and the engine's [`Method`].
//!
//! It sits in the runtime because the runtime is the one crate that sees both sides: the
//! engine must not depend on the API crate and the API crate must not depend on the engine.
//! (Rust's orphan rule forbids `impl From<MappingMethod> for Method` here, as both types
//! are foreign, hence two functions.) The registry turns a session request into an engine
//! method with [`engine_method`]; tests, benchmarks and `evaluate` go the other way with
//! [`api_method`]. Both agree with the names (`as_str`) of the two enums.

use sketchslam_api::MappingMethod;
use sketchslam_engine::mapper::Method;

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
}
