#!/usr/bin/env python3
"""What a ROS 2 node on rmw_zenoh sees of `anguilla link` with `[link] ros2
= true`, done by other implementations: `eclipse-zenoh` (PyPI, 1.10.2) for
the wire, `rosbags` (PyPI) for the messages and their RIHS01 type hashes.

As rmw_zenoh's graph cache does, it asks for the liveliness tokens of the
domain (`@ros2_lv/<domain>/**`), parses them as rmw_zenoh's design document
describes (docs/ros2.md), and finds the node and each publisher with its
type and hash. Every hash must equal `rosbags`' own computation from Jazzy's
definitions (with `--distro humble`: `TypeHashNotSupported`, as Humble's
rmw_zenoh writes, and Humble's definitions). It then subscribes by the data key built from each token, as a
ROS 2 subscription would, and deserialises every message with `rosbags`'
CDR reader. With the link's state on `P/state` at every change (the link
run with `--state-rate 1000`), each joint state, IMU, pressure and torque
message must hold the values of one state the daemon published, and the
diagnostics its mode. Every sample must carry rmw_zenoh's 33-byte
attachment with an increasing sequence number and one GID per publisher.

Exit 0 when all holds, 1 otherwise (the first failure is printed).
"""

import argparse
import math
import struct
import xml.etree.ElementTree as ET
import sys
import time

import numpy
import zenoh
import zenoh.ext
from rosbags.typesys import Stores, get_typestore

from anguilla_client import MODES, StateSnapshot
from zenoh_client import close, session

TOPICS = {
    "joint_states": "sensor_msgs/msg/JointState",
    "imu": "sensor_msgs/msg/Imu",
    "pressure": "sensor_msgs/msg/FluidPressure",
    "feedforward": "std_msgs/msg/Float64MultiArray",
    "torque_residual": "std_msgs/msg/Float64MultiArray",
    "diagnostics": "diagnostic_msgs/msg/DiagnosticArray",
    "tf": "tf2_msgs/msg/TFMessage",
    "cross_track_error": "std_msgs/msg/Float64",
    "current": "geometry_msgs/msg/Vector3Stamped",
}
# Transient local: a late subscriber gets their last message.
LATCHED = {
    "robot_description": "std_msgs/msg/String",
    "tf_static": "tf2_msgs/msg/TFMessage",
}


def unmangle(s):
    return "" if s == "%" else s.replace("%", "/")


def ros_type(dds):
    """`pkg::msg::dds_::Type_` -> `pkg/msg/Type`."""
    pkg, kind, dds_, ty = dds.split("::")
    assert dds_ == "dds_" and ty.endswith("_"), dds
    return f"{pkg}/{kind}/{ty[:-1]}"


def parse_token(key):
    """rmw_zenoh's liveliness token: a dict, or None for another shape."""
    f = key.split("/")
    if len(f) < 9 or f[0] != "@ros2_lv":
        return None
    t = dict(domain=int(f[1]), zid=f[2], node_id=int(f[3]), entity_id=int(f[4]), kind=f[5],
             enclave=unmangle(f[6]), namespace=unmangle(f[7]) or "/", node=f[8])
    if t["kind"] != "NN":
        if len(f) != 13:
            return None
        t.update(topic=unmangle(f[9]), dds_type=f[10], type=ros_type(f[10]), hash=f[11], qos=f[12])
    return t


