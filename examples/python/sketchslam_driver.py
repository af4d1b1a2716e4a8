#!/usr/bin/env python3
"""A robot driver in Python: publishes LiDAR scans and odometry to sketchslam over iceoryx2.

It uses iceoryx2's own Python package (`pip install iceoryx2==0.10.*`, the version the Rust
side links) and opens the robot's three services exactly as the Rust publisher does
(`shared/ipc/src/services.rs`): the same names, payload layout, type names and settings.
A real driver would read its LiDAR and wheel encoders; this example reads a recording, one
JSON object per line, as `sketchslam_types::SensorEvent` serializes:

    {"Odometry": {"sequence": 0, "stamp_ns": 0, "x_m": 0.0, "y_m": 0.0, "theta_rad": 0.0}}
    {"Scan": {"header": {"sequence": 0, "stamp_ns": 50000000, "angle_min_rad": -2.35, ...},
              "ranges_m": [1.2, 1.3, null, ...]}}     (null: no return)

Usage:
    sketchslam_driver.py RECORDING.jsonl --robot r1 [--prefix sketchslam] [--rate 1.0]
    sketchslam_driver.py --print-layout        (the structs' layout, checked by the tests)

The layout, in one place (Rust: `shared/types/src/messages.rs`, `#[repr(C)]`):

  service  PREFIX/ROBOT/scan   payload [f32] (type name "f32", slice), user header ScanHeader
           ScanHeader "sketchslam::ScanHeader", 40 bytes, align 8:
             sequence u64 @0, stamp_ns u64 @8, angle_min_rad f32 @16,
             angle_increment_rad f32 @20, range_min_m f32 @24, range_max_m f32 @28,
             beam_count u32 @32 (4 bytes padding)
  service  PREFIX/ROBOT/odom   payload Odometry "sketchslam::Odometry", 40 bytes, align 8:
             sequence u64 @0, stamp_ns u64 @8, x_m f64 @16, y_m f64 @24, theta_rad f64 @32
  service  PREFIX/ROBOT/events event; notify id 1 after a scan, 2 after an odometry reading
  pub/sub settings: safe overflow off, subscriber buffer 32 (scan) / 128 (odom),
  history 0, max publishers 2, max subscribers 8; iceoryx2's default config with
  global.prefix = "PREFIX_".

Stamps are the publisher's clock in nanoseconds; sequence numbers count from 0 per topic
without gaps (a gap is counted as lost scans by the service).
"""

import argparse
import ctypes
import json
import math
import sys
import time

SCAN_BUFFER = 32
ODOM_BUFFER = 128
MAX_PUBLISHERS = 2
MAX_SUBSCRIBERS = 8
INITIAL_MAX_BEAMS = 2048
EVENT_SCAN = 1
EVENT_ODOM = 2


class ScanHeader(ctypes.Structure):
    """The fixed part of a scan; the ranges follow as the sample's f32 slice."""

    _fields_ = [
        ("sequence", ctypes.c_uint64),
        ("stamp_ns", ctypes.c_uint64),
        ("angle_min_rad", ctypes.c_float),
        ("angle_increment_rad", ctypes.c_float),
        ("range_min_m", ctypes.c_float),
        ("range_max_m", ctypes.c_float),
        ("beam_count", ctypes.c_uint32),
    ]

    @staticmethod
    def type_name() -> str:
        return "sketchslam::ScanHeader"


class Odometry(ctypes.Structure):
    """The robot's dead-reckoned pose."""

    _fields_ = [
        ("sequence", ctypes.c_uint64),
        ("stamp_ns", ctypes.c_uint64),
        ("x_m", ctypes.c_double),
        ("y_m", ctypes.c_double),
        ("theta_rad", ctypes.c_double),
    ]

    @staticmethod
    def type_name() -> str:
        return "sketchslam::Odometry"


def layout() -> dict:
    """Sizes, alignments and field offsets, for the tests to compare with the Rust structs."""
    out = {}
    for t in (ScanHeader, Odometry):
        out[t.type_name()] = {
            "size": ctypes.sizeof(t),
            "align": ctypes.alignment(t),
            "fields": {name: getattr(t, name).offset for name, _ in t._fields_},
        }
    return out


