#!/usr/bin/env python3
"""Checks `anguilla export --ros2 SESSION` with other implementations:
`rosbags`' rosbag2 reader (PyPI) opens the MCAP, every connection has its
ROS 2 type, `cdr`, the schema `rosbags` generates from Jazzy's definitions
and the live node's QoS, and every message deserialises. The counts and values must be the
session's: state.bin (read here with the ctypes twins of docs/ipc.md) is
thinned at each topic's rate on the recorded clock, as the export says it
does, and each joint state must hold its snapshot's measured joints, each
stamped with the recording's start plus the snapshot's time. The bag's
rosbag2 metadata (the MCAP metadata record `rosbag2`, `serialized_metadata`,
as rosbag2's MCAP plugin writes it) is read as rosbag2 reads it: version 9,
each topic's QoS profiles by name (Jazzy's form), counts and times the
bag's own; with --humble, Humble's form instead (integers, `ROS_DISTRO`).

    ros2_bag_check.py SESSION_DIR BAG.mcap [--rate HZ] [--rates TOPIC=HZ ...]

Exit 0 when all holds, 1 otherwise.
"""

import argparse
import ctypes
import math
import os
import struct
import sys
import xml.etree.ElementTree as ET

from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore

from anguilla_client import StateSnapshot

TOPICS = ["joint_states", "imu", "pressure", "feedforward", "torque_residual", "diagnostics", "tf",
          "cross_track_error", "current"]
LATCHED = ["robot_description", "tf_static"]


