//! Evaluation and multi-process test support for sketchslam: the accuracy metrics of
//! docs/architecture.md, the runs `evaluate` performs, and helpers that launch the real
//! binaries.

pub mod dataset_run;
pub mod generated;
pub mod line_offset;
pub mod live_warp;
pub mod loop_audit;
pub mod metrics;
pub mod overlay;
pub mod processes;
pub mod real_process;
pub mod relations;
pub mod replay_floor;
pub mod run;
pub mod run_loop;
pub mod run_method;
pub mod samples;
pub mod service_histogram;
pub mod service_process;
pub mod session_request;
pub mod sketch_truth;
pub mod warp_problem_file;
