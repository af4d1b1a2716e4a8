//! How a run's processes find each other: the prefix of the service names and of every
//! iceoryx2 resource, and the node every port hangs from.

use crate::error::{IpcError, setup_err};
use iceoryx2::prelude::*;
use sketchslam_types::names::{DEFAULT_PREFIX, ServiceNames, validate_segment};

/// How a run's processes find each other: the prefix of the service names and of every
/// iceoryx2 resource. Processes with different prefixes are fully isolated.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct IpcConfig {
    /// The prefix, e.g. `sketchslam` (1-64 of `[A-Za-z0-9_-]`).
    pub prefix: String,
}

impl Default for IpcConfig {
    fn default() -> Self {
        Self {
            prefix: DEFAULT_PREFIX.to_string(),
        }
    }
}

impl IpcConfig {
    /// A configuration for `prefix`, validated.
    pub fn new(prefix: &str) -> Result<Self, IpcError> {
        validate_segment("prefix", prefix)?;
        Ok(Self {
            prefix: prefix.to_string(),
        })
    }

    /// The service names of `robot_id`.
    pub fn names(&self, robot_id: &str) -> Result<ServiceNames, IpcError> {
        Ok(ServiceNames::new(&self.prefix, robot_id)?)
    }

    /// The iceoryx2 configuration: iceoryx2's built-in defaults (not a config file found
    /// in the working directory, so that two processes started from different directories
    /// still agree) with `global.prefix = "<prefix>_"`.
    pub fn iceoryx_config(&self) -> Result<Config, IpcError> {
        validate_segment("prefix", &self.prefix)?;
        let mut config = Config::default();
        config.global.prefix = FileName::new(format!("{}_", self.prefix).as_bytes())
            .map_err(|e| setup_err("use", format!("prefix {:?}", self.prefix), e))?;
        Ok(config)
    }

    /// A node under this configuration: `SignalHandlingMode::Disabled` (the owning process
    /// handles signals itself, e.g. with tokio; transport fact 3), and the resources of dead
    /// nodes (a killed earlier run) are cleaned before it is returned.
    pub fn create_node(&self, node_name: &str) -> Result<Node<ipc::Service>, IpcError> {
        let config = self.iceoryx_config()?;
        let name = NodeName::new(node_name).map_err(|e| setup_err("name", node_name, e))?;
        let node = NodeBuilder::new()
            .name(&name)
            .config(&config)
            .signal_handling_mode(SignalHandlingMode::Disabled)
            .create::<ipc::Service>()
            .map_err(|e| setup_err("create", format!("node {node_name}"), e))?;
        let cleanup = node.try_cleanup_dead_nodes();
        if cleanup.cleanups > 0 || cleanup.failed_cleanups > 0 {
            tracing::info!(
                cleaned = cleanup.cleanups,
                failed = cleanup.failed_cleanups,
                "cleaned up dead iceoryx2 nodes"
            );
        }
        Ok(node)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prefix_goes_into_the_iceoryx_config() {
        let c = IpcConfig::new("run-42").unwrap();
        let ice = c.iceoryx_config().unwrap();
        assert_eq!(ice.global.prefix.to_string(), "run-42_");
        assert!(IpcConfig::new("a/b").is_err());
    }
}
