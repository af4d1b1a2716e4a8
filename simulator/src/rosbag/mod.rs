//! ROS 2 bags as a robot's stream: `simulator replay BAG.mcap` publishes a rosbag2 MCAP
//! recording (`sensor_msgs/msg/LaserScan` and `nav_msgs/msg/Odometry`, CDR-encoded as ROS 2
//! writes them) like a simulation, stamps from the messages' headers. No ROS installation:
//! the `mcap` crate reads the container (chunks compressed with zstd or lz4 too) and `cdr`
//! the messages ([`messages`]).
//!
//! The LiDAR's mounting pose comes from `/tf_static` when the bag has it: the chain of
//! transforms from the robot's frame (`--base-frame`, else the odometry's
//! `child_frame_id`, else `base_link`) to the scans' `frame_id`, flattened to x, y, yaw.
//! The scan stream has no field for it, so [`BagStream::lidar_mount`] is for the session
//! request (`lidar_mount`), which the replay prints.
//!
//! [`write_bag`] is the other way, for tests and for turning a simulation into a bag.

pub mod messages;

use std::collections::HashMap;
use std::path::Path;

use sketchslam_types::{Odometry, Pose2, Scan, ScanHeader, SensorEvent};

use crate::error::SimError;

/// Where a bag keeps what the service needs.
#[derive(Debug, Clone, PartialEq)]
pub struct BagTopics {
    /// The `LaserScan` topic.
    pub scan: String,
    /// The `Odometry` topic.
    pub odom: String,
    /// The robot's frame; `None`: the odometry's `child_frame_id`, else `base_link`.
    pub base_frame: Option<String>,
}

impl Default for BagTopics {
    fn default() -> Self {
        BagTopics {
            scan: "/scan".into(),
            odom: "/odom".into(),
            base_frame: None,
        }
    }
}

/// The robot's stream read from a bag.
#[derive(Debug, Clone, PartialEq)]
pub struct BagStream {
    /// Scans and odometry in stamp order, numbered from 0 per topic.
    pub events: Vec<SensorEvent>,
    /// Scans among them.
    pub scans: u64,
    /// The LiDAR's pose on the robot from `/tf_static`, when the bag has the chain.
    pub lidar_mount: Option<Pose2>,
    /// The scans' `frame_id`.
    pub laser_frame: Option<String>,
    /// Messages on the two topics that could not be used (a stamp before the epoch).
    pub skipped: usize,
}

/// The first bytes of every MCAP file.
const MCAP_MAGIC: &[u8] = b"\x89MCAP0\r\n";
const LASER_SCAN: &str = "sensor_msgs/msg/LaserScan";
const ODOMETRY: &str = "nav_msgs/msg/Odometry";
const TF_MESSAGE: &str = "tf2_msgs/msg/TFMessage";
const TF_STATIC: &str = "/tf_static";
/// Frames followed from the laser up to the robot before giving up (a cycle).
const MAX_TF_HOPS: usize = 32;

fn bag_error(file: &Path, message: impl Into<String>) -> SimError {
    SimError::Bag {
        file: file.to_path_buf(),
        message: message.into(),
    }
}

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

