//! The session's method: which front end turns scans into poses (see [`super`]).

use crate::EngineError;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// How a session turns scans into a map.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Scans placed at the dead-reckoned pose.
    Odometry,
    /// Frame-to-frame ICP seeded by odometry, no sketch.
    Icp,
    /// The paper's method with a hand-drawn map.
    Sketch,
}

impl Method {
    /// Every method, baselines first.
    pub const ALL: [Method; 3] = [Method::Odometry, Method::Icp, Method::Sketch];

    /// The method's name as used in the API and on the command line.
    pub fn as_str(&self) -> &'static str {
        match self {
            Method::Odometry => "odometry",
            Method::Icp => "icp",
            Method::Sketch => "sketch",
        }
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl FromStr for Method {
    type Err = EngineError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "odometry" => Ok(Method::Odometry),
            "icp" => Ok(Method::Icp),
            "sketch" => Ok(Method::Sketch),
            other => Err(EngineError::InvalidParameter {
                name: "method",
                reason: format!("{other:?} is not one of odometry, icp, sketch"),
            }),
        }
    }
}
