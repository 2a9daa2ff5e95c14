#!/usr/bin/env python3
"""Driving the robot from ROS 2 as rmw_zenoh would, with other
implementations: `eclipse-zenoh` (PyPI, 1.10.2) for the wire, `rosbags`
(PyPI) for the messages and the type hashes.

From the liveliness tokens of `anguilla link` (`[link] ros2 = true`) it
finds the node's `cmd_vel` subscriptions (`geometry_msgs/msg/Twist` and
`TwistStamped`) and its services (`std_srvs/srv/Trigger`), checks every
hash (a service's as rosidl computes one: its request, response and event,
the computation checked first on rmw_zenoh's documented `AddTwoInts`
hash), then, as a ROS 2 node would:
- calls `~/take_control` and `~/enable`: the daemon names a holder and
  becomes ready;
- publishes CDR twists with rmw_zenoh's attachment at 10 Hz: the robot
  swims the mapped gait (docs/ros2.md), and a twist that is not finite
  changes nothing;
- stops publishing: the daemon's deadman stops the swim (cause: operator
  silent);
- publishes a `nav_msgs/msg/Path` (rosbags' CDR) on `path` and calls
  `~/follow_path`: the daemon follows it (its state's `guide` says
  following, leg 1) and the node keeps control alive while it does;
  `~/stop` interrupts it;
- calls `~/estop`: the robot is in e-stop, and stays there while twists
  keep coming (it latches);
- publishes a `geometry_msgs/msg/PoseStamped` on `pose_fix` stamped 0.8 s
  ago, then a `nav_msgs/msg/Odometry` on `odom_fix` with a covariance:
  the daemon's position sensor shows each fix, its σ (the link's
  `ros2-pose-sigma`, then the covariance's) and an age of at least the
  stamp's (the link ages each fix by its stamp).
Every reply must echo the call's sequence number and GID. Exit 0 when all
holds, 1 otherwise.
"""

import argparse
import math
import struct
import sys
import time

import numpy
import zenoh
from rosbags.typesys import Stores, get_typestore, get_types_from_msg

from anguilla_client import MODES, StateSnapshot
from ros2_graph_client import fail, parse_token
from zenoh_client import close, session

GID = bytes(range(0xA0, 0xB0))
CAUSE_OPERATOR_SILENT = 2
ADD_TWO_INTS = "RIHS01_e118de6bf5eeb66a2491b5bda11202e7b68f198d6f67922cf30364858239c81a"


def _srv_path(x):
    """rosbags' .msg parser files every type under msg/: put srv/ back."""
    if isinstance(x, str):
        return x.replace("/srv/msg/", "/srv/")
    if isinstance(x, (tuple, list)):
        return type(x)(_srv_path(y) for y in x)
    return x


def service_store():
    """Types for services: Time, and ServiceEventInfo with its client_gid
    as rosidl hashes it (a .msg `char` is IDL uint8; rosbags' Jazzy store
    keeps `char`)."""
    ts = get_typestore(Stores.EMPTY)
    ts.register(get_types_from_msg("int32 sec\nuint32 nanosec\n", "builtin_interfaces/msg/Time"))
    ts.register(get_types_from_msg(
        "uint8 event_type\nbuiltin_interfaces/msg/Time stamp\nuint8[16] client_gid\n"
        "int64 sequence_number\n", "service_msgs/msg/ServiceEventInfo"))
    return ts


