#!/usr/bin/env python3
"""Operator commands from a Foxglove client, written from the published
Foxglove WebSocket protocol (github.com/foxglove/ws-protocol, docs/spec.md:
the clientPublish capability, "advertise" from the client, then binary
Client Message Data frames: opcode 1, u32 client channel id, payload),
not from anguilla's code.

    foxglove_commands.py ws://127.0.0.1:PORT drive     # [foxglove] commands = true
    foxglove_commands.py ws://127.0.0.1:PORT readonly  # the default

drive: advertises /anguilla/command, takes control, enables, swims while it
publishes the swim at 5 Hz, then goes silent: the daemon must stop the swim
on its own (the deadman holds for Foxglove clients); then an E-stop. Every
step is read back from /anguilla/state and /anguilla/command_reply.
readonly: the server must not offer clientPublish, and a command published
anyway must change nothing. Exits 1 naming what is wrong.
"""

import asyncio
import json
import struct
import sys

import websockets


def fail(why):
    print(f"foxglove_commands: {why}")
    sys.exit(1)


class View:
    def __init__(self, ws):
        self.ws, self.channels, self.info = ws, {}, None
        self.mode = self.cause = None
        self.replies = []

    async def start(self, want):
        while not want <= {c["topic"] for c in self.channels.values()}:
            msg = json.loads(await asyncio.wait_for(self.ws.recv(), 10))
            if msg["op"] == "serverInfo":
                self.info = msg
            elif msg["op"] == "advertise":
                for c in msg["channels"]:
                    self.channels[c["id"]] = c
        self.subs = {i + 1: cid for i, cid in enumerate(self.channels)
                     if self.channels[cid]["topic"] in want}
        await self.ws.send(json.dumps({"op": "subscribe", "subscriptions": [
            {"id": sid, "channelId": cid} for sid, cid in self.subs.items()]}))

    async def pump(self, seconds):
        loop = asyncio.get_running_loop()
        end = loop.time() + seconds
        while loop.time() < end:
            try:
                msg = await asyncio.wait_for(self.ws.recv(), max(0.01, end - loop.time()))
            except asyncio.TimeoutError:
                return
            if isinstance(msg, str) or msg[0] != 1:
                continue
            sid, _ = struct.unpack_from("<IQ", msg, 1)
            topic = self.channels[self.subs[sid]]["topic"]
            body = json.loads(msg[13:])
            if topic == "/anguilla/state":
                self.mode, self.cause = body["mode"], body["cause"]
            elif topic == "/anguilla/command_reply":
                self.replies.append(body)

    async def until(self, what, pred, seconds):
        loop = asyncio.get_running_loop()
        end = loop.time() + seconds
        while loop.time() < end:
            await self.pump(0.05)
            if pred():
                return
        fail(f"{what}: not within {seconds} s (mode {self.mode}, cause {self.cause}, "
             f"replies {self.replies[-3:]})")


async def publish(ws, command, **fields):
    await ws.send(b"\x01" + struct.pack("<I", 7) + json.dumps({"command": command, **fields}).encode())


async def main(url, role):
    async with websockets.connect(url, subprotocols=["foxglove.sdk.v1"]) as ws:
        v = View(ws)
        await v.start({"/anguilla/state"} | ({"/anguilla/command_reply"} if role == "drive" else set()))
        caps = v.info.get("capabilities", [])
        await ws.send(json.dumps({"op": "advertise", "channels": [{
            "id": 7, "topic": "/anguilla/command", "encoding": "json",
            "schemaName": "anguilla.Command"}]}))
        if role == "readonly":
            if "clientPublish" in caps:
                fail(f"a read-only server offers clientPublish: {caps}")
            await v.until("a state", lambda: v.mode is not None, 5)
            before = v.mode
            await publish(ws, "take-control")
            await publish(ws, "enable")
            await v.pump(1.5)
            if v.mode != before:
                fail(f"a read-only view obeyed: mode {before} -> {v.mode}")
            print(f"foxglove_commands: read-only: no clientPublish, mode stays {v.mode}")
            return
        if "clientPublish" not in caps:
            fail(f"commands enabled but no clientPublish: {caps}")
        await publish(ws, "take-control")
        await v.until("take-control accepted", lambda: any(
            r["command"] == "take-control" and r["accepted"] for r in v.replies), 5)
        await publish(ws, "swim", amplitude=0.5)
        await v.until("a malformed command refused", lambda: any(
            "frequency" in r["reason"] and not r["accepted"] for r in v.replies), 5)
        await publish(ws, "enable")
        await v.until("ready", lambda: v.mode == "ready", 10)
        loop = asyncio.get_running_loop()
        end = loop.time() + 2.0
        while loop.time() < end:
            await publish(ws, "swim", amplitude=0.5, frequency=1.0)
            await v.pump(0.2)
        if v.mode != "swimming":
            fail(f"publishing the swim at 5 Hz: mode {v.mode}")
        # Silence: the daemon's deadman stops the swim by itself.
        await v.until("the silent client's swim stopped", lambda: v.mode in ("stopping", "ready"), 3)
        silent_cause = v.cause
        await publish(ws, "e-stop")
        await v.until("e-stop", lambda: v.mode == "e-stop", 3)
        print(f"foxglove_commands: took control, enabled, swam 2 s, silence stopped it "
              f"({silent_cause}), e-stop latched; {len(v.replies)} replies")


if __name__ == "__main__":
    asyncio.run(main(sys.argv[1], sys.argv[2]))
