#!/usr/bin/env python3
"""Reads a daemon's MCAP recording with the independent Python `mcap` reader.

    check_mcap.py FILE --finished   a controlled stop: a summary, the five
                                    channels with JSON schemas, equal counts
                                    on the data channels, monotonic times,
                                    and messages that parse as JSON
    check_mcap.py FILE --killed     a killed daemon: the messages up to the
                                    last complete chunk read, no summary

Prints one line of figures; exits 1 naming what is wrong.
"""

import json
import sys

from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.records import Channel, Message, Schema
from mcap.stream_reader import StreamReader

TOPICS = {
    "/anguilla/state": "anguilla.State",
    "/anguilla/joints": "anguilla.Joints",
    "/log": "foxglove.Log",
    "/tf": "foxglove.FrameTransforms",
    "/body": "foxglove.SceneUpdate",
}
DATA = ["/anguilla/state", "/anguilla/joints", "/tf", "/body"]


def fail(why):
    print(f"check_mcap: {why}")
    sys.exit(1)


def scan(messages):
    """Counts per topic, monotonic per topic, schemas seen; stops at a cut."""
    counts, last, schemas, cut = {}, {}, {}, None
    try:
        for schema, channel, message in messages:
            t = channel.topic
            if message.log_time < last.get(t, 0):
                fail(f"{t}: log time goes back at message {counts.get(t, 0)}")
            last[t] = message.log_time
            counts[t] = counts.get(t, 0) + 1
            schemas[t] = (schema.name, schema.encoding, channel.message_encoding)
            body = json.loads(message.data)
            if t == "/body" and not body["entities"][0]["spheres"]:
                fail("/body: a scene without links")
    except (McapError, EOFError, ValueError) as e:
        cut = type(e).__name__
    return counts, schemas, cut


def stream(f):
    """(schema, channel, message) from the records in file order, as far as
    they go (a killed writer leaves its last chunk unfinished)."""
    schemas, channels = {}, {}
    for r in StreamReader(f, skip_magic=False).records:
        if isinstance(r, Schema):
            schemas[r.id] = r
        elif isinstance(r, Channel):
            channels[r.id] = r
        elif isinstance(r, Message):
            c = channels[r.channel_id]
            yield schemas[c.schema_id], c, r


def main():
    path, mode = sys.argv[1], sys.argv[2]
    with open(path, "rb") as f:
        if mode == "--finished":
            reader = make_reader(f)
            summary = reader.get_summary()
            if summary is None:
                fail("no summary in a file the daemon finished")
            counts, schemas, cut = scan(reader.iter_messages(log_time_order=False))
            if cut:
                fail(f"reading stopped early: {cut}")
            if set(schemas) != set(TOPICS):
                fail(f"channels {sorted(schemas)}, expected {sorted(TOPICS)}")
            for t, name in TOPICS.items():
                if schemas[t] != (name, "jsonschema", "json"):
                    fail(f"{t}: schema {schemas[t]}, expected ({name}, jsonschema, json)")
            n = {counts[t] for t in DATA}
            if len(n) != 1:
                fail(f"data channels differ in count: { {t: counts[t] for t in DATA} }")
            stats = summary.statistics
            if stats is None or stats.message_count != sum(counts.values()):
                fail("the summary's statistics do not count the messages read")
            print(f"check_mcap: finished: {counts} ({len(summary.chunk_indexes)} chunks indexed)")
        else:
            counts, schemas, cut = scan(stream(f))
            if not counts.get("/anguilla/state"):
                fail(f"nothing readable in a killed daemon's file ({cut})")
            print(f"check_mcap: killed: {counts} read before the cut ({cut})")


if __name__ == "__main__":
    main()
