//! Localization on the drawing: where the robot is on the hand-drawn map, and at what scale.
//!
//! Second stage of a `sketch` session's scan, after the drawing was ingested ([`crate::sketch`])
//! and before its lines correct the heading ([`crate::lines`]):
//! - [`mcl`]: Monte Carlo localization with a scale per particle (eq. 1–3);
//! - [`observation_model`]: how likely a scan is from a particle — the paper's ray-traced
//!   eq. (3), or a likelihood field on the drawing's distance transform;
//! - [`recovery`]: breakdown detection and the respread of section 3.2;
//! - [`line_observation`]: the line observation probability (eq. 4), the sketch lines the
//!   robot really sees from MCL's estimate.

pub mod line_observation;
pub mod mcl;
pub mod observation_model;
pub mod recovery;
