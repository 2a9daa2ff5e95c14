#!/usr/bin/env python3
"""A small Python operator client for the anguilla daemon, over iceoryx2.

Written only from docs/ipc.md and the #[repr(C)] payloads of ipc/src/payload.rs,
with iceoryx2's Python bindings from PyPI (iceoryx2==0.10.0, the Rust crate's
version); CI runs it against a live daemon (examples/python/run-example.sh).
As a module: Client(prefix) with state(), wait_state() and request(). As a
program: take control, enable, swim ~2 s, E-stop, reset, release; exit 1 on any
unexpected outcome, 2 when no daemon serves the prefix.
"""

import argparse
import ctypes
import sys
import time

try:
    import iceoryx2 as iox2
except ImportError:  # the payloads alone (zenoh_client.py) need no iceoryx2
    iox2 = None

LAYOUT_VERSION = 12
(ENABLE, DISABLE, SWIM, STOP, ESTOP, RESET, TAKE_CONTROL, RELEASE_CONTROL, KEEP_ALIVE, HOLD,
 SWIM_HOLD) = range(1, 12)
HOLD_HEADING, HOLD_DEPTH = 1, 2
IDLE, ENABLING, READY, SWIMMING, STOPPING, FAULT, E_STOP = range(7)
MODES = ["idle", "enabling", "ready", "swimming", "stopping", "fault", "e-stop"]
MAX_TOOLS, MAX_NODES, MAX_REQUESTS_PER_CLIENT = 32, 36, 4
u8, u16, u32, u64 = ctypes.c_uint8, ctypes.c_uint16, ctypes.c_uint32, ctypes.c_uint64
f32 = ctypes.c_float


class _Payload(ctypes.Structure):
    """A #[repr(C)] payload; its iceoryx2 type name is that of its Rust twin."""

    @classmethod
    def type_name(cls):  # iceoryx2's get_type_name() uses this when a type has it
        return f"anguilla::{cls.__name__}"


class JointSnapshot(_Payload):
    _fields_ = [(n, f32) for n in (
        "commanded_pitch", "commanded_yaw", "measured_pitch", "measured_yaw",
        "commanded_pitch_velocity", "commanded_yaw_velocity",
        "measured_pitch_velocity", "measured_yaw_velocity",
        "predicted_pitch_torque", "predicted_yaw_torque",
        "measured_pitch_torque", "measured_yaw_torque")] + [
        ("node_state", u8), ("node_alive", u8), ("residual_alarm", u8), ("reserved", u8),
        ("node_errors", u32), ("pitch_torque_residual", f32), ("yaw_torque_residual", f32)]


class GaitSnapshot(_Payload):
    _fields_ = [("amplitude", f32), ("frequency", f32), ("turn", f32), ("pitch", f32)]


class LoopSnapshot(_Payload):
    _fields_ = [(n, u32) for n in (
        "period_ns", "jitter_p50_ns", "jitter_p99_ns", "jitter_max_ns",
        "compute_p50_ns", "compute_p99_ns", "compute_max_ns", "reserved")] + [
        ("periods", u64), ("overruns", u64)]


class BusSnapshot(_Payload):
    _fields_ = [(n, u64) for n in (
        "tx_frames", "rx_frames", "tx_dropped", "malformed", "errors", "rx_overruns")] + [
        ("bus_off_count", u32), ("state", u8), ("reserved", u8 * 3)]


class LimitsSnapshot(_Payload):
    _fields_ = [("max_frequency", f32), ("max_turn", f32), ("max_pitch", f32),
                ("command_timeout_ms", u32), ("control_release_ms", u32), ("daemon_pid", u32)]


class NavSnapshot(_Payload):
    _fields_ = [("sensor", u8), ("hold", u8), ("hold_exit", u8), ("roll_alarm", u8)] + [
        (n, f32) for n in (
            "heading_deg", "pitch_deg", "roll_deg", "depth_m", "depth_rate", "temperature",
            "heading_target_deg", "depth_target_m", "rate_innovation", "depth_innovation")] + [
        ("heading_hold", u8), ("depth_hold", u8), ("surfaced", u8), ("reserved", u8),
        ("samples", u64), ("lost_samples", u64),
        ("x_m", f32), ("y_m", f32), ("position_sigma_m", f32), ("position_fixes", u32),
        ("current_x", f32), ("current_y", f32), ("current_sigma", f32), ("fix_age_ms", u32),
        ("position_health", u8), ("reserved_position", u8 * 3), ("speed_scale", f32)]


