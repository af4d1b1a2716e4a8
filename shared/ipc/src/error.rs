//! The transport's error type: every way opening, sending or receiving can fail.

use sketchslam_types::names::NameError;
use thiserror::Error;

/// Everything that can fail in the transport.
#[derive(Debug, Error)]
pub enum IpcError {
    /// The prefix or robot id cannot be part of a service name.
    #[error(transparent)]
    Name(#[from] NameError),
    /// iceoryx2 could not create or open something (node, service, port).
    #[error("iceoryx2: cannot {action} {what}: {reason}")]
    Setup {
        /// "create", "open", ...
        action: &'static str,
        /// The node, service or port concerned.
        what: String,
        /// iceoryx2's error, as text.
        reason: String,
    },
    /// A sample could not be loaned or sent.
    #[error("iceoryx2: cannot send on {topic}: {reason}")]
    Send {
        /// The service name.
        topic: String,
        /// iceoryx2's error, as text.
        reason: String,
    },
    /// A sample could not be received.
    #[error("iceoryx2: cannot receive on {topic}: {reason}")]
    Receive {
        /// The service name.
        topic: String,
        /// iceoryx2's error, as text.
        reason: String,
    },
    /// A scan's header disagrees with its ranges.
    #[error("scan {sequence}: header says {beam_count} beams but {ranges} ranges were given")]
    BeamCount {
        /// The scan's sequence number.
        sequence: u64,
        /// `header.beam_count`.
        beam_count: u32,
        /// The number of ranges.
        ranges: usize,
    },
}

pub(crate) fn setup_err(
    action: &'static str,
    what: impl Into<String>,
    e: impl std::fmt::Debug,
) -> IpcError {
    IpcError::Setup {
        action,
        what: what.into(),
        reason: format!("{e:?}"),
    }
}