/// Writes `events` as a rosbag2 MCAP file at `path`: scans on `topics.scan` in frame
/// `laser_frame`, odometry on `topics.odom` (`odom` → base frame), and, when `mount` is
/// given, the base → laser transform on `/tf_static`. Stamps are the events' own.
pub fn write_bag(
    path: &Path,
    events: &[SensorEvent],
    topics: &BagTopics,
    laser_frame: &str,
    mount: Option<Pose2>,
) -> Result<(), SimError> {
    let io_error = |source: std::io::Error| SimError::Io {
        file: path.to_path_buf(),
        action: "cannot write",
        source,
    };
    let mcap_error = |e: mcap::McapError| bag_error(path, format!("writing: {e}"));
    let cdr_error = |e: cdr::Error| bag_error(path, format!("encoding: {e}"));
    let file = std::io::BufWriter::new(std::fs::File::create(path).map_err(io_error)?);
    let mut writer = mcap::Writer::new(file).map_err(mcap_error)?;
    let base = topics
        .base_frame
        .clone()
        .unwrap_or_else(|| "base_link".into());
    let mut channel = |topic: &str, schema: &str| -> Result<u16, SimError> {
        let schema_id = writer
            .add_schema(schema, "ros2msg", b"")
            .map_err(mcap_error)?;
        writer
            .add_channel(schema_id, topic, "cdr", &Default::default())
            .map_err(mcap_error)
    };
    let scan_channel = channel(&topics.scan, LASER_SCAN)?;
    let odom_channel = channel(&topics.odom, ODOMETRY)?;
    let tf_channel = channel(TF_STATIC, TF_MESSAGE)?;
    let mut sequence = 0u32;
    let mut write = |writer: &mut mcap::Writer<_>, channel_id: u16, t_ns: u64, data: &[u8]| {
        let header = mcap::records::MessageHeader {
            channel_id,
            sequence,
            log_time: t_ns,
            publish_time: t_ns,
        };
        sequence += 1;
        writer
            .write_to_known_channel(&header, data)
            .map_err(mcap_error)
    };
    if let Some(m) = mount {
        let first_ns = events.first().map_or(0, SensorEvent::stamp_ns);
        let tf = messages::TfMessage {
            transforms: vec![messages::TransformStamped {
                header: messages::Header {
                    stamp: messages::Time::from_ns(first_ns),
                    frame_id: base.clone(),
                },
                child_frame_id: laser_frame.into(),
                transform: messages::Transform {
                    translation: messages::Vector3 {
                        x: m.x,
                        y: m.y,
                        z: 0.0,
                    },
                    rotation: messages::Quaternion::from_yaw(m.heading_rad),
                },
            }],
        };
        let data = cdr::serialize::<_, _, cdr::CdrLe>(&tf, cdr::Infinite).map_err(cdr_error)?;
        write(&mut writer, tf_channel, first_ns, &data)?;
    }
    for event in events {
        let stamp = messages::Time::from_ns(event.stamp_ns());
        let (channel_id, data) = match event {
            SensorEvent::Scan(scan) => {
                let h = &scan.header;
                let n = scan.ranges_m.len();
                let msg = messages::LaserScan {
                    header: messages::Header {
                        stamp,
                        frame_id: laser_frame.into(),
                    },
                    angle_min: h.angle_min_rad,
                    angle_max: h.angle_min_rad + h.angle_increment_rad * n.saturating_sub(1) as f32,
                    angle_increment: h.angle_increment_rad,
                    time_increment: 0.0,
                    scan_time: 0.0,
                    range_min: h.range_min_m,
                    range_max: h.range_max_m,
                    ranges: scan.ranges_m.clone(),
                    intensities: Vec::new(),
                };
                let data =
                    cdr::serialize::<_, _, cdr::CdrLe>(&msg, cdr::Infinite).map_err(cdr_error)?;
                (scan_channel, data)
            }
            SensorEvent::Odometry(o) => {
                let msg = messages::Odometry {
                    header: messages::Header {
                        stamp,
                        frame_id: "odom".into(),
                    },
                    child_frame_id: base.clone(),
                    pose: messages::PoseWithCovariance {
                        pose: messages::Pose {
                            position: messages::Vector3 {
                                x: o.x_m,
                                y: o.y_m,
                                z: 0.0,
                            },
                            orientation: messages::Quaternion::from_yaw(o.theta_rad),
                        },
                        covariance: [[0.0; 6]; 6],
                    },
                    twist: Default::default(),
                };
                let data =
                    cdr::serialize::<_, _, cdr::CdrLe>(&msg, cdr::Infinite).map_err(cdr_error)?;
                (odom_channel, data)
            }
        };
        write(&mut writer, channel_id, event.stamp_ns(), &data)?;
    }
    writer.finish().map_err(mcap_error)?;
    Ok(())
}
