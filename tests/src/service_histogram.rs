//! A Prometheus histogram read back from the service's `GET /metrics` text: how `evaluate`
//! reports engine time per scan through the processes (the service's
//! `sketchslam_scan_processing_seconds`), where it cannot time the engine itself.
//!
//! The mean is exact (`_sum / _count`); a quantile is interpolated linearly inside its
//! bucket, as Prometheus' `histogram_quantile` does, so it is only as fine as the buckets.

/// The service's time per scan, all sessions together.
pub const SCAN_PROCESSING: &str = "sketchslam_scan_processing_seconds";

/// One histogram's samples.
#[derive(Debug, Clone, PartialEq)]
pub struct ServiceHistogram {
    /// `(le, cumulative count)` of the finite buckets, by increasing `le`.
    pub buckets: Vec<(f64, u64)>,
    /// Observations (the `+Inf` bucket).
    pub count: u64,
    /// Sum of the observations.
    pub sum: f64,
}

impl ServiceHistogram {
    /// The samples of histogram `name` in a Prometheus text exposition; `None` when it is
    /// not there (or has no `_count`).
    pub fn parse(text: &str, name: &str) -> Option<Self> {
        let (mut buckets, mut count, mut sum) = (Vec::new(), None, None);
        let bucket_prefix = format!("{name}_bucket{{le=\"");
        for line in text.lines() {
            let Some((key, value)) = line.rsplit_once(' ') else {
                continue;
            };
            if let Some(le) = key
                .strip_prefix(&bucket_prefix)
                .and_then(|r| r.strip_suffix("\"}"))
            {
                if le != "+Inf" {
                    buckets.push((le.parse().ok()?, value.parse().ok()?));
                }
            } else if key == format!("{name}_count") {
                count = value.parse().ok();
            } else if key == format!("{name}_sum") {
                sum = value.parse().ok();
            }
        }
        buckets.sort_by(|a: &(f64, u64), b| a.0.total_cmp(&b.0));
        Some(Self {
            buckets,
            count: count?,
            sum: sum?,
        })
    }

    /// `_sum / _count`; `None` without observations.
    pub fn mean(&self) -> Option<f64> {
        (self.count > 0).then(|| self.sum / self.count as f64)
    }

    /// The `q`-quantile (`0 < q ≤ 1`): rank `r = q · count`, the first bucket whose
    /// cumulative count reaches `r`, and linear interpolation between its lower bound (the
    /// previous `le`, 0 for the first) and its `le`. Past the last finite bucket it is that
    /// bucket's `le`. `None` without observations.
    pub fn quantile(&self, q: f64) -> Option<f64> {
        if self.count == 0 {
            return None;
        }
        let rank = q * self.count as f64;
        let (mut lower, mut below) = (0.0, 0u64);
        for &(le, cumulative) in &self.buckets {
            if cumulative as f64 >= rank {
                let inside = (cumulative - below) as f64;
                let share = if inside > 0.0 {
                    (rank - below as f64) / inside
                } else {
                    1.0
                };
                return Some(lower + (le - lower) * share);
            }
            (lower, below) = (le, cumulative);
        }
        self.buckets.last().map(|&(le, _)| le)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = "\
# HELP t Time.
# TYPE t histogram
t_bucket{le=\"0.001\"} 10
t_bucket{le=\"0.01\"} 90
t_bucket{le=\"0.1\"} 100
t_bucket{le=\"+Inf\"} 100
t_sum 0.5
t_count 100
other_count 3
";

    #[test]
    fn the_mean_is_sum_over_count() {
        let h = ServiceHistogram::parse(TEXT, "t").unwrap();
        assert_eq!(h.buckets, vec![(0.001, 10), (0.01, 90), (0.1, 100)]);
        assert_eq!(h.mean(), Some(0.005));
        assert!(ServiceHistogram::parse(TEXT, "missing").is_none());
    }

    #[test]
    fn quantiles_interpolate_inside_their_bucket_by_hand() {
        let h = ServiceHistogram::parse(TEXT, "t").unwrap();
        // Median: rank 50, in (0.001, 0.01] holding 80 from 10: 0.001 + 0.009 · 40/80.
        assert!((h.quantile(0.5).unwrap() - 0.0055).abs() < 1e-12);
        // p99: rank 99, in (0.01, 0.1] holding 10 from 90: 0.01 + 0.09 · 9/10.
        assert!((h.quantile(0.99).unwrap() - 0.091).abs() < 1e-12);
        // p5: rank 5 in the first bucket, from 0: 0.001 · 5/10.
        assert!((h.quantile(0.05).unwrap() - 0.0005).abs() < 1e-12);
    }
}