def srv_hash(ts, name, req, resp):
    """REP-2016's hash of the service `pkg/srv/Name`: the description of
    `request_message`, `response_message` and `event_message`."""
    types = {}
    types.update(get_types_from_msg(req, f"{name}_Request"))
    types.update(get_types_from_msg(resp, f"{name}_Response"))
    types.update(get_types_from_msg(
        f"service_msgs/msg/ServiceEventInfo info\n{name}_Request[<=1] request\n"
        f"{name}_Response[<=1] response\n", f"{name}_Event"))
    types.update(get_types_from_msg(
        f"{name}_Request request_message\n{name}_Response response_message\n"
        f"{name}_Event event_message\n", name))
    ts.register({_srv_path(k): _srv_path(v) for k, v in types.items()})
    return ts.hash_rihs01(name)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("endpoint")
    ap.add_argument("--prefix", required=True)
    ap.add_argument("--domain", type=int, default=0)
    ap.add_argument("--node", default="anguilla")
    ap.add_argument("--max-speed", type=float, default=0.4, help="[link] ros2-max-speed")
    ap.add_argument("--pose-sigma", type=float, default=0.01, help="[link] ros2-pose-sigma")
    a = ap.parse_args(argv)
    jazzy = get_typestore(Stores.ROS2_JAZZY)
    srv = service_store()
    got = srv_hash(srv, "example_interfaces/srv/AddTwoInts", "int64 a\nint64 b\n", "int64 sum\n")
    if got != ADD_TWO_INTS:
        fail(f"the service hash computation gives {got} for AddTwoInts, rmw_zenoh documents "
             f"{ADD_TWO_INTS}")
    trigger = srv_hash(srv, "std_srvs/srv/Trigger", "uint8 structure_needs_at_least_one_member\n",
                       "bool success\nstring message\n")
    print(f"service hashes: AddTwoInts = rmw_zenoh's documented one; std_srvs/srv/Trigger {trigger}")
    z = session(a.endpoint)
    tokens = []
    end = time.monotonic() + 30
    while time.monotonic() < end and not any(t and t["kind"] == "SS" for t in tokens):
        tokens = [parse_token(str(r.ok.key_expr))
                  for r in z.liveliness().get(f"@ros2_lv/{a.domain}/**", timeout=2.0) if r.ok]
        time.sleep(0.2)
    mine = [t for t in tokens if t and t["node"] == a.node and t["kind"] in ("MS", "SS")]
    services, cmd_vel, path_sub, fixes = {}, {}, None, {}
    for t in mine:
        if t["kind"] == "SS":
            if t["type"] != "std_srvs/srv/Trigger" or t["hash"] != trigger:
                fail(f"service {t['topic']}: {t['type']} {t['hash']}, expected Trigger {trigger}")
            services[t["topic"].rsplit("/", 1)[1]] = t
        elif t["topic"].endswith("/path"):
            if t["type"] != "nav_msgs/msg/Path" or t["hash"] != jazzy.hash_rihs01(t["type"]):
                fail(f"path: {t['type']} {t['hash']}, expected nav_msgs/msg/Path with rosbags' hash")
            path_sub = t
        elif t["topic"].endswith(("/pose_fix", "/odom_fix")):
            if t["hash"] != jazzy.hash_rihs01(t["type"]):
                fail(f"{t['topic']} [{t['type']}]: hash {t['hash']} is not rosbags' own")
            fixes[t["topic"].rsplit("/", 1)[1]] = t
        elif t["topic"].endswith("/cmd_vel"):
            if t["hash"] != jazzy.hash_rihs01(t["type"]):
                fail(f"cmd_vel [{t['type']}]: hash {t['hash']} is not rosbags' own")
            cmd_vel[t["type"]] = t
        print(f"  {t['kind']} {t['topic']} [{t['type']}] {t['hash']}: hash checked")
    if path_sub is None:
        fail("no path subscription")
    want = {"pose_fix": "geometry_msgs/msg/PoseStamped", "odom_fix": "nav_msgs/msg/Odometry"}
    if {k: t["type"] for k, t in fixes.items()} != want:
        fail(f"position-fix subscriptions {sorted(fixes)}, expected {want}")
    for name in ("take_control", "release_control", "enable", "disable", "stop", "estop",
                 "follow_path", "resume_path"):
        if name not in services:
            fail(f"no service ~/{name} among {sorted(services)}")
    for ty in ("geometry_msgs/msg/Twist", "geometry_msgs/msg/TwistStamped"):
        if ty not in cmd_vel:
            fail(f"no cmd_vel subscription of {ty} among {sorted(cmd_vel)}")

    def key(t):
        return f"{t['domain']}/{t['topic'].lstrip('/')}/{t['dds_type']}/{t['hash']}"

    state_sub = z.declare_subscriber(f"{a.prefix}/state")
    last = {}

    def state():
        s = state_sub.try_recv()
        while s is not None:
            last["s"] = StateSnapshot.from_buffer_copy(s.payload.to_bytes())
            s = state_sub.try_recv()
        return last.get("s")

    def wait_for(what, pred, timeout):
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            s = state()
            if s is not None and pred(s):
                return s
            time.sleep(0.01)
        s = state()
        fail(f"{what} within {timeout} s (mode {MODES[s.mode] if s else None})")

    seq = [0]

    def call(name):
        seq[0] += 1
        att = struct.pack("<qq", seq[0], time.time_ns()) + bytes([16]) + GID
        replies = list(z.get(key(services[name]), payload=b"\x00\x01\x00\x00\x00", attachment=att,
                             target=zenoh.QueryTarget.ALL_COMPLETE, timeout=5.0))
        if len(replies) != 1 or replies[0].ok is None:
            fail(f"~/{name}: {len(replies)} replies "
                 f"{[r.err.payload.to_bytes() for r in replies if r.err is not None]}")
        r = replies[0].ok
        ra = r.attachment.to_bytes() if r.attachment is not None else b""
        if len(ra) != 33 or struct.unpack_from("<q", ra)[0] != seq[0] or ra[17:] != GID:
            fail(f"~/{name}: the reply's attachment {ra.hex()} does not echo sequence {seq[0]} "
                 f"and the GID")
        body = r.payload.to_bytes()
        success = body[4] != 0
        (n,) = struct.unpack_from("<I", body, 8)
        message = body[12:12 + n - 1].decode()
        print(f"  ~/{name}: success {success}, {message!r}")
        return success, message

    twist_pub = z.declare_publisher(key(cmd_vel["geometry_msgs/msg/Twist"]))
    stamped_pub = z.declare_publisher(key(cmd_vel["geometry_msgs/msg/TwistStamped"]))
    tseq = [0]

    def twist(x, wz, z_=0.0, stamped=False):
        tseq[0] += 1
        att = struct.pack("<qq", tseq[0], time.time_ns()) + bytes([16]) + GID
        body = struct.pack("<6d", x, 0.0, z_, 0.0, 0.0, wz)
        if stamped:
            now = time.time_ns()
            hdr = struct.pack("<iI", now // 10**9, now % 10**9) + struct.pack("<I", 5) + b"base\x00"
            hdr += b"\x00" * ((-len(hdr)) % 8)
            stamped_pub.put(b"\x00\x01\x00\x00" + hdr + body, attachment=att)
        else:
            twist_pub.put(b"\x00\x01\x00\x00" + body, attachment=att)

    wait_for("a state", lambda s: True, 10)
    ok, _ = call("take_control")
    if not ok:
        fail("~/take_control was refused")
    wait_for("a holder", lambda s: s.holder() != 0, 5)
    ok, _ = call("enable")
    if not ok:
        fail("~/enable was refused")
    wait_for("ready", lambda s: MODES[s.mode] == "ready", 20)
    # A twist that is not finite is dropped; the robot stays ready.
    twist(float("nan"), 0.0)
    time.sleep(0.3)
    if MODES[state().mode] != "ready":
        fail(f"a NaN twist changed the mode to {MODES[state().mode]}")
    x, wz = 0.3, 0.2
    end = time.monotonic() + 4.0
    i = 0
    while time.monotonic() < end:
        twist(x, wz, stamped=i % 2 == 1)
        i += 1
        time.sleep(0.1)
    s = wait_for("swimming", lambda s: MODES[s.mode] == "swimming", 5)
    g = s.gait_target
    # The amplitude is the one whose steady speed the link's model gives as
    # x (a table made at its start; checked against the simulation's ground
    # truth by tests/tests/cmd_vel_speed.rs): here, within reach, strictly
    # between 0 and full amplitude.
    print(f"  swimming: gait asked amplitude {g.amplitude:.3f} for {x} m/s, frequency "
          f"{g.frequency:.2f} Hz, turn {g.turn:.3f} /m (want {min(wz / x, s.limits.max_turn):.3f})")
    if not 0.0 < g.amplitude < 1.0 or x > a.max_speed or \
            not math.isclose(g.turn, min(wz / x, s.limits.max_turn), abs_tol=1e-3):
        fail("the gait is not the twist's")
    t0 = time.monotonic()
    s = wait_for("the deadman's stop", lambda s: MODES[s.mode] != "swimming", 15)
    print(f"  twists stopped: mode {MODES[s.mode]} after {time.monotonic() - t0:.1f} s, "
          f"cause code {s.cause}")
    if s.cause != CAUSE_OPERATOR_SILENT:
        fail(f"the swim ended with cause {s.cause}, not 'operator silent' ({CAUSE_OPERATOR_SILENT})")
    # A path: three waypoints from where the robot is, in odom.
    T = jazzy.types
    hdr = T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=0, nanosec=0),
                                   frame_id="odom")
    s = state()
    x0, y0 = s.nav.x_m, s.nav.y_m
    poses = [T["geometry_msgs/msg/PoseStamped"](
        header=hdr, pose=T["geometry_msgs/msg/Pose"](
            position=T["geometry_msgs/msg/Point"](x=x0 + dx, y=y0 + dy, z=0.0),
            orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)))
        for dx, dy in ((0.0, 0.0), (20.0, 0.0), (20.0, 10.0))]
    body = jazzy.serialize_cdr(T["nav_msgs/msg/Path"](header=hdr, poses=poses), "nav_msgs/msg/Path")
    att = struct.pack("<qq", 1, time.time_ns()) + bytes([16]) + GID
    z.declare_publisher(key(path_sub)).put(bytes(body), attachment=att)
    time.sleep(0.5)
    ok, _ = call("take_control")
    ok, message = call("follow_path")
    if not ok:
        fail(f"~/follow_path was refused: {message}")
    s = wait_for("the path followed", lambda s: s.guide.state == 1 and MODES[s.mode] == "swimming", 10)
    if (s.guide.leg, s.guide.waypoints) != (1, 3):
        fail(f"following leg {s.guide.leg} of {s.guide.waypoints}, expected 1 of 3")
    time.sleep(3.0)
    s = state()
    if s.guide.state != 1 or MODES[s.mode] != "swimming":
        fail(f"the path was not kept alive: guide state {s.guide.state}, mode {MODES[s.mode]}")
    print(f"  following: leg {s.guide.leg}, cross-track {s.guide.cross_track_m:+.2f} m, "
          f"{s.guide.to_go_m:.1f} m to go")
    call("stop")
    s = wait_for("the path stopped", lambda s: MODES[s.mode] in ("ready", "stopping"), 10)
    if s.guide.state != 3:
        fail(f"after ~/stop the path's state is {s.guide.state}, not interrupted (3)")
    call("estop")
    wait_for("e-stop", lambda s: MODES[s.mode] == "e-stop", 5)
    for _ in range(10):
        twist(x, 0.0)
        time.sleep(0.1)
    if MODES[state().mode] != "e-stop":
        fail(f"twists after the e-stop took the robot to {MODES[state().mode]}")
    # Position fixes: a motion capture's PoseStamped 0.8 s old, then an
    # Odometry with σ 0.04 m; the daemon's position sensor (kind 3) shows
    # each as the link handed it over, aged by its stamp.
    def fix_shown(x_, y_, sigma, age):
        def shown(s):
            return any(e.kind == 3 and math.isclose(e.values[0], x_, abs_tol=1e-3)
                       and math.isclose(e.values[1], y_, abs_tol=1e-3)
                       and math.isclose(e.values[2], sigma, rel_tol=1e-3)
                       and e.values[3] >= age for e in s.sensors)
        return shown

    def stamped_header(ago):
        t = time.time_ns() - int(ago * 1e9)
        return T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](
            sec=t // 10**9, nanosec=t % 10**9), frame_id="odom")

    def pose(x_, y_):
        return T["geometry_msgs/msg/Pose"](
            position=T["geometry_msgs/msg/Point"](x=x_, y=y_, z=0.0),
            orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0))

    pose_pub = z.declare_publisher(key(fixes["pose_fix"]))
    odom_pub = z.declare_publisher(key(fixes["odom_fix"]))
    for name, pub, make, (fx, fy, sigma, ago) in (
        ("pose_fix", pose_pub, lambda: jazzy.serialize_cdr(T["geometry_msgs/msg/PoseStamped"](
            header=stamped_header(0.8), pose=pose(123.25, -45.5)),
            "geometry_msgs/msg/PoseStamped"), (123.25, -45.5, a.pose_sigma, 0.8)),
        ("odom_fix", odom_pub, lambda: jazzy.serialize_cdr(T["nav_msgs/msg/Odometry"](
            header=stamped_header(0.0), child_frame_id="base_link",
            pose=T["geometry_msgs/msg/PoseWithCovariance"](
                pose=pose(-7.5, 8.25), covariance=numpy.array(
                    [0.0016 if i in (0, 7) else 0.0 for i in range(36)])),
            twist=T["geometry_msgs/msg/TwistWithCovariance"](
                twist=T["geometry_msgs/msg/Twist"](
                    linear=T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0),
                    angular=T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)),
                covariance=numpy.zeros(36))), "nav_msgs/msg/Odometry"), (-7.5, 8.25, 0.04, 0.0)),
    ):
        # 20 Hz, as a motion capture's bridge (the built-in robot's own
        # simulated USBL sends to the same port once a second).
        end, seen, n = time.monotonic() + 15, None, 0
        while time.monotonic() < end and seen is None:
            n += 1
            att = struct.pack("<qq", n, time.time_ns()) + bytes([16]) + GID
            pub.put(bytes(make()), attachment=att)
            time.sleep(0.05)
            s = state()
            if s is not None and fix_shown(fx, fy, sigma, ago)(s):
                seen = s
        if seen is None:
            e = [e for e in state().sensors if e.kind == 3]
            fail(f"{name}: the daemon's position sensor does not show ({fx}, {fy}) σ {sigma} "
                 f"aged >= {ago} s: {[list(x.values) for x in e]}")
        e = next(e for e in seen.sensors if e.kind == 3)
        print(f"  {name}: the daemon's position sensor shows ({e.values[0]:.2f}, "
              f"{e.values[1]:.2f}) σ {e.values[2]:.4f} m, age {e.values[3]:.2f} s")
    print("ros2 drive client: OK (took control, enabled, swam from cmd_vel, the deadman "
          "stopped it, followed a nav_msgs/Path, e-stop latched, took PoseStamped and "
          "Odometry fixes aged by their stamps)")
    close(z)


if __name__ == "__main__":
    main()
