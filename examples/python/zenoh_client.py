#!/usr/bin/env python3
"""A remote anguilla client over Zenoh, with another Zenoh implementation.

Written from docs/remote.md (the keys and messages of `anguilla link`) and
docs/ipc.md (the payloads, whose ctypes twins are in anguilla_client.py),
with the `eclipse-zenoh` package from PyPI (1.10.2: the Rust crate's
version). CI runs it against a daemon and a link on loopback
(scripts/check-link). It reads COUNT states on P/state, then opens a
command session (a secret token, a hello), takes control, checks that the
daemon names it as the holder, and releases control. Exit 0 when all
holds, 1 otherwise.
"""

import argparse
import ctypes
import os
import struct
import sys
import time

import zenoh

from anguilla_client import (CommandReply, CommandRequest, LAYOUT_VERSION, MODES,
                             RELEASE_CONTROL, StateSnapshot, TAKE_CONTROL)


def session(endpoint):
    cfg = zenoh.Config()
    cfg.insert_json5("mode", '"client"')
    cfg.insert_json5("connect/endpoints", f'["{endpoint}"]')
    cfg.insert_json5("scouting/multicast/enabled", "false")
    return zenoh.open(cfg)


def close(z):
    """Closes a session now, saying so if that times out (a busy machine):
    left to the garbage collector, zenoh-python's close would panic in a
    destructor instead."""
    try:
        z.close()
    except zenoh.ZError as e:
        print(f"(closing the Zenoh session: {e})", file=sys.stderr)


def states(z, prefix, count, timeout):
    sub = z.declare_subscriber(f"{prefix}/state")
    got, end = [], time.monotonic() + timeout
    while len(got) < count and time.monotonic() < end:
        sample = sub.try_recv()
        if sample is None:
            time.sleep(0.005)
            continue
        data = sample.payload.to_bytes()
        if len(data) != ctypes.sizeof(StateSnapshot):
            raise SystemExit(f"a state of {len(data)} bytes, expected {ctypes.sizeof(StateSnapshot)}")
        got.append(StateSnapshot.from_buffer_copy(data))
    sub.undeclare()
    return got


SYNC = {}  # the last hello's answer: epoch, the link's clock (ms), when it came


def stamp():
    """A command's stamp: the link's epoch and its clock now, estimated
    from the last hello (docs/remote.md); None before the first hello."""
    if not SYNC:
        return None
    now = SYNC["link_ms"] + int((time.monotonic() - SYNC["at"]) * 1000)
    return struct.pack("<Qq", SYNC["epoch"], now)


def hello(z, key):
    """Opens (or keeps) the session: the client id; records the clock."""
    ok, data = query(z, key)
    assert ok and len(data) == 32, f"hello: {data!r}"
    epoch, link_ms = struct.unpack_from("<Qq", data, 16)
    SYNC.update(epoch=epoch, link_ms=link_ms, at=time.monotonic())
    return int.from_bytes(data[:16], "little")


def query(z, key, payload=None, attachment=None):
    """The one reply to a query: (ok, bytes)."""
    for r in z.get(key, payload=payload, attachment=attachment, timeout=2.0):
        if r.ok is not None:
            return True, r.ok.payload.to_bytes()
        return False, r.err.payload.to_bytes()
    return False, b"no reply"


def command(z, key, code, seq):
    req = CommandRequest(layout_version=LAYOUT_VERSION, code=code, sequence=seq)
    ok, data = query(z, key, bytes(req), stamp())
    if not ok:
        raise SystemExit(f"command {code}: the link said {data.decode(errors='replace')}")
    client_id = int.from_bytes(data[:16], "little")
    return client_id, CommandReply.from_buffer_copy(data[16:])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("endpoint", help="the link's endpoint, e.g. unixsock-stream//tmp/anguilla/PREFIX/link/sock "
                    "(the local link) or tls/robot.local:7447")
    ap.add_argument("--prefix", default="anguilla")
    ap.add_argument("--count", type=int, default=20)
    a = ap.parse_args(argv)
    z = session(a.endpoint)
    got = states(z, a.prefix, a.count, 10.0)
    if len(got) < a.count:
        print(f"only {len(got)} of {a.count} states within 10 s", file=sys.stderr)
        return 1
    seqs = [s.sequence for s in got]
    assert all(s.layout_version == LAYOUT_VERSION for s in got), "layout version"
    assert seqs == sorted(seqs) and len(set(seqs)) == len(seqs), f"sequences {seqs}"
    span = (got[-1].time_ns - got[0].time_ns) / 1e9
    print(f"{len(got)} states, sequence {seqs[0]}..{seqs[-1]}, {len(got) / max(span, 1e-9):.0f} "
          f"states/s of daemon time, mode {MODES[got[-1].mode]}, {got[-1].joint_count} joints")
    key = f"{a.prefix}/command/{os.urandom(16).hex()}"
    me = hello(z, key)
    client_id, r = command(z, key, TAKE_CONTROL, 1)
    assert client_id == me, "the same client for the same token"
    assert r.accepted == 1, f"take control refused: {r.reason_text()}"
    sub = z.declare_subscriber(f"{a.prefix}/state")
    end = time.monotonic() + 3.0
    holder = None
    while time.monotonic() < end and holder != me:
        s = sub.try_recv()
        if s is None:
            time.sleep(0.005)
            continue
        holder = StateSnapshot.from_buffer_copy(s.payload.to_bytes()).holder()
    assert holder == me, f"holder {holder} is not this client {me}"
    print(f"took control as client {me:032x}; the daemon names it as the holder")
    _, r = command(z, key, RELEASE_CONTROL, 2)
    assert r.accepted == 1, f"release refused: {r.reason_text()}"
    ok, text = query(z, f"{a.prefix}/command/not-a-token", bytes(40))
    assert not ok, "a malformed key was served"
    print(f"a malformed key is refused: {text.decode(errors='replace')}")
    close(z)
    return 0


if __name__ == "__main__":
    sys.exit(main())
