#!/usr/bin/env python3
"""A Foxglove WebSocket subscriber written from the published protocol
(github.com/foxglove/ws-protocol, docs/spec.md; the Foxglove SDK serves it
as subprotocol "foxglove.sdk.v1", the v1 messages under a new name), not
from anguilla's code.

    foxglove_client.py ws://127.0.0.1:PORT SECONDS

Connects, expects serverInfo and an advertise of anguilla's five channels
(JSON encoded, with schemas), subscribes to all of them, decodes the binary
Message Data frames (opcode 1: u32 subscription id, u64 log time, payload)
for SECONDS, and checks that every channel delivered parseable JSON. Prints
the counts; exits 1 naming what is wrong.
"""

import asyncio
import json
import struct
import sys

import websockets

WANT = {"/anguilla/state", "/anguilla/joints", "/tf", "/body", "/anguilla/sensors"}


def fail(why):
    print(f"foxglove_client: {why}")
    sys.exit(1)


async def main(url, seconds):
    async with websockets.connect(url, subprotocols=["foxglove.sdk.v1"]) as ws:
        if ws.subprotocol != "foxglove.sdk.v1":
            fail(f"subprotocol {ws.subprotocol!r}")
        channels, info = {}, None
        # serverInfo, then advertise (possibly more than one).
        while not WANT <= {c["topic"] for c in channels.values()}:
            msg = json.loads(await asyncio.wait_for(ws.recv(), 10))
            if msg["op"] == "serverInfo":
                info = msg
            elif msg["op"] == "advertise":
                for c in msg["channels"]:
                    channels[c["id"]] = c
        if info is None:
            fail("no serverInfo")
        for c in channels.values():
            if c["encoding"] != "json" or not c.get("schemaName"):
                fail(f"channel {c['topic']}: encoding {c['encoding']}, schema {c.get('schemaName')}")
        subs = {i + 1: cid for i, cid in enumerate(channels)}
        await ws.send(json.dumps({
            "op": "subscribe",
            "subscriptions": [{"id": sid, "channelId": cid} for sid, cid in subs.items()],
        }))
        counts, last_time = {}, {}
        loop = asyncio.get_running_loop()
        end = loop.time() + seconds
        while loop.time() < end:
            try:
                msg = await asyncio.wait_for(ws.recv(), max(0.05, end - loop.time()))
            except asyncio.TimeoutError:
                break
            if isinstance(msg, str):
                continue
            if msg[0] != 1:
                continue
            sid, t = struct.unpack_from("<IQ", msg, 1)
            topic = channels[subs[sid]]["topic"]
            body = json.loads(msg[13:])
            if topic == "/body" and not body["entities"][0]["spheres"]:
                fail("/body without links")
            if topic == "/anguilla/sensors":
                # check-foxglove's daemon has a head sensor and a tail IMU.
                kinds = [s["kind"] for s in body["sensors"]]
                if kinds != ["head-nav", "tail-imu"]:
                    fail(f"/anguilla/sensors lists {kinds}, expected head-nav, tail-imu")
            if t < last_time.get(topic, 0):
                fail(f"{topic}: time goes back")
            last_time[topic] = t
            counts[topic] = counts.get(topic, 0) + 1
        missing = WANT - set(counts)
        if missing:
            fail(f"no message on {sorted(missing)} in {seconds} s (got {counts})")
        print(f"foxglove_client: {info.get('name')}: {counts}")


if __name__ == "__main__":
    asyncio.run(main(sys.argv[1], float(sys.argv[2])))
