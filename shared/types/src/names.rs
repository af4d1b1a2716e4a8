//! iceoryx2 service names: `PREFIX/ROBOT/scan` and `PREFIX/ROBOT/odom`.
//!
//! The prefix (default `sketchslam`) also names the iceoryx2 global prefix of a run, so that
//! parallel test runs with distinct prefixes share nothing, not even `/dev/shm` segments.

use thiserror::Error;

/// The prefix used when none is given.
pub const DEFAULT_PREFIX: &str = "sketchslam";

/// The two topics a robot publishes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Topic {
    /// LiDAR scans.
    Scan,
    /// Wheel odometry.
    Odom,
}

impl Topic {
    /// The topic's last name segment.
    pub fn as_str(&self) -> &'static str {
        match self {
            Topic::Scan => "scan",
            Topic::Odom => "odom",
        }
    }
}

/// An error echoes at most this many characters of a rejected value.
pub const ECHO_CHARS: usize = 64;

/// A robot id or prefix that cannot be part of a service name.
#[derive(Debug, Error, PartialEq, Eq)]
pub enum NameError {
    /// Empty, too long, or holding characters other than `[A-Za-z0-9_-]`.
    #[error(
        "invalid {what} {value:?}{}: use 1-64 characters of A-Z, a-z, 0-9, '_' or '-'",
        if *.length > ECHO_CHARS { format!(" ({length} characters)") } else { String::new() }
    )]
    Invalid {
        /// Which part was invalid ("robot id" or "prefix").
        what: &'static str,
        /// The rejected value, cut to its first [`ECHO_CHARS`] characters (an error
        /// message echoes it, and a 15 MB id must not come back in a 15 MB answer).
        value: String,
        /// The rejected value's length in characters.
        length: usize,
    },
}

/// Checks that `value` is usable as a robot id or prefix segment.
pub fn validate_segment(what: &'static str, value: &str) -> Result<(), NameError> {
    let ok = !value.is_empty()
        && value.len() <= 64
        && value
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
    if ok {
        Ok(())
    } else {
        Err(NameError::Invalid {
            what,
            value: value.chars().take(ECHO_CHARS).collect(),
            length: value.chars().count(),
        })
    }
}

/// The service names of one robot under one prefix.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ServiceNames {
    /// The run's prefix, e.g. `sketchslam`.
    pub prefix: String,
    /// The robot id.
    pub robot_id: String,
}

impl ServiceNames {
    /// Names for `robot_id` under `prefix`, both validated.
    pub fn new(prefix: &str, robot_id: &str) -> Result<Self, NameError> {
        validate_segment("prefix", prefix)?;
        validate_segment("robot id", robot_id)?;
        Ok(Self {
            prefix: prefix.to_string(),
            robot_id: robot_id.to_string(),
        })
    }

    /// `PREFIX/ROBOT/TOPIC`.
    pub fn service_name(&self, topic: Topic) -> String {
        format!("{}/{}/{}", self.prefix, self.robot_id, topic.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builds_names() {
        let n = ServiceNames::new("sketchslam", "r1").unwrap();
        assert_eq!(n.service_name(Topic::Scan), "sketchslam/r1/scan");
        assert_eq!(n.service_name(Topic::Odom), "sketchslam/r1/odom");
    }

    #[test]
    fn rejects_bad_segments() {
        assert!(ServiceNames::new("p", "a/b").is_err());
        assert!(ServiceNames::new("", "r").is_err());
        assert!(ServiceNames::new("p", &"x".repeat(65)).is_err());
    }

    #[test]
    fn an_error_echoes_a_long_value_cut_with_its_length() {
        let e = validate_segment("robot id", &"x".repeat(15_000_000)).unwrap_err();
        let text = e.to_string();
        assert!(text.len() < 200, "{} bytes", text.len());
        assert!(text.contains(&format!("\"{}\" (15000000 characters)", "x".repeat(64))));
        // A short one comes back whole, without a length.
        let e = validate_segment("robot id", "a/b").unwrap_err();
        assert_eq!(
            e.to_string(),
            "invalid robot id \"a/b\": use 1-64 characters of A-Z, a-z, 0-9, '_' or '-'"
        );
    }
}