class GuideSnapshot(_Payload):
    _fields_ = [("state", u8), ("looped", u8), ("leg", u16), ("waypoints", u16),
                ("reserved", u16)] + [
        (n, f32) for n in (
            "cross_track_m", "along_track_m", "leg_length_m", "heading_deg", "integral_m",
            "from_x", "from_y", "to_x", "to_y", "to_go_m")]


class SensorEntry(_Payload):
    _fields_ = [("kind", u8), ("id", u8), ("health", u8), ("reserved", u8), ("samples", u32),
                ("values", f32 * 8)]


class StateSnapshot(_Payload):
    _fields_ = [
        ("layout_version", u32), ("joint_count", u32), ("sequence", u64), ("time_ns", u64),
        ("mode", u8), ("cause", u8), ("feedforward_dropped", u8), ("reserved", u8),
        ("fault_kinds", u32), ("fault_nodes", u64), ("holder_lo", u64), ("holder_hi", u64),
        ("predicted_head_speed", f32), ("predicted_turn_rate", f32),
        ("gait_target", GaitSnapshot), ("gait_actual", GaitSnapshot),
        ("loop_stats", LoopSnapshot), ("bus", BusSnapshot),
        ("clamped_setpoints", u64), ("refused_commands", u64),
        ("operator_silent_stops", u64), ("socket_estops", u64), ("records_lost", u64),
        ("limits", LimitsSnapshot), ("nav", NavSnapshot), ("guide", GuideSnapshot),
        ("sensors", SensorEntry * 4),
        ("joints", JointSnapshot * 32)]

    def holder(self):
        """The client port id holding control (u128), 0 if nobody."""
        return self.holder_hi << 64 | self.holder_lo


class SwimBody(_Payload):
    _fields_ = [("amplitude", f32), ("frequency", f32), ("turn", f32), ("pitch", f32)]


class HoldBody(_Payload):
    _fields_ = [("hold", u32), ("heading", f32), ("depth", f32)]


class SwimHoldBody(_Payload):
    _fields_ = [("amplitude", f32), ("frequency", f32), ("turn", f32), ("pitch", f32),
                ("hold", u32), ("heading", f32), ("depth", f32)]


class WaypointBody(_Payload):
    _fields_ = [("index", u32), ("x", f32), ("y", f32), ("depth", f32)]


class FollowBody(_Payload):
    _fields_ = [("amplitude", f32), ("frequency", f32), ("count", u32), ("flags", u32)]


class CommandBody(ctypes.Union):
    """`CommandRequest.body`: the parameters of the request's code."""
    _fields_ = [("swim", SwimBody), ("hold", HoldBody), ("swim_hold", SwimHoldBody),
                ("waypoint", WaypointBody), ("follow", FollowBody), ("words", u32 * 7)]


class CommandRequest(_Payload):
    _fields_ = [("layout_version", u32), ("code", u32), ("sequence", u32), ("body", CommandBody)]


class CommandReply(_Payload):
    _fields_ = [("sequence", u32), ("accepted", u8), ("mode", u8), ("reason_len", u16),
                ("reason", u8 * 120)]

    def reason_text(self):
        return bytes(self.reason[:min(self.reason_len, 120)]).decode("utf-8", "replace")


for _t, _size in ((JointSnapshot, 64), (GaitSnapshot, 16), (LoopSnapshot, 48), (BusSnapshot, 56),
                  (LimitsSnapshot, 24), (NavSnapshot, 104), (GuideSnapshot, 48), (SensorEntry, 40),
                  (StateSnapshot, 2624), (SwimBody, 16), (HoldBody, 12), (SwimHoldBody, 28),
                  (WaypointBody, 16), (FollowBody, 16), (CommandRequest, 40),
                  (CommandReply, 128)):
    assert ctypes.sizeof(_t) == _size, (_t.__name__, ctypes.sizeof(_t))


def _copy(ptr, cls):
    """Copies a payload out of shared memory, so that its sample can be released."""
    return cls.from_buffer_copy(cls.from_address(ptr))


