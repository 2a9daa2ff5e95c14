#!/usr/bin/env python3
"""Checks `anguilla export --ros2 SESSION` with other implementations:
`rosbags`' rosbag2 reader (PyPI) opens the MCAP, every connection has its
ROS 2 type, `cdr`, the schema `rosbags` generates from Jazzy's definitions
and the live node's QoS, and every message deserialises. The counts and values must be the
session's: state.bin (read here with the ctypes twins of docs/ipc.md) is
thinned at each topic's rate on the recorded clock, as the export says it
does, and each joint state must hold its snapshot's measured joints, each
stamped with the recording's start plus the snapshot's time.

    ros2_bag_check.py SESSION_DIR BAG.mcap [--rate HZ] [--rates TOPIC=HZ ...]

Exit 0 when all holds, 1 otherwise.
"""

import argparse
import ctypes
import os
import struct
import sys
import xml.etree.ElementTree as ET

from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore

from anguilla_client import StateSnapshot

TOPICS = ["joint_states", "imu", "pressure", "feedforward", "torque_residual", "diagnostics", "tf"]
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
    a = ap.parse_args(argv)
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
            if name == "joint_states":
                f32 = lambda x: struct.unpack("<f", struct.pack("<f", x))[0]  # noqa: E731
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


if __name__ == "__main__":
    main()