class RobotPublisher:
    """The publishing side of one robot's services."""

    def __init__(self, prefix: str, robot: str):
        import iceoryx2 as iox2

        self.iox2 = iox2
        config = iox2.config.default()
        config.global_cfg.prefix = iox2.FileName.new(f"{prefix}_")
        self.node = (
            iox2.NodeBuilder.new()
            .name(iox2.NodeName.new(f"py-driver-{robot}"))
            .config(config)
            .signal_handling_mode(iox2.SignalHandlingMode.Disabled)
            .create(iox2.ServiceType.Ipc)
        )
        scan = (
            self.node.service_builder(iox2.ServiceName.new(f"{prefix}/{robot}/scan"))
            .publish_subscribe(iox2.Slice[ctypes.c_float])
            .user_header(ScanHeader)
            .enable_safe_overflow(False)
            .subscriber_max_buffer_size(SCAN_BUFFER)
            .history_size(0)
            .max_publishers(MAX_PUBLISHERS)
            .max_subscribers(MAX_SUBSCRIBERS)
            .open_or_create()
        )
        odom = (
            self.node.service_builder(iox2.ServiceName.new(f"{prefix}/{robot}/odom"))
            .publish_subscribe(Odometry)
            .enable_safe_overflow(False)
            .subscriber_max_buffer_size(ODOM_BUFFER)
            .history_size(0)
            .max_publishers(MAX_PUBLISHERS)
            .max_subscribers(MAX_SUBSCRIBERS)
            .open_or_create()
        )
        events = (
            self.node.service_builder(iox2.ServiceName.new(f"{prefix}/{robot}/events"))
            .event()
            .open_or_create()
        )
        self.scan = (
            scan.publisher_builder()
            .initial_max_slice_len(INITIAL_MAX_BEAMS)
            .allocation_strategy(iox2.AllocationStrategy.PowerOfTwo)
            .create()
        )
        self.odom = odom.publisher_builder().create()
        self.notifier = events.notifier_builder().create()

    def publish_scan(self, header: dict, ranges_m: list) -> None:
        n = len(ranges_m)
        sample = self.scan.loan_slice_uninit(n)
        h = sample.user_header().contents
        for name, _ in ScanHeader._fields_:
            setattr(h, name, header[name])
        h.beam_count = n
        payload = sample.payload()
        for i, r in enumerate(ranges_m):
            payload[i] = math.inf if r is None else r
        sample.assume_init().send()
        self.notifier.notify_with_custom_event_id(self.iox2.EventId.new(EVENT_SCAN))

    def publish_odometry(self, odom: dict) -> None:
        value = Odometry(**{name: odom[name] for name, _ in Odometry._fields_})
        self.odom.send_copy(value)
        self.notifier.notify_with_custom_event_id(self.iox2.EventId.new(EVENT_ODOM))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("recording", nargs="?", help="JSON lines of SensorEvent")
    parser.add_argument("--robot", default="r1")
    parser.add_argument("--prefix", default="sketchslam")
    parser.add_argument(
        "--rate", type=float, default=1.0, help="times real time (0: as fast as possible)"
    )
    parser.add_argument("--print-layout", action="store_true")
    args = parser.parse_args()
    if args.print_layout:
        print(json.dumps(layout()))
        return 0
    if not args.recording:
        parser.error("a recording is needed")
    publisher = RobotPublisher(args.prefix, args.robot)
    # A subscriber connects to a new publisher on its next look; give it one.
    time.sleep(0.5)
    first_stamp = None
    started = time.monotonic()
    scans = 0
    with open(args.recording, encoding="utf-8") as f:
        for line in f:
            if not line.strip():
                continue
            event = json.loads(line)
            stamp = (event.get("Scan", {}).get("header") or event.get("Odometry"))["stamp_ns"]
            if args.rate > 0:
                first_stamp = stamp if first_stamp is None else first_stamp
                due = started + (stamp - first_stamp) / 1e9 / args.rate
                time.sleep(max(0.0, due - time.monotonic()))
            if "Scan" in event:
                publisher.publish_scan(event["Scan"]["header"], event["Scan"]["ranges_m"])
                scans += 1
            else:
                publisher.publish_odometry(event["Odometry"])
    print(f"published {scans} scans", file=sys.stderr)
    # Let the subscriber take the last samples before the publisher goes away.
    time.sleep(1.0)
    return 0


if __name__ == "__main__":
    sys.exit(main())