class Client:
    """One operator tool: a node, a state subscriber, a command client."""

    def __init__(self, prefix="anguilla", name="anguilla-py"):
        builder = iox2.NodeBuilder.new().name(iox2.NodeName.new(name))
        self.node = builder.create(iox2.ServiceType.Ipc)
        self.prefix, self.opened = prefix, {}  # opened: service -> how open() succeeded
        state = self._open("state", lambda b: b.publish_subscribe(StateSnapshot),
                           history_size=1, subscriber_max_buffer_size=2, enable_safe_overflow=True,
                           max_subscribers=MAX_TOOLS, max_publishers=1, max_nodes=MAX_NODES)
        command = self._open("command", lambda b: b.request_response(CommandRequest, CommandReply),
                             max_clients=MAX_TOOLS, max_servers=1,
                             max_active_requests_per_client=MAX_REQUESTS_PER_CLIENT,
                             enable_safe_overflow_for_requests=True, max_nodes=MAX_NODES)
        state_ready = self._open("state-ready", lambda b: b.event(),
                                 max_notifiers=1, max_listeners=MAX_TOOLS, max_nodes=MAX_NODES)
        command_ready = self._open("command-ready", lambda b: b.event(),
                                   max_notifiers=MAX_TOOLS, max_listeners=1, max_nodes=MAX_NODES)
        self.subscriber = state.subscriber_builder().create()
        self.listener = state_ready.listener_builder().create()
        self.client = command.client_builder().create()
        self.notifier = command_ready.notifier_builder().create()
        self.sequence, self.latest = 0, None

    def _open(self, leaf, pattern, **qos):
        """Opens (never creates) a service: with the daemon's QoS settings, else plainly."""
        def builder():
            return pattern(self.node.service_builder(iox2.ServiceName.new(f"{self.prefix}/{leaf}")))
        try:
            b = builder()
            for setting, value in qos.items():
                b = getattr(b, setting)(value)
            factory, self.opened[leaf] = b.open(), "with the daemon's QoS"
        except Exception as e:  # noqa: BLE001 - e.g. RequestResponseOpenError
            factory, self.opened[leaf] = builder().open(), f"plainly (with QoS: {e!r})"
        return factory

    @property
    def id(self):
        """This client port's unique id, as the daemon names the holder (u128), or None."""
        port_id = getattr(self.client, "id", None)  # a property in iceoryx2 0.10
        return getattr(port_id, "value", None)

    def state(self):
        """The latest state received (draining the buffer), or the last one seen."""
        while (sample := self.subscriber.receive()) is not None:
            self.latest = _copy(sample.payload_ptr, StateSnapshot)
            sample.delete()
        return self.latest

    def wait_state(self, pred=lambda s: True, timeout=2.0, keep_alive_s=None):
        """Waits for a state satisfying `pred`; sends keep-alives while waiting if asked."""
        deadline, last_sent = time.monotonic() + timeout, time.monotonic()
        while True:
            s = self.state()
            if s is not None and pred(s):
                return s
            now = time.monotonic()
            if now >= deadline:
                return None
            if keep_alive_s is not None and now - last_sent >= keep_alive_s:
                if not (r := self.request(KEEP_ALIVE)).accepted:
                    raise RuntimeError(f"keep-alive refused: {r.reason_text()}")
                last_sent = now
            self.listener.timed_wait(iox2.Duration.from_secs_f64(min(0.05, deadline - now)))

    def request(self, code, amplitude=0.0, frequency=0.0, turn=0.0, pitch=0.0, timeout=1.0):
        """Sends one command and returns its CommandReply (TimeoutError if none)."""
        self.sequence += 1
        req = CommandRequest(LAYOUT_VERSION, code, self.sequence)
        if code == SWIM:
            req.body.swim = SwimBody(amplitude, frequency, turn, pitch)
        pending = self.client.send_copy(req)
        self.notifier.notify()
        deadline = time.monotonic() + timeout
        try:
            while time.monotonic() < deadline:
                if (response := pending.receive()) is not None:
                    reply = _copy(response.payload_ptr, CommandReply)
                    response.delete()
                    if reply.sequence != req.sequence:
                        raise RuntimeError(f"reply to #{reply.sequence}, expected #{req.sequence}")
                    return reply
                time.sleep(0.001)
            raise TimeoutError(f"no reply to command {code} (#{req.sequence}) within {timeout} s")
        finally:
            pending.delete()  # frees the active request slot at once


