//! The sensor simulator: it owns the truth (world, robot motion, sensor and odometry
//! models) and publishes only what a real robot driver would, over iceoryx2.
