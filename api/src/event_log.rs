//! A session's event feed with ids: what `GET /v1/sessions/{id}/events` streams, and what a
//! client that lost its connection resumes from (`Last-Event-ID`).
//!
//! Sits between a backend's session (which publishes each `pose` and `status`) and the
//! router's server-sent events. Every event gets the next id (1, 2, …) and is kept in a
//! ring of the last `capacity` events; a subscriber names the last id it saw and gets the
//! kept events after it, then the live feed, with nothing lost or repeated in between
//! (the id is assigned, kept and broadcast under one lock, and subscribing takes the same
//! lock). An id older than the ring (or from another run of the service) cannot be
//! resumed: the subscriber is told, and starts over from a fresh `status`.

use std::collections::VecDeque;
use std::sync::Mutex;

use tokio::sync::broadcast;

use crate::types::SessionEvent;

/// An event with its id.
#[derive(Debug, Clone, PartialEq)]
pub struct NumberedEvent {
    /// 1 for a session's first event, then one more for each.
    pub id: u64,
    /// The event.
    pub event: SessionEvent,
}

/// What a subscriber gets ([`EventLog::subscribe`]).
#[derive(Debug)]
pub struct EventSubscription {
    /// The kept events after the id asked for, oldest first (empty unless `resumed`).
    pub replay: Vec<NumberedEvent>,
    /// True when the feed continues exactly after the id asked for.
    pub resumed: bool,
    /// The id of the last event published before the subscription (0: none yet).
    pub last_id: u64,
    /// Events published from now on.
    pub live: broadcast::Receiver<NumberedEvent>,
}

impl EventSubscription {
    /// A subscription to a feed that has ended: nothing to replay, a closed channel.
    pub fn ended() -> Self {
        Self {
            replay: Vec::new(),
            resumed: false,
            last_id: 0,
            live: broadcast::channel(1).1,
        }
    }
}

#[derive(Debug)]
struct Ring {
    last_id: u64,
    kept: VecDeque<NumberedEvent>,
}

/// A session's numbered events: the last `capacity` kept, all broadcast.
#[derive(Debug)]
pub struct EventLog {
    ring: Mutex<Ring>,
    capacity: usize,
    tx: broadcast::Sender<NumberedEvent>,
}

impl EventLog {
    /// An empty log keeping the last `capacity` events (also the broadcast's lag bound).
    pub fn new(capacity: usize) -> Self {
        let capacity = capacity.max(1);
        Self {
            ring: Mutex::new(Ring {
                last_id: 0,
                kept: VecDeque::with_capacity(capacity),
            }),
            capacity,
            tx: broadcast::channel(capacity).0,
        }
    }

    /// Publishes `event` under the next id and returns that id. O(1).
    pub fn publish(&self, event: SessionEvent) -> u64 {
        let mut ring = self.ring.lock().unwrap_or_else(|p| p.into_inner());
        ring.last_id += 1;
        let numbered = NumberedEvent {
            id: ring.last_id,
            event,
        };
        if ring.kept.len() == self.capacity {
            ring.kept.pop_front();
        }
        ring.kept.push_back(numbered.clone());
        // No subscriber is not an error.
        let _ = self.tx.send(numbered);
        ring.last_id
    }

    /// Subscribes after `last_seen` (a client's `Last-Event-ID`), or from now on. O(kept).
    pub fn subscribe(&self, last_seen: Option<u64>) -> EventSubscription {
        let ring = self.ring.lock().unwrap_or_else(|p| p.into_inner());
        let live = self.tx.subscribe();
        let oldest_kept = ring.kept.front().map_or(ring.last_id + 1, |e| e.id);
        match last_seen {
            // Everything after `seen` is still kept (or nothing came after it).
            Some(seen) if seen <= ring.last_id && seen + 1 >= oldest_kept => EventSubscription {
                replay: ring.kept.iter().filter(|e| e.id > seen).cloned().collect(),
                resumed: true,
                last_id: ring.last_id,
                live,
            },
            _ => EventSubscription {
                replay: Vec::new(),
                resumed: false,
                last_id: ring.last_id,
                live,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::types::{PoseResponse, SessionEvent};

    fn pose(x: f64) -> SessionEvent {
        SessionEvent::Pose(PoseResponse {
            session_id: "s".into(),
            x,
            y: 0.0,
            theta: 0.0,
            stamp: None,
            sketch: None,
            map_id: "s".into(),
            position_initialized: true,
            localization_score: 1.0,
        })
    }

    #[test]
    fn a_resumed_subscriber_gets_what_it_missed_then_the_live_feed() {
        let log = EventLog::new(4);
        for k in 1..=3 {
            assert_eq!(log.publish(pose(k as f64)), k);
        }
        let mut sub = log.subscribe(Some(1));
        assert!(sub.resumed);
        assert_eq!(sub.last_id, 3);
        let ids: Vec<u64> = sub.replay.iter().map(|e| e.id).collect();
        assert_eq!(ids, [2, 3]);
        log.publish(pose(4.0));
        assert_eq!(sub.live.try_recv().unwrap().id, 4);
        // Up to date: nothing to replay, still resumed.
        let sub = log.subscribe(Some(4));
        assert!(sub.resumed && sub.replay.is_empty());
    }

    #[test]
    fn an_id_older_than_the_ring_or_from_the_future_starts_over() {
        let log = EventLog::new(2);
        for k in 1..=5 {
            log.publish(pose(k as f64));
        }
        // Kept: 4 and 5. After 3 nothing is missing; after 2, event 3 is gone.
        assert!(log.subscribe(Some(3)).resumed);
        let old = log.subscribe(Some(2));
        assert!(!old.resumed && old.replay.is_empty() && old.last_id == 5);
        // An id this log never gave (a restarted service).
        assert!(!log.subscribe(Some(99)).resumed);
        assert!(!log.subscribe(None).resumed);
    }
}