class Failed(Exception):
    """An unexpected outcome of the scenario."""


def scenario(c, swim_seconds):
    def send(name, code, verbose=True, **gait):
        r = c.request(code, **gait)
        if not r.accepted:
            raise Failed(f"{name} refused (mode {MODES[r.mode]}): {r.reason_text()}")
        if verbose:
            print(f"{name}: accepted, mode {MODES[r.mode]}")

    def expect(mode, timeout, keep_alive_s=None):
        s = c.wait_state(lambda s: s.mode == mode, timeout, keep_alive_s)
        if s is None:
            raise Failed(f"mode not {MODES[mode]} after {timeout} s (is {MODES[c.latest.mode]})")
        print(f"state: mode {MODES[s.mode]} (cause {s.cause})")
        return s

    s = c.wait_state(timeout=2.0)
    if s is None:
        raise Failed("no state received within 2 s")
    if s.layout_version != LAYOUT_VERSION:
        raise Failed(f"daemon layout version {s.layout_version}, this client's {LAYOUT_VERSION}")
    lim = s.limits
    print(f"state #{s.sequence}: mode {MODES[s.mode]}, {s.joint_count} joints, daemon pid "
          f"{lim.daemon_pid}, command timeout {lim.command_timeout_ms} ms")
    resend = lim.command_timeout_ms / 4000  # seconds between commands while swimming

    send("take-control", TAKE_CONTROL)
    if c.id is None:
        print("holder check skipped: this iceoryx2 binding does not expose Client.id")
    elif c.wait_state(lambda s: s.holder() == c.id, 1.0) is None:
        raise Failed(f"holder {c.latest.holder():#x} is not this client port {c.id:#x}")
    else:
        print(f"holder is this client port ({c.id:#x})")

    send("enable", ENABLE)
    s = expect(READY, 5.0, keep_alive_s=resend)
    t0, seen, silent_stops, n = time.monotonic(), set(), s.operator_silent_stops, 0
    while time.monotonic() - t0 < swim_seconds:
        send("swim", SWIM, n == 0, amplitude=0.5, frequency=1.0)
        n += 1
        c.wait_state(lambda s: seen.add(s.mode), resend)  # only collects modes for `resend` s
    s = c.state()
    print(f"swam {time.monotonic() - t0:.1f} s, {n} swim commands: mode {MODES[s.mode]}, "
          f"gait {s.gait_actual.amplitude:.2f} at {s.gait_actual.frequency:.2f} Hz")
    if SWIMMING not in seen or s.mode != SWIMMING:
        raise Failed(f"mode never became or did not stay swimming (is {MODES[s.mode]})")
    if s.operator_silent_stops != silent_stops:
        raise Failed("the daemon stopped the swim for operator silence")

    send("e-stop", ESTOP)
    expect(E_STOP, 2.0)
    send("reset", RESET)
    expect(IDLE, 2.0)
    send("release-control", RELEASE_CONTROL)
    if c.wait_state(lambda s: s.holder() == 0, 1.0) is None:
        raise Failed("control still held after release-control")
    print("released: nobody holds control")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--prefix", default="anguilla", help="the daemon's [ipc] prefix")
    ap.add_argument("--swim-seconds", type=float, default=2.0)
    args = ap.parse_args(argv)
    iox2.set_log_level_from_env_or(iox2.LogLevel.Error)  # Warn says "No config file was loaded"
    try:
        c = Client(args.prefix)
    except Exception as e:  # noqa: BLE001 - iceoryx2's *OpenError
        print(f"no anguilla daemon serves '{args.prefix}': {e!r}", file=sys.stderr)
        return 2
    print("\n".join(f"opened {args.prefix}/{leaf} {how}" for leaf, how in c.opened.items()))
    try:
        scenario(c, args.swim_seconds)
    except Exception as e:  # noqa: BLE001 - Failed, TimeoutError, iceoryx2's errors
        print(f"FAILED: {e}" if isinstance(e, Failed) else f"FAILED: {e!r}", file=sys.stderr)
        return 1
    print("OK")
    return 0


if __name__ == "__main__":
    sys.exit(main())
