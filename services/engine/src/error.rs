//! The engine's error type: every way a value handed to the engine can be refused.

use thiserror::Error;

/// Errors of the mapping engine.
#[derive(Debug, Error)]
pub enum EngineError {
    /// The image bytes are not a PNG or JPEG that decodes.
    #[error("the image does not decode: {0}")]
    ImageDecode(String),
    /// The image is larger than the limits (pixels or bytes).
    #[error("the image is too large: {0}")]
    ImageTooLarge(String),
    /// The image has no pixels.
    #[error("the image is empty (0 pixels)")]
    ImageEmpty,
    /// No strokes were found in the drawing.
    #[error("no strokes found in the drawing")]
    NoStrokes,
    /// Strokes were found but no line could be extracted from them.
    #[error("no lines found in the drawing")]
    NoLines,
    /// A map file (PGM image or map_server YAML) that does not parse.
    #[error("malformed map file: {0}")]
    MapFormat(String),
    /// A parameter is out of its domain (non-finite, negative, outside the sketch, ...).
    #[error("invalid {name}: {reason}")]
    InvalidParameter {
        /// The parameter's name.
        name: &'static str,
        /// What is wrong with it.
        reason: String,
    },
}
