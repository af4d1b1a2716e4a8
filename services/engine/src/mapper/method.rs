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
    /// The `sketch` method's engine without the drawing: keyframe ICP, correlative loop
    /// closure and a pose graph (the slam_toolbox / Cartographer class of LiDAR SLAM), so
    /// that `sketch` against `graph` measures what the drawing adds.
    Graph,
    /// The paper's method with a hand-drawn map.
    Sketch,
}

impl Method {
    /// Every method, baselines first.
    pub const ALL: [Method; 4] = [Method::Odometry, Method::Icp, Method::Graph, Method::Sketch];

    /// The method's name as used in the API and on the command line.
    pub fn as_str(&self) -> &'static str {
        match self {
            Method::Odometry => "odometry",
            Method::Icp => "icp",
            Method::Graph => "graph",
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
        Method::ALL
            .into_iter()
            .find(|m| m.as_str() == s)
            .ok_or_else(|| EngineError::InvalidParameter {
                name: "method",
                reason: format!(
                    "{s:?} is not one of {}",
                    Method::ALL.map(|m| m.as_str()).join(", ")
                ),
            })
    }
}
