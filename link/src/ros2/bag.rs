//! A recorded session as a rosbag2 MCAP (`anguilla export --ros2`,
//! docs/ros2.md): the node's topics, from the recorded state snapshots, as
//! the live node would have published them (the same messages, at the
//! same rates on the recorded clock), for `ros2 bag info`, `ros2 bag play`
//! and any ROS 2 analysis tool.
//!
//! rosbag2's MCAP conventions (its `rosbag2_storage_mcap`): the profile
//! `ros2`; one schema per type in `ros2msg` (the `.msg` text with each
//! type it uses after a line of 80 `=` and `MSG: pkg/Type`: the files in
//! `msgdefs/`, as `rosbags` generates them); channels in `cdr`, each with
//! its `offered_qos_profiles` and `topic_type_hash`; log and publish
//! times in ns since the epoch.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{self, BufWriter};
use std::path::Path;

use anguilla_ipc::StateSnapshot;
use mcap::records::MessageHeader;

use super::{TOPICS, state};

/// Each topic's type's schema (`ros2msg`), in [`TOPICS`]' order.
pub const MSGDEFS: [&str; 6] = [
    include_str!("msgdefs/sensor_msgs__JointState.msg"),
    include_str!("msgdefs/sensor_msgs__Imu.msg"),
    include_str!("msgdefs/sensor_msgs__FluidPressure.msg"),
    include_str!("msgdefs/std_msgs__Float64MultiArray.msg"),
    include_str!("msgdefs/std_msgs__Float64MultiArray.msg"),
    include_str!("msgdefs/diagnostic_msgs__DiagnosticArray.msg"),
];

/// The QoS the live node offers (reliable, volatile, keep last 10), as
/// rosbag2 writes a profile list.
const QOS: &str = "- history: 1\n  depth: 10\n  reliability: 1\n  durability: 2\n  deadline:\n    sec: 9223372036\n    nsec: 854775807\n  lifespan:\n    sec: 9223372036\n    nsec: 854775807\n  liveliness: 1\n  liveliness_lease_duration:\n    sec: 9223372036\n    nsec: 854775807\n  avoid_ros_namespace_conventions: false\n";

/// How the bag is written.
#[derive(Debug, Clone, PartialEq)]
pub struct BagSettings {
    /// The node's namespace (`/` or `/name`): the topics go under it.
    pub namespace: String,
    /// Most messages a second of each topic on the recorded clock (Hz), in
    /// [`TOPICS`]' order.
    pub rates: [f64; 6],
    /// The recording's start in ns since the epoch: a snapshot's time is
    /// this plus its `time_ns`.
    pub start_ns: u64,
}

/// A bag being written.
pub struct Bag {
    w: mcap::Writer<BufWriter<File>>,
    channels: [u16; 6],
    last: [Option<u64>; 6],
    settings: BagSettings,
    /// Messages written per topic.
    pub counts: [u64; 6],
}

fn err(e: mcap::McapError) -> io::Error {
    io::Error::other(e.to_string())
}

impl Bag {
    /// Creates `path` (replaced if it exists).
    pub fn create(path: &Path, settings: BagSettings) -> io::Result<Self> {
        let file = BufWriter::new(File::create(path)?);
        let mut w = mcap::WriteOptions::new()
            .compression(None)
            .profile("ros2")
            .library("anguilla export --ros2")
            .create(file)
            .map_err(err)?;
        let mut channels = [0u16; 6];
        for (i, (name, ty)) in TOPICS.iter().enumerate() {
            let schema = w
                .add_schema(ty.name, "ros2msg", MSGDEFS[i].as_bytes())
                .map_err(err)?;
            let metadata = BTreeMap::from([
                ("offered_qos_profiles".to_string(), QOS.to_string()),
                ("topic_type_hash".to_string(), ty.hash.to_string()),
            ]);
            let topic = super::graph::qualified(&settings.namespace, name);
            channels[i] = w
                .add_channel(schema, &topic, "cdr", &metadata)
                .map_err(err)?;
        }
        Ok(Self {
            w,
            channels,
            last: [None; 6],
            settings,
            counts: [0; 6],
        })
    }

    /// Writes the messages of `s` on every topic that is due.
    pub fn write(&mut self, s: &StateSnapshot) -> io::Result<()> {
        let due: Vec<bool> = (0..6)
            .map(|i| {
                self.last[i].is_none_or(|l| {
                    s.time_ns.saturating_sub(l) as f64 * 1e-9 >= 1.0 / self.settings.rates[i]
                })
            })
            .collect();
        if !due.contains(&true) {
            return Ok(());
        }
        let ns = self.settings.start_ns.saturating_add(s.time_ns);
        for (i, payload) in state::all(s, ns).into_iter().enumerate() {
            if !due[i] {
                continue;
            }
            self.last[i] = Some(s.time_ns);
            self.counts[i] += 1;
            self.w
                .write_to_known_channel(
                    &MessageHeader {
                        channel_id: self.channels[i],
                        sequence: u32::try_from(self.counts[i]).unwrap_or(u32::MAX),
                        log_time: ns,
                        publish_time: ns,
                    },
                    &payload,
                )
                .map_err(err)?;
        }
        Ok(())
    }

    /// Writes the summary and index and closes the file.
    pub fn finish(mut self) -> io::Result<[u64; 6]> {
        self.w.finish().map_err(err)?;
        Ok(self.counts)
    }
}
