//! Writing a robot's stream as a rosbag2 MCAP file, as ROS 2 would record it: for tests,
//! and for turning a simulation into a bag.

use std::path::Path;

use sketchslam_types::{Pose2, SensorEvent};

use super::{BagTopics, LASER_SCAN, ODOMETRY, TF_MESSAGE, TF_STATIC, bag_error, messages};
use crate::error::SimError;

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
