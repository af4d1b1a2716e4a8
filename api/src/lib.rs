//! The sketchslam HTTP API: request/response types, errors as JSON, the axum router over a
//! [`Backend`], the OpenAPI document and a typed client.
//!
//! The crate knows nothing of the mapping engine: the service runtime implements
//! [`Backend`] and serves [`router()`]; tests can do the same with an in-memory fake.
//!
//! ```no_run
//! # async fn demo() -> Result<(), sketchslam_api::ClientError> {
//! let client = sketchslam_api::SketchslamClient::new("http://127.0.0.1:8080");
//! let sketches = client.list_sketches().await?;
//! println!("{} sketches", sketches.sketches.len());
//! # Ok(()) }
//! ```

pub mod backend;
pub mod client;
pub mod error;
pub mod event_log;
pub mod extract;
pub mod map_image;
pub mod occupancy;
pub mod openapi;
pub mod openapi_wire;
pub mod registration;
mod registration_routes;
pub mod router;
pub mod types;
pub mod web;

pub use backend::Backend;
pub use client::{ClientError, EventStream, SketchslamClient};
pub use error::{ApiError, ErrorBody, ErrorDetail};
pub use event_log::{EventLog, EventSubscription, NumberedEvent};
pub use map_image::{MapFrame, TaggedPng};
pub use occupancy::{
    MapMetaData, OccupancyGridResponse, RosHeader, RosPoint, RosPose, RosQuaternion, RosTime,
};
pub use openapi::ApiDoc;
pub use registration::*;
pub use router::{
    DEFAULT_MAX_BODY_BYTES, DEFAULT_MAX_CONCURRENT_UPLOADS, HttpMetrics, RouterOptions, router,
};
pub use types::*;
