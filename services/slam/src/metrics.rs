//! The service's Prometheus metrics: the scan processing time histogram, and the `/metrics`
//! text rendered from it and the sessions' status (the per-session counters are read from
//! the sessions when `/metrics` is asked for; the registry collects them).
//!
//! Written by hand rather than with a metrics crate: the text exposition format for a few
//! counters and one histogram is a screenful of code, and the per-session series come and
//! go with sessions, which a registry-of-handles crate makes awkward.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use sketchslam_api::router::escape_label;
use sketchslam_api::{SessionInfo, SessionState};

use crate::process_stats::ProcessStats;

/// Upper bounds of the processing time buckets, seconds.
pub const BUCKETS_S: [f64; 11] = [
    0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 2.5,
];

/// A Prometheus histogram of durations (lock-free; updated by every mapper thread).
#[derive(Debug, Default)]
pub struct Histogram {
    buckets: [AtomicU64; BUCKETS_S.len()],
    count: AtomicU64,
    sum_ns: AtomicU64,
}

impl Histogram {
    /// Records one observation.
    pub fn observe(&self, d: Duration) {
        let s = d.as_secs_f64();
        for (bound, bucket) in BUCKETS_S.iter().zip(&self.buckets) {
            if s <= *bound {
                bucket.fetch_add(1, Ordering::Relaxed);
            }
        }
        self.count.fetch_add(1, Ordering::Relaxed);
        self.sum_ns
            .fetch_add(d.as_nanos().min(u64::MAX as u128) as u64, Ordering::Relaxed);
    }

    /// Observations so far.
    pub fn count(&self) -> u64 {
        self.count.load(Ordering::Relaxed)
    }

    /// The histogram's samples in text format (after its `# TYPE` line).
    pub fn render(&self, name: &str, out: &mut String) {
        for (bound, bucket) in BUCKETS_S.iter().zip(&self.buckets) {
            out.push_str(&format!(
                "{name}_bucket{{le=\"{bound}\"}} {}\n",
                bucket.load(Ordering::Relaxed)
            ));
        }
        let count = self.count();
        out.push_str(&format!("{name}_bucket{{le=\"+Inf\"}} {count}\n"));
        out.push_str(&format!(
            "{name}_sum {}\n",
            self.sum_ns.load(Ordering::Relaxed) as f64 * 1e-9
        ));
        out.push_str(&format!("{name}_count {count}\n"));
    }
}

/// What `/metrics` reports of one running session.
#[derive(Debug, Clone)]
pub struct RunningSession {
    /// Its status.
    pub info: SessionInfo,
    /// Odometry readings lost.
    pub odometry_lost: u64,
    /// Heap held by its mapper's growing parts ([`sketchslam_engine::mapper::Mapper::heap_bytes`]).
    pub heap_bytes: u64,
}

/// The `/metrics` text (Prometheus exposition format): one series per running session and
/// family (`running`),
/// sessions by state (`states`: every session the service holds), stored sketches, the
/// scan processing histogram and the process's own use. Labels are escaped; their values
/// come from session ids, robot ids and method names only, and a stopped session's series
/// go with it, so the series are bounded by the sessions running at once.
pub fn render_metrics(
    running: &[RunningSession],
    states: &[SessionState],
    sketches: usize,
    histogram: &Histogram,
    process: &ProcessStats,
) -> String {
    let mut out = String::new();
    let labels = |i: &SessionInfo| {
        format!(
            "session=\"{}\",robot=\"{}\",method=\"{}\"",
            escape_label(&i.id),
            escape_label(&i.robot_id),
            i.method.as_str()
        )
    };
    let mut family =
        |name: &str, kind: &str, help: &str, value: &dyn Fn(&RunningSession) -> String| {
            out.push_str(&format!("# HELP {name} {help}\n# TYPE {name} {kind}\n"));
            for r in running {
                out.push_str(&format!("{name}{{{}}} {}\n", labels(&r.info), value(r)));
            }
        };
    family(
        "sketchslam_scans_processed_total",
        "counter",
        "Scans fused into the session's map.",
        &|r| r.info.scans_processed.to_string(),
    );
    family(
        "sketchslam_scans_lost_total",
        "counter",
        "Scans missing from the robot's stream (sequence gaps).",
        &|r| r.info.scans_lost.to_string(),
    );
    family(
        "sketchslam_odometry_lost_total",
        "counter",
        "Odometry readings missing from the robot's stream (running sessions).",
        &|r| r.odometry_lost.to_string(),
    );
    family(
        "sketchslam_recoveries_total",
        "counter",
        "Recoveries of localization on the sketch.",
        &|r| r.info.recoveries.to_string(),
    );
    family(
        "sketchslam_loop_closures_total",
        "counter",
        "Loops closed by the back end (graph and sketch methods).",
        &|r| r.info.loop_closures.to_string(),
    );
    family(
        "sketchslam_loop_closures_rejected_total",
        "counter",
        "Matched loops the back end refused (inconsistent with the odometry chain or the other loops).",
        &|r| r.info.loop_closures_rejected.to_string(),
    );
    family(
        "sketchslam_localization_score",
        "gauge",
        "Localization score in [0, 1].",
        &|r| r.info.localization_score.to_string(),
    );
    family(
        "sketchslam_session_heap_bytes",
        "gauge",
        "Heap held by what grows with the session: its scan log, trajectory, grid and keyframes (an estimate from capacities).",
        &|r| r.heap_bytes.to_string(),
    );
    out.push_str(
        "# HELP sketchslam_sessions Sessions by state.\n# TYPE sketchslam_sessions gauge\n",
    );
    for (state, name) in [
        (SessionState::WaitingForData, "waiting_for_data"),
        (SessionState::Mapping, "mapping"),
        (SessionState::Stopped, "stopped"),
        (SessionState::Failed, "failed"),
        (SessionState::Interrupted, "interrupted"),
    ] {
        let n = states.iter().filter(|s| **s == state).count();
        out.push_str(&format!("sketchslam_sessions{{state=\"{name}\"}} {n}\n"));
    }
    out.push_str(&format!(
        "# HELP sketchslam_sketches Stored sketches.\n# TYPE sketchslam_sketches gauge\nsketchslam_sketches {sketches}\n"
    ));
    out.push_str(
        "# HELP sketchslam_scan_processing_seconds Time to process one scan (all sessions).\n\
         # TYPE sketchslam_scan_processing_seconds histogram\n",
    );
    histogram.render("sketchslam_scan_processing_seconds", &mut out);
    process.render(&mut out);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn buckets_are_cumulative() {
        let h = Histogram::default();
        h.observe(Duration::from_micros(500));
        h.observe(Duration::from_millis(30));
        h.observe(Duration::from_secs(10));
        let mut out = String::new();
        h.render("x", &mut out);
        assert!(out.contains("x_bucket{le=\"0.001\"} 1\n"), "{out}");
        assert!(out.contains("x_bucket{le=\"0.05\"} 2\n"), "{out}");
        assert!(out.contains("x_bucket{le=\"2.5\"} 2\n"), "{out}");
        assert!(out.contains("x_bucket{le=\"+Inf\"} 3\n"), "{out}");
        assert!(out.contains("x_count 3\n"), "{out}");
    }
}