def fail(why):
    print(f"ros2 bag check: FAILED: {why}")
    sys.exit(1)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("session")
    ap.add_argument("bag")
    ap.add_argument("--rate", type=float, default=20.0)
    ap.add_argument("--rates", nargs="*", default=["diagnostics=1.0"])
    ap.add_argument("--namespace", default="")
    ap.add_argument("--humble", action="store_true",
                    help="the session's [link] ros2-distro is humble")
    a = ap.parse_args(argv)
    check_rosbag2_metadata(a.bag, a.humble)
    rates = {t: a.rate for t in TOPICS}
    rates.update({k: float(v) for k, v in (r.split("=") for r in a.rates)})
    ts = get_typestore(Stores.ROS2_JAZZY)
    start_ns = int(os.path.basename(a.session.rstrip("/")).split("-")[1]) * 10**9

    raw = open(os.path.join(a.session, "state.bin"), "rb").read()
    size = ctypes.sizeof(StateSnapshot)
    states = [StateSnapshot.from_buffer_copy(raw, i * size) for i in range(len(raw) // size)]
    expected = {t: [] for t in TOPICS}
    last = {t: None for t in TOPICS}
    for s in states:
        for t in TOPICS:
            if last[t] is None or (s.time_ns - last[t]) * 1e-9 >= 1.0 / rates[t]:
                last[t] = s.time_ns
                expected[t].append(s)

    got = {t: 0 for t in TOPICS}
    with Reader(a.bag) as r:
        conns = {c.topic: c for c in r.connections}
        for t in TOPICS:
            c = conns.get(f"{a.namespace}/{t}")
            if c is None:
                fail(f"no connection {a.namespace}/{t} among {sorted(conns)}")
            if c.ext.serialization_format != "cdr":
                fail(f"{t}: serialization {c.ext.serialization_format}")
            want, _ = ts.generate_msgdef(c.msgtype, ros_version=2)
            if c.msgdef.data != want:
                fail(f"{t}: the schema of {c.msgtype} is not what rosbags generates from Jazzy's "
                     f"definitions (link/src/ros2/msgdefs/)")
            q = c.ext.offered_qos_profiles
            if len(q) != 1 or q[0].depth != 10 or q[0].reliability.name != "RELIABLE":
                fail(f"{t}: offered QoS {q}, expected reliable, keep last 10")
        for t in LATCHED:
            c = conns.get(f"{a.namespace}/{t}")
            if c is None or c.ext.offered_qos_profiles[0].durability.name != "TRANSIENT_LOCAL":
                fail(f"{t}: missing, or not transient local")
        latched = {}
        for c, t_ns, data in r.messages():
            name = c.topic.rsplit("/", 1)[1]
            m = ts.deserialize_cdr(data, c.msgtype)
            if name in LATCHED:
                latched.setdefault(name, []).append((t_ns, m))
                continue
            i = got[name]
            got[name] += 1
            if i >= len(expected[name]):
                continue
            s = expected[name][i]
            stamp = start_ns + s.time_ns
            if t_ns != stamp:
                fail(f"{name} #{i}: log time {t_ns}, expected {stamp}")
            if hasattr(m, "header") and m.header.stamp.sec * 10**9 + m.header.stamp.nanosec != stamp:
                fail(f"{name} #{i}: header stamp is not the snapshot's")
            f32 = lambda x: struct.unpack("<f", struct.pack("<f", x))[0]  # noqa: E731
            if name == "cross_track_error":
                want = f32(s.guide.cross_track_m) if s.guide.state == 1 else None
                if (want is None and not math.isnan(m.data)) or \
                        (want is not None and m.data != want):
                    fail(f"cross_track_error #{i}: {m.data}, snapshot {i}'s is {want} "
                         f"(NaN when no path is followed)")
            if name == "current" and [m.vector.x, m.vector.y] != [f32(s.nav.current_x),
                                                                  f32(s.nav.current_y)]:
                fail(f"current #{i}: not snapshot {i}'s estimated current")
            if name == "joint_states":
                want = [f32(getattr(j, f)) for j in s.joints[:s.joint_count]
                        for f in ("measured_pitch", "measured_yaw")]
                if list(m.position) != want:
                    fail(f"joint_states #{i}: positions are not snapshot {i}'s")
    for t in LATCHED:
        msgs = latched.get(t, [])
        if len(msgs) != 1 or msgs[0][0] != start_ns + states[0].time_ns:
            fail(f"{t}: {len(msgs)} messages, expected one at the first snapshot's time")
    urdf = ET.fromstring(latched["robot_description"][0][1].data)
    joints = [j.get("name") for j in urdf.iter("joint") if j.get("type") == "revolute"]
    if len(joints) != 2 * states[0].joint_count:
        fail(f"robot_description has {len(joints)} revolute joints for {states[0].joint_count} joints")
    for t in TOPICS:
        if got[t] != len(expected[t]):
            fail(f"{t}: {got[t]} messages, the session's {len(states)} snapshots at {rates[t]} Hz "
                 f"give {len(expected[t])}")
    print(f"ros2 bag check: OK ({len(states)} snapshots; "
          + ", ".join(f"{t} {got[t]}" for t in TOPICS) + "; robot_description and tf_static once"
          + "; every message deserialised by rosbags' rosbag2 reader, joint states = snapshots)")


# rosbag2's names of the policies (rmw_qos_*_policy_to_str) and their
# integers (rmw_qos_*_policy_e), which Humble writes and reads.
POLICIES = {
    "history": {"system_default": 0, "keep_last": 1, "keep_all": 2},
    "reliability": {"system_default": 0, "reliable": 1, "best_effort": 2},
    "durability": {"system_default": 0, "transient_local": 1, "volatile": 2},
    "liveliness": {"system_default": 0, "automatic": 1},
}


def check_rosbag2_metadata(bag, humble):
    """The MCAP's `rosbag2` metadata record and the channels' QoS, as
    rosbag2's MCAP plugin (rosbag2_storage_mcap, read_metadata) reads them."""
    from mcap.reader import make_reader
    from rosbags.rosbag2.metadata import parse_qos
    from ruamel.yaml import YAML

    with open(bag, "rb") as f:
        r = make_reader(f)
        summary = r.get_summary()
        records = [m for m in r.iter_metadata() if m.name == "rosbag2"]
    if len(records) != 1:
        fail(f"{len(records)} metadata records named rosbag2, expected 1")
    rec = records[0].metadata
    for c in summary.channels.values():
        q = YAML(typ="safe").load(c.metadata["offered_qos_profiles"])
        for k, names in POLICIES.items():
            v = q[0][k]
            if humble and not isinstance(v, int) or not humble and v not in names:
                fail(f"{c.topic}: QoS {k} {v!r} is not in {'Humble' if humble else 'Jazzy'}'s form")
        p = parse_qos(c.metadata["offered_qos_profiles"])[0]
        latched = c.topic.rsplit("/", 1)[1] in LATCHED
        if p.durability.name != ("TRANSIENT_LOCAL" if latched else "VOLATILE"):
            fail(f"{c.topic}: durability {p.durability.name}")
    if humble:
        if rec != {"ROS_DISTRO": "humble"}:
            fail(f"rosbag2 record {rec}, expected Humble's ROS_DISTRO alone")
        return
    meta = YAML(typ="safe").load(rec["serialized_metadata"])
    stats = summary.statistics
    want = {
        "version": 9,
        "storage_identifier": "mcap",
        "message_count": stats.message_count,
        "duration": {"nanoseconds": stats.message_end_time - stats.message_start_time},
        "starting_time": {"nanoseconds_since_epoch": stats.message_start_time},
        "relative_file_paths": [os.path.basename(bag)],
        "ros_distro": "jazzy",
    }
    for k, v in want.items():
        if meta.get(k) != v:
            fail(f"rosbag2 metadata {k}: {meta.get(k)!r}, expected {v!r}")
    by_topic = {c.topic: (c, stats.channel_message_counts.get(i, 0))
                for i, c in summary.channels.items()}
    for t in meta["topics_with_message_count"]:
        tm = t["topic_metadata"]
        c, n = by_topic[tm["name"]]
        if t["message_count"] != n:
            fail(f"rosbag2 metadata {tm['name']}: {t['message_count']} messages, the bag has {n}")
        if tm["offered_qos_profiles"] != YAML(typ="safe").load(c.metadata["offered_qos_profiles"]):
            fail(f"rosbag2 metadata {tm['name']}: QoS differs from its channel's")
        if tm["type_description_hash"] != c.metadata["topic_type_hash"]:
            fail(f"rosbag2 metadata {tm['name']}: type hash differs from its channel's")
    if len(meta["topics_with_message_count"]) != len(summary.channels):
        fail("rosbag2 metadata does not list every channel")
    print(f"ros2 bag check: rosbag2 metadata version 9, {len(summary.channels)} topics, "
          f"{stats.message_count} messages, QoS by name")


if __name__ == "__main__":
    main()
