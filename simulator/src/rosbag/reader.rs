//! Reading a rosbag2 MCAP file into a robot's stream ([`super::BagStream`]), and the
//! LiDAR's mount from its `/tf_static`.

use std::collections::HashMap;
use std::path::Path;

use sketchslam_types::{Odometry, Pose2, Scan, ScanHeader, SensorEvent};

use super::{
    BagStream, BagTopics, LASER_SCAN, MAX_TF_HOPS, MCAP_MAGIC, ODOMETRY, TF_MESSAGE, TF_STATIC,
    bag_error, messages,
};
use crate::error::SimError;

/// Reads the scans and odometry of `topics` from the MCAP file at `path`.
pub fn read_bag(path: &Path, topics: &BagTopics) -> Result<BagStream, SimError> {
    let bytes = std::fs::read(path).map_err(|source| SimError::Io {
        file: path.to_path_buf(),
        action: "cannot read",
        source,
    })?;
    if !bytes.starts_with(MCAP_MAGIC) {
        return Err(bag_error(
            path,
            "not an MCAP file (rosbag2's default storage; a .db3 bag converts with `ros2 bag convert`)",
        ));
    }
    let stream = mcap::MessageStream::new(&bytes)
        .map_err(|e| bag_error(path, format!("not an MCAP file: {e}")))?;
    // In the bag's order (receive order), stamped.
    let mut events: Vec<(u64, SensorEvent)> = Vec::new();
    let mut tf: Vec<messages::TransformStamped> = Vec::new();
    let mut laser_frame = None;
    let mut robot_frame = None;
    let mut skipped = 0;
    let mut topics_seen: Vec<String> = Vec::new();
    for message in stream {
        let message = message.map_err(|e| bag_error(path, format!("reading a message: {e}")))?;
        let channel = &message.channel;
        if !topics_seen.contains(&channel.topic) {
            topics_seen.push(channel.topic.clone());
        }
        let wanted = channel.topic == topics.scan
            || channel.topic == topics.odom
            || channel.topic == TF_STATIC;
        if !wanted {
            continue;
        }
        if channel.message_encoding != "cdr" {
            return Err(bag_error(
                path,
                format!(
                    "topic {}: message encoding {:?}, not ROS 2's \"cdr\"",
                    channel.topic, channel.message_encoding
                ),
            ));
        }
        let schema = channel
            .schema
            .as_ref()
            .map(|s| s.name.as_str())
            .unwrap_or("");
        let decode_error = |what: &str, e: cdr::Error| {
            bag_error(
                path,
                format!("topic {}: a {what} does not decode: {e}", channel.topic),
            )
        };
        if channel.topic == topics.scan {
            expect_schema(path, &channel.topic, schema, LASER_SCAN)?;
            let msg: messages::LaserScan =
                cdr::deserialize(&message.data).map_err(|e| decode_error("LaserScan", e))?;
            let Some(stamp_ns) = msg.header.stamp.to_ns() else {
                skipped += 1;
                continue;
            };
            laser_frame.get_or_insert_with(|| msg.header.frame_id.clone());
            let header = ScanHeader {
                sequence: 0,
                stamp_ns,
                angle_min_rad: msg.angle_min,
                angle_increment_rad: msg.angle_increment,
                range_min_m: msg.range_min,
                range_max_m: msg.range_max,
                beam_count: msg.ranges.len() as u32,
            };
            events.push((
                stamp_ns,
                SensorEvent::Scan(Scan {
                    header,
                    ranges_m: msg.ranges,
                }),
            ));
        } else if channel.topic == topics.odom {
            expect_schema(path, &channel.topic, schema, ODOMETRY)?;
            let msg: messages::Odometry =
                cdr::deserialize(&message.data).map_err(|e| decode_error("Odometry", e))?;
            let Some(stamp_ns) = msg.header.stamp.to_ns() else {
                skipped += 1;
                continue;
            };
            robot_frame.get_or_insert_with(|| msg.child_frame_id.clone());
            let p = msg.pose.pose;
            events.push((
                stamp_ns,
                SensorEvent::Odometry(Odometry {
                    sequence: 0,
                    stamp_ns,
                    x_m: p.position.x,
                    y_m: p.position.y,
                    theta_rad: p.orientation.yaw_rad(),
                }),
            ));
        } else {
            expect_schema(path, &channel.topic, schema, TF_MESSAGE)?;
            let msg: messages::TfMessage =
                cdr::deserialize(&message.data).map_err(|e| decode_error("TFMessage", e))?;
            tf.extend(msg.transforms);
        }
    }
    for (topic, what) in [
        (&topics.scan, "--scan-topic"),
        (&topics.odom, "--odom-topic"),
    ] {
        if !topics_seen.contains(topic) {
            return Err(bag_error(
                path,
                format!("no topic {topic} ({what}); the bag has {topics_seen:?}"),
            ));
        }
    }
    // Stamp order, ties kept as recorded; then numbered from 0 per topic.
    events.sort_by_key(|(t, _)| *t);
    let (mut scan_count, mut odom_count) = (0u64, 0u64);
    for (_, event) in &mut events {
        match event {
            SensorEvent::Scan(scan) => {
                scan.header.sequence = scan_count;
                scan_count += 1;
            }
            SensorEvent::Odometry(odom) => {
                odom.sequence = odom_count;
                odom_count += 1;
            }
        }
    }
    let base = topics
        .base_frame
        .clone()
        .or(robot_frame)
        .unwrap_or_else(|| "base_link".into());
    let lidar_mount = laser_frame
        .as_deref()
        .and_then(|laser| mount_from_tf(&tf, &base, laser));
    Ok(BagStream {
        events: events.into_iter().map(|(_, e)| e).collect(),
        scans: scan_count,
        lidar_mount,
        laser_frame,
        skipped,
    })
}

fn expect_schema(path: &Path, topic: &str, schema: &str, wanted: &str) -> Result<(), SimError> {
    if schema == wanted {
        Ok(())
    } else {
        Err(bag_error(
            path,
            format!("topic {topic} carries {schema:?}, not {wanted}"),
        ))
    }
}

/// The pose of `laser` in `base`, composed along the static transforms (planar: x, y and
/// the yaw of each rotation); `None` when no chain joins them.
pub fn mount_from_tf(
    transforms: &[messages::TransformStamped],
    base: &str,
    laser: &str,
) -> Option<Pose2> {
    if base == laser {
        return Some(Pose2::IDENTITY);
    }
    let parent: HashMap<&str, (&str, Pose2)> = transforms
        .iter()
        .map(|t| {
            let tr = &t.transform;
            let pose = Pose2::new(tr.translation.x, tr.translation.y, tr.rotation.yaw_rad());
            (
                t.child_frame_id.as_str(),
                (t.header.frame_id.as_str(), pose),
            )
        })
        .collect();
    // Walk up from the laser: laser_in_base = parent_in_base ⊕ laser_in_parent.
    let mut frame = laser;
    let mut pose = Pose2::IDENTITY;
    for _ in 0..MAX_TF_HOPS {
        let (up, in_up) = parent.get(frame)?;
        pose = in_up.compose(&pose);
        if *up == base {
            return Some(pose);
        }
        frame = up;
    }
    None
}