def fail(why):
    print(f"ros2 graph client: FAILED: {why}")
    sys.exit(1)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("endpoint")
    ap.add_argument("--prefix", required=True, help="the daemon's prefix (for P/state)")
    ap.add_argument("--domain", type=int, default=0)
    ap.add_argument("--node", default="anguilla")
    ap.add_argument("--count", type=int, default=20, help="messages per topic")
    ap.add_argument("--timeout", type=float, default=30.0)
    ap.add_argument("--distro", choices=["jazzy", "humble"], default="jazzy",
                    help="humble: TypeHashNotSupported in keys and tokens, Humble's messages")
    ap.add_argument("--faster", nargs=2, metavar=("FAST", "SLOW"),
                    help="FAST's rate is configured at least twice SLOW's: its count must be "
                         "more than 1.5 times SLOW's")
    a = ap.parse_args(argv)
    ts = get_typestore(Stores.ROS2_HUMBLE if a.distro == "humble" else Stores.ROS2_JAZZY)
    z = session(a.endpoint)

    # The graph, as rmw_zenoh's graph cache builds it.
    tokens, end = [], time.monotonic() + a.timeout
    while time.monotonic() < end:
        tokens = [parse_token(str(r.ok.key_expr))
                  for r in z.liveliness().get(f"@ros2_lv/{a.domain}/**", timeout=2.0) if r.ok]
        if any(t and t["kind"] == "NN" for t in tokens):
            break
        time.sleep(0.2)
    tokens = [t for t in tokens if t]
    nodes = [t for t in tokens if t["kind"] == "NN" and t["node"] == a.node]
    if len(nodes) != 1:
        fail(f"{len(nodes)} nodes named {a.node!r} in domain {a.domain}: {tokens}")
    node = nodes[0]
    print(f"node {node['namespace'].rstrip('/')}/{node['node']} (session {node['zid']}, "
          f"domain {node['domain']})")
    pubs = {}
    for t in tokens:
        if t["kind"] != "MP" or t["zid"] != node["zid"] or t["node"] != a.node:
            continue
        want = "TypeHashNotSupported" if a.distro == "humble" else ts.hash_rihs01(t["type"])
        if t["hash"] != want:
            fail(f"{t['topic']}: type hash {t['hash']}, expected {want} for {t['type']} ({a.distro})")
        pubs[t["topic"]] = t
        print(f"  publisher {t['topic']} [{t['type']}] {t['hash']} qos {t['qos']}: hash checked")
    ns = node["namespace"].rstrip("/")
    for name, ty in list(TOPICS.items()) + list(LATCHED.items()):
        t = pubs.get(f"{ns}/{name}")
        if t is None or t["type"] != ty:
            fail(f"no publisher of {ns}/{name} [{ty}] among {sorted(pubs)}")
    latched = {}
    for name in LATCHED:
        t = pubs.pop(f"{ns}/{name}")
        durability = t["qos"].split(":")[1]
        if durability != "1":
            fail(f"{name}: QoS {t['qos']} is not transient local (durability 1)")
        latched[name] = t
    # A late joiner, as rmw_zenoh subscribes to a transient-local topic:
    # an advanced subscriber with history, which asks the publisher's cache.
    late = {}
    for name, t in latched.items():
        key = f"{t['domain']}/{t['topic'].lstrip('/')}/{t['dds_type']}/{t['hash']}"
        late[name] = zenoh.ext.declare_advanced_subscriber(
            z, key, history=zenoh.ext.HistoryConfig(detect_late_publishers=True, max_samples=1),
            subscriber_detection=True)

    # Subscribe by the data keys, as a ROS 2 subscription does, and to the
    # daemon's state through the link.
    got = {topic: [] for topic in pubs}
    # diagnostics come at 1 Hz by default
    need = {t: (min(a.count, 5) if t.endswith("/diagnostics") else a.count) for t in pubs}
    subs = []
    for topic, t in pubs.items():
        key = f"{t['domain']}/{topic.lstrip('/')}/{t['dds_type']}/{t['hash']}"
        subs.append((topic, z.declare_subscriber(key)))
    state_sub = z.declare_subscriber(f"{a.prefix}/state")
    # A hostile client (another session) forges joint states on the node's
    # data key and declares a node of its own: the link's access list lets
    # no remote client publish a ROS 2 topic, so no subscriber may see it.
    forger = session(a.endpoint)
    js = pubs[f"{ns}/joint_states"]
    forged_key = f"{js['domain']}/{js['topic'].lstrip('/')}/{js['dds_type']}/{js['hash']}"
    forged = ts.serialize_cdr(
        ts.types["sensor_msgs/msg/JointState"](
            header=ts.types["std_msgs/msg/Header"](
                stamp=ts.types["builtin_interfaces/msg/Time"](sec=1, nanosec=0), frame_id="forged"),
            name=["forged"], position=numpy.array([6.28]),
            velocity=numpy.array([0.0]), effort=numpy.array([0.0])),
        "sensor_msgs/msg/JointState")
    for _ in range(20):
        forger.put(forged_key, bytes(forged))
    states = []
    end = time.monotonic() + a.timeout
    while time.monotonic() < end and any(len(v) < need[t] for t, v in got.items()):
        idle = True
        for topic, sub in subs:
            s = sub.try_recv()
            if s is not None:
                idle = False
                att = s.attachment.to_bytes() if s.attachment is not None else b""
                got[topic].append((s.payload.to_bytes(), att))
        s = state_sub.try_recv()
        while s is not None:
            idle = False
            states.append(StateSnapshot.from_buffer_copy(s.payload.to_bytes()))
            s = state_sub.try_recv()
        if idle:
            time.sleep(0.002)
    for topic, v in got.items():
        if len(v) < need[topic]:
            fail(f"{len(v)} messages on {topic} in {a.timeout} s, expected {need[topic]}")
    # (drain the states the last messages came from)
    time.sleep(0.2)
    s = state_sub.try_recv()
    while s is not None:
        states.append(StateSnapshot.from_buffer_copy(s.payload.to_bytes()))
        s = state_sub.try_recv()

    f32 = lambda x: struct.unpack("<f", struct.pack("<f", x))[0]  # noqa: E731

    def axes(st, pitch, yaw):
        return [f32(getattr(j, f)) for j in st.joints[:st.joint_count] for f in (pitch, yaw)]

    # A state can be missing here while its ROS 2 messages arrived: the
    # link sends states and topics with congestion control "drop", and a
    # busy machine drops some. So each message must equal a state received,
    # but up to a tenth of a topic's may find theirs missing.
    unmatched = {}

    def match(what, values, of):
        for st in states:
            if list(values) == of(st):
                return st
        unmatched.setdefault(what, []).append(list(values)[:4])
        return None

    moved = 0
    for topic, msgs in got.items():
        ty = pubs[topic]["type"]
        seqs, gids = [], set()
        for payload, att in msgs:
            if len(att) != 33 or att[16] != 16:
                fail(f"{topic}: attachment of {len(att)} bytes {att.hex()}, expected rmw_zenoh's 33")
            seq, stamp = struct.unpack_from("<qq", att)
            seqs.append(seq)
            gids.add(att[17:])
            m = ts.deserialize_cdr(payload, ty)
            name = topic.rsplit("/", 1)[1]
            if name == "joint_states":
                if m.header.frame_id == "forged":
                    fail("a forged joint state from another client reached a subscriber")
                # position, velocity and effort together: states at rest
                # share positions
                match("joint_states", list(m.position) + list(m.velocity) + list(m.effort),
                      lambda s: axes(s, "measured_pitch", "measured_yaw")
                      + axes(s, "measured_pitch_velocity", "measured_yaw_velocity")
                      + axes(s, "measured_pitch_torque", "measured_yaw_torque"))
                n = states[-1].joint_count
                want = [f"joint{j}_{ax}" for j in range(1, n + 1) for ax in ("pitch", "yaw")]
                if list(m.name) != want:
                    fail(f"joint names {list(m.name)}, expected {want}")
                moved += any(abs(p) > 1e-3 for p in m.position)
            elif name in ("feedforward", "torque_residual"):
                fields = {"feedforward": ("predicted_pitch_torque", "predicted_yaw_torque"),
                          "torque_residual": ("pitch_torque_residual", "yaw_torque_residual")}[name]
                match(name, m.data, lambda s, f=fields: axes(s, *f))
                if m.layout.dim[0].size != len(m.data):
                    fail(f"{name}: layout size {m.layout.dim[0].size} for {len(m.data)} values")
            elif name == "pressure":
                match("pressure", [m.fluid_pressure],
                      lambda s: [101325.0 + 1000.0 * 9.80665 * f32(s.nav.depth_m)])
            elif name == "imu":
                q = m.orientation
                if abs(q.x ** 2 + q.y ** 2 + q.z ** 2 + q.w ** 2 - 1.0) > 1e-9:
                    fail(f"imu orientation not a unit quaternion: {q}")
                if m.angular_velocity_covariance[0] != -1.0:
                    fail("imu: rates not marked unknown")
            elif name == "tf":
                frames = [(x.header.frame_id, x.child_frame_id) for x in m.transforms]
                if frames[0] != ("odom", "head"):
                    fail(f"tf: the first transform is {frames[0]}, expected odom -> head")
                # each joint: its pitch about -y, then its yaw about z, as
                # the URDF's joints; from one state the daemon published
                def rotations(st):
                    out = []
                    for j in st.joints[:st.joint_count]:
                        p, y = f32(j.measured_pitch), f32(j.measured_yaw)
                        out += [(0.0, -math.sin(p / 2), 0.0, math.cos(p / 2)),
                                (0.0, 0.0, math.sin(y / 2), math.cos(y / 2))]
                    return out
                got_r = [(x.transform.rotation.x, x.transform.rotation.y, x.transform.rotation.z,
                          x.transform.rotation.w) for x in m.transforms[1:]]
                if not any(len(got_r) == 2 * st.joint_count and all(
                        abs(u - v) < 1e-12 for a_, b_ in zip(got_r, rotations(st))
                        for u, v in zip(a_, b_)) for st in states):
                    unmatched.setdefault("tf", []).append(got_r[:2])
            elif name == "cross_track_error":
                # NaN while no path is followed, else a state's error
                if math.isnan(m.data):
                    if all(st.guide.state == 1 for st in states):
                        fail("cross_track_error: NaN while every state follows a path")
                else:
                    match(name, [m.data], lambda st: [f32(st.guide.cross_track_m)]
                          if st.guide.state == 1 else [None])
            elif name == "current":
                if m.header.frame_id != "odom" or m.vector.z != 0.0:
                    fail(f"current: frame {m.header.frame_id!r}, z {m.vector.z}: expected odom, 0")
                match(name, [m.vector.x, m.vector.y],
                      lambda st: [f32(st.nav.current_x), f32(st.nav.current_y)])
            elif name == "diagnostics":
                daemon = [x for x in m.status if x.name == "anguilla: daemon"]
                if not daemon:
                    fail("diagnostics: no 'anguilla: daemon' status")
                mode = {kv.key: kv.value for kv in daemon[0].values}.get("mode")
                if mode not in {MODES[s.mode] for s in states}:
                    fail(f"diagnostics: mode {mode!r}, which no state had")
            if stamp <= 0 or (hasattr(m, "header") and m.header.stamp.sec <= 0):
                fail(f"{topic}: no source timestamp or header stamp")
        if seqs != sorted(set(seqs)) or len(gids) != 1:
            fail(f"{topic}: sequence numbers {seqs[:5]}... not increasing, or {len(gids)} GIDs")
        print(f"  {topic}: {len(msgs)} messages, deserialised by rosbags, sequence "
              f"{seqs[0]}..{seqs[-1]}, GID {next(iter(gids)).hex()}")
    for what, misses in unmatched.items():
        n = len(got[f"{ns}/{what}"])
        print(f"  {what}: {len(misses)} of {n} messages found no state received (dropped by a busy "
              f"machine)")
        if len(misses) > n / 10:
            fail(f"{what}: {len(misses)} of {n} messages equal no state the daemon published "
                 f"({len(states)} received), e.g. {misses[0]}")
    forger.close()
    for name, sub in late.items():
        sample, end = None, time.monotonic() + 10
        while sample is None and time.monotonic() < end:
            sample = sub.try_recv()
            time.sleep(0.01)
        if sample is None:
            fail(f"a late subscriber got no {name} from the publisher's cache")
        m = ts.deserialize_cdr(sample.payload.to_bytes(), LATCHED[name])
        if name == "robot_description":
            robot = ET.fromstring(m.data)
            joints = [j.get("name") for j in robot.iter("joint") if j.get("type") == "revolute"]
            n = states[-1].joint_count
            want = [f"joint{j}_{ax}" for j in range(1, n + 1) for ax in ("pitch", "yaw")]
            if joints != want:
                fail(f"robot_description's revolute joints {joints}, expected joint_states' {want}")
            print(f"  late joiner: robot_description, a URDF of {len(list(robot.iter('link')))} "
                  f"links and {len(joints)} revolute joints named as joint_states'")
        else:
            frames = [(x.header.frame_id, x.child_frame_id) for x in m.transforms]
            if frames != [("head", "head_sensor")]:
                fail(f"tf_static: {frames}")
            print(f"  late joiner: tf_static {frames}")
    if a.faster:
        fast, slow = (len(got[f"{ns}/{n}"]) for n in a.faster)
        print(f"  {a.faster[0]}: {fast} messages, {a.faster[1]}: {slow} in the same time")
        if fast <= 1.5 * slow:
            fail(f"{a.faster[0]} is configured faster than {a.faster[1]} but came {fast} to {slow}")
    all_gids = {m[0][1][17:] for m in got.values()}
    if len(all_gids) != len(got):
        fail("two publishers share a GID")
    print(f"ros2 graph client: OK ({len(states)} states; {moved} joint states with the joints moved)")
    close(forger)
    close(z)


if __name__ == "__main__":
    main()
