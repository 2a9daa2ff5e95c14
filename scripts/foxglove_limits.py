#!/usr/bin/env python3
"""The Foxglove view's limits, tried from outside with Python `websockets`.

    foxglove_limits.py ws://127.0.0.1:PORT PID MAX CHURN

PID is the `anguilla foxglove` process, started with [foxglove]
max-clients = MAX and a short subscribe-timeout. Checks, in order:
- MAX viewers that subscribe are served; one more is refused with HTTP 503;
  when one leaves, the next is served;
- a viewer that connects and subscribes to nothing is closed by the server;
- CHURN more viewers (MAX at a time: connect, subscribe, read one message,
  leave), after which the process's resident memory is back near where it
  was before them (printed; fails above 64 MiB more).
Exits 1 naming what is wrong.
"""

import asyncio
import json
import sys

import websockets

PROTO = ["foxglove.sdk.v1"]
# How many times a viewer asked again after a 503 while the gate freed places.
asked_again = 0
STATE_TOPIC = "/anguilla/state"


def fail(why):
    print(f"foxglove_limits: {why}")
    sys.exit(1)


def rss_kib(pid):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    fail(f"no VmRSS for pid {pid}")


def threads(pid):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("Threads:"):
                return int(line.split()[1])
    return -1


async def viewer(url):
    """Connects and subscribes to the robot's state, sent every period.

    By topic, not by place: the server advertises its channels in the
    order of a hash map, which changes from one process to the next, and
    the first may be /log, which is quiet for minutes."""
    ws = await websockets.connect(url, subprotocols=PROTO, open_timeout=30)
    channel = None
    while channel is None:
        msg = json.loads(await asyncio.wait_for(ws.recv(), 30))
        if msg["op"] == "advertise":
            for c in msg["channels"]:
                if c["topic"] == STATE_TOPIC:
                    channel = c["id"]
    await ws.send(json.dumps({
        "op": "subscribe", "subscriptions": [{"id": 1, "channelId": channel}],
    }))
    return ws


async def admitted_viewer(url):
    """A viewer, asking again while the gate still counts the last batch.

    A closed viewer's place is freed when the gate's two threads for it
    see the close, which on a loaded machine can come after the client
    has already opened the next one: a 503 then means "not yet", and the
    viewer asks again (up to 30 s) instead of failing the check."""
    global asked_again
    for _ in range(300):
        try:
            return await viewer(url)
        except Exception as e:
            response = getattr(e, "response", None)
            if getattr(response, "status_code", None) != 503 and getattr(e, "status_code", None) != 503:
                raise
            asked_again += 1
            await asyncio.sleep(0.1)
    fail("the gate still refused a viewer 30 s after the last batch left")


async def refused(url):
    """The status of a refused connection, or None if it was served."""
    try:
        ws = await websockets.connect(url, subprotocols=PROTO, open_timeout=30)
    except Exception as e:  # InvalidStatus (websockets >= 14) or InvalidStatusCode
        response = getattr(e, "response", None)
        status = getattr(response, "status_code", None) or getattr(e, "status_code", None)
        return status if status is not None else repr(e)
    await ws.close()
    return None


async def main(url, pid, most, churn):
    before = rss_kib(pid)
    inside = [await viewer(url) for _ in range(most)]
    status = await refused(url)
    if status != 503:
        fail(f"viewer {most + 1} of {most}: expected HTTP 503, got {status}")
    await inside.pop().close()
    # The gate frees the place once it sees the close; ask until it has.
    inside.append(await admitted_viewer(url))
    for ws in inside:
        await ws.close()
    print(f"foxglove_limits: {most} viewers served, viewer {most + 1} refused (HTTP 503), "
          "a freed place taken")

    # One that subscribes to nothing is closed by the server.
    ws = await websockets.connect(url, subprotocols=PROTO, open_timeout=30)
    try:
        while True:
            await asyncio.wait_for(ws.recv(), 120)
    except websockets.exceptions.ConnectionClosed:
        print("foxglove_limits: a viewer that subscribed to nothing was closed")
    except asyncio.TimeoutError:
        fail("a viewer that subscribed to nothing was still open after 120 s")

    peak = before
    done = 0
    while done < churn:
        batch = await asyncio.gather(*[admitted_viewer(url) for _ in range(min(most, churn - done))])
        for ws in batch:
            await asyncio.wait_for(ws.recv(), 30)
        peak = max(peak, rss_kib(pid))
        await asyncio.gather(*[ws.close() for ws in batch])
        done += len(batch)
    # Wait until the gate's threads for them are gone, then read the memory.
    for _ in range(600):
        if threads(pid) <= base_threads:
            break
        await asyncio.sleep(0.1)
    after = rss_kib(pid)
    print(f"foxglove_limits: {churn} more viewers, {most} at a time: resident "
          f"{before / 1024:.1f} MiB before, {peak / 1024:.1f} MiB at most, "
          f"{after / 1024:.1f} MiB after; threads {threads(pid)} (idle {base_threads}); "
          f"{asked_again} connections asked again after a 503 while places were freed")
    # 64 MiB: the view idles at about 26 MiB and grew by 2-3 MiB after 400
    # or 2,000 viewers here; without the gate, 2,000 connections left it at
    # 225 MB. The bound tells a leak per viewer from the allocator's slack.
    if after - before > 64 * 1024:
        fail(f"resident memory grew by {(after - before) / 1024:.1f} MiB after the viewers left")


if __name__ == "__main__":
    if len(sys.argv) != 5:
        fail("usage: foxglove_limits.py ws://HOST:PORT PID MAX CHURN")
    pid = int(sys.argv[2])
    base_threads = threads(pid)
    asyncio.run(main(sys.argv[1], pid, int(sys.argv[3]), int(sys.argv[4])))
