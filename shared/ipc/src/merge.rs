//! The pure half of the subscriber: a robot's two topics merged into one stream in stamp
//! order. No iceoryx2 inside, so it is tested on hand-made sequences.

use sketchslam_types::{Odometry, Scan, SensorEvent};
use std::collections::VecDeque;

#[derive(Debug)]
struct Held<T> {
    item: T,
    stamp_ns: u64,
    /// Proven that nothing of the other topic with a smaller stamp is still in flight.
    safe: bool,
}

/// Merges a robot's two topics into one stream in stamp order (odometry before a scan with
/// the same stamp), without knowing the publisher's timing. Pure: no iceoryx2 inside.
///
/// The publisher sends both topics through one thread in stamp order, and each topic is a
/// FIFO. So after draining one topic's queue completely, every sample of the *other* topic
/// held before that drain is known to have no predecessor still in flight:
/// - held odometry becomes safe after a later scan drain (and whenever its stamp is at or
///   below the newest scan received);
/// - held scans become safe after a later odometry drain (and whenever their stamp is below
///   the newest odometry received).
///
/// The head of the merged stream is released only when it is safe. A receiver alternates
/// odometry drain, scan drain, odometry drain, so everything received is released by the
/// end of one pull.
#[derive(Debug, Default)]
pub struct StampMerge {
    odometry: VecDeque<Held<Odometry>>,
    scans: VecDeque<Held<Scan>>,
    newest_scan_ns: Option<u64>,
    newest_odometry_ns: Option<u64>,
    last_released_ns: Option<u64>,
    out_of_order: u64,
}

impl StampMerge {
    /// An empty merge.
    pub fn new() -> Self {
        Self::default()
    }

    /// Holds a received odometry reading.
    pub fn push_odometry(&mut self, odometry: Odometry) {
        self.newest_odometry_ns = Some(
            self.newest_odometry_ns
                .map_or(odometry.stamp_ns, |n| n.max(odometry.stamp_ns)),
        );
        self.odometry.push_back(Held {
            stamp_ns: odometry.stamp_ns,
            item: odometry,
            safe: false,
        });
    }

    /// Holds a received scan.
    pub fn push_scan(&mut self, scan: Scan) {
        let stamp_ns = scan.header.stamp_ns;
        self.newest_scan_ns = Some(self.newest_scan_ns.map_or(stamp_ns, |n| n.max(stamp_ns)));
        self.scans.push_back(Held {
            item: scan,
            stamp_ns,
            safe: false,
        });
    }

    /// The odometry queue was drained empty: every scan held now is safe.
    pub fn odometry_drained(&mut self) {
        self.scans.iter_mut().for_each(|h| h.safe = true);
    }

    /// The scan queue was drained empty: every odometry reading held now is safe.
    pub fn scans_drained(&mut self) {
        self.odometry.iter_mut().for_each(|h| h.safe = true);
    }

    /// Events held, released or not.
    pub fn len(&self) -> usize {
        self.odometry.len() + self.scans.len()
    }

    /// True when nothing is held.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Events released out of stamp order so far (possible only when samples were lost).
    pub fn out_of_order(&self) -> u64 {
        self.out_of_order
    }

    /// The next event in stamp order, if it is known that nothing earlier is in flight.
    pub fn pop(&mut self) -> Option<SensorEvent> {
        let odom_first = match (self.odometry.front(), self.scans.front()) {
            (None, None) => return None,
            (Some(_), None) => true,
            (None, Some(_)) => false,
            (Some(o), Some(s)) => o.stamp_ns <= s.stamp_ns,
        };
        let event = if odom_first {
            let head = self.odometry.front()?;
            let safe = head.safe || self.newest_scan_ns.is_some_and(|n| head.stamp_ns <= n);
            if !safe {
                return None;
            }
            SensorEvent::Odometry(self.odometry.pop_front()?.item)
        } else {
            let head = self.scans.front()?;
            let safe = head.safe || self.newest_odometry_ns.is_some_and(|n| head.stamp_ns < n);
            if !safe {
                return None;
            }
            SensorEvent::Scan(self.scans.pop_front()?.item)
        };
        let stamp = event.stamp_ns();
        if self.last_released_ns.is_some_and(|last| stamp < last) {
            self.out_of_order += 1;
        }
        self.last_released_ns = Some(self.last_released_ns.map_or(stamp, |l| l.max(stamp)));
        Some(event)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sketchslam_types::ScanHeader;

    fn odom(seq: u64, t: u64) -> Odometry {
        Odometry {
            sequence: seq,
            stamp_ns: t,
            ..Default::default()
        }
    }

    fn scan(seq: u64, t: u64) -> Scan {
        Scan {
            header: ScanHeader {
                sequence: seq,
                stamp_ns: t,
                ..Default::default()
            },
            ranges_m: vec![],
        }
    }

    fn drain(m: &mut StampMerge) -> Vec<(char, u64)> {
        std::iter::from_fn(|| m.pop())
            .map(|e| match e {
                SensorEvent::Odometry(o) => ('o', o.stamp_ns),
                SensorEvent::Scan(s) => ('s', s.header.stamp_ns),
            })
            .collect()
    }

    #[test]
    fn merge_orders_by_stamp_with_odometry_first_on_ties() {
        let mut m = StampMerge::new();
        // Pull: odometry drain, scan drain, odometry drain.
        m.push_odometry(odom(0, 0));
        m.push_odometry(odom(1, 20));
        m.push_odometry(odom(2, 40));
        m.odometry_drained();
        m.push_scan(scan(0, 0));
        m.push_scan(scan(1, 50));
        m.scans_drained();
        m.push_odometry(odom(3, 60));
        m.odometry_drained();
        assert_eq!(
            drain(&mut m),
            vec![('o', 0), ('s', 0), ('o', 20), ('o', 40), ('s', 50)]
        );
        // Odometry at 60 waits: a scan at 55 may still be in flight until the next scan drain.
        assert_eq!(m.len(), 1);
        m.scans_drained();
        assert_eq!(drain(&mut m), vec![('o', 60)]);
        assert_eq!(m.out_of_order(), 0);
    }

    #[test]
    fn merge_holds_odometry_until_no_earlier_scan_can_arrive() {
        let mut m = StampMerge::new();
        m.push_scan(scan(0, 10));
        m.odometry_drained(); // scan 10 safe
        // Odometry at 30 arrived, but a scan at 25 may still be in flight.
        m.push_odometry(odom(0, 30));
        assert_eq!(drain(&mut m), vec![('s', 10)]);
        assert_eq!(m.len(), 1);
        // The scan at 25 was sent before the odometry at 30.
        m.push_scan(scan(1, 25));
        m.scans_drained();
        m.odometry_drained();
        assert_eq!(drain(&mut m), vec![('s', 25), ('o', 30)]);
        assert!(m.is_empty());
    }

    #[test]
    fn merge_holds_a_scan_until_its_odometry_is_drained() {
        let mut m = StampMerge::new();
        m.push_scan(scan(0, 100));
        m.scans_drained();
        // No odometry drain yet: odometry at <= 100 might be queued.
        assert_eq!(m.pop(), None);
        m.push_odometry(odom(0, 90));
        m.push_odometry(odom(1, 100));
        m.odometry_drained();
        assert_eq!(drain(&mut m), vec![('o', 90), ('o', 100), ('s', 100)]);
    }
}
