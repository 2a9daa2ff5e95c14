#!/usr/bin/env python3
"""Reads a daemon's MCAP recording with the independent Python `mcap` reader.

    check_mcap.py FILE --finished   a controlled stop: a summary, the five
                                    channels with JSON schemas, equal counts
                                    on the data channels, monotonic times,
                                    and messages that parse as JSON
    check_mcap.py FILE --killed     a killed daemon: the messages up to the
                                    last complete chunk read, no summary

In both, every message of every JSON channel is validated against its
channel's JSON Schema with the independent Python `jsonschema` package
(the schema checked first against its own dialect, draft 2020-12).

Prints the figures (and the messages validated per channel); exits 1 naming
what is wrong: a message that fails names its channel, its index on the
channel and jsonschema's error.
"""

import json
import sys

import jsonschema

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
    "/anguilla/sensors": "anguilla.Sensors",
    # The built-in simulated robot's ground truth (anguilla run records it
    # when it drives that robot, as here).
    "/sim/truth": "anguilla.SimTruth",
}
DATA = ["/anguilla/state", "/anguilla/joints", "/tf", "/body", "/anguilla/sensors"]


def fail(why):
    print(f"check_mcap: {why}")
    sys.exit(1)


DIALECT = "https://json-schema.org/draft/2020-12/schema"


def validator(schema, channel):
    """The jsonschema validator of a channel's schema record, the schema
    itself checked against its dialect first."""
    if schema.encoding != "jsonschema" or channel.message_encoding != "json":
        return None
    try:
        s = json.loads(schema.data)
    except ValueError as e:
        fail(f"{channel.topic}: schema {schema.name} is not JSON: {e}")
    if s.get("$schema") != DIALECT:
        fail(f"{channel.topic}: schema {schema.name} has $schema {s.get('$schema')!r}, "
             f"expected {DIALECT}")
    cls = jsonschema.validators.validator_for(s)
    try:
        cls.check_schema(s)
    except jsonschema.exceptions.SchemaError as e:
        fail(f"{channel.topic}: schema {schema.name} is not a valid JSON Schema: {e.message}")
    return cls(s)


def scan(messages):
    """Counts per topic, monotonic per topic, schemas seen, messages
    validated per topic; stops at a cut."""
    counts, last, schemas, validated, validators, cut = {}, {}, {}, {}, {}, None
    try:
        for schema, channel, message in messages:
            t = channel.topic
            i = counts.get(t, 0)
            if message.log_time < last.get(t, 0):
                fail(f"{t}: log time goes back at message {i}")
            last[t] = message.log_time
            counts[t] = i + 1
            schemas[t] = (schema.name, schema.encoding, channel.message_encoding)
            body = json.loads(message.data)
            if channel.id not in validators:
                validators[channel.id] = validator(schema, channel)
            v = validators[channel.id]
            if v is not None:
                error = jsonschema.exceptions.best_match(v.iter_errors(body))
                if error is not None:
                    where = "/".join(str(p) for p in error.absolute_path) or "(message)"
                    fail(f"{t}: message {i} does not match schema {schema.name}: "
                         f"at {where}: {error.message}")
                validated[t] = validated.get(t, 0) + 1
            if t == "/body" and not body["entities"][0]["spheres"]:
                fail("/body: a scene without links")
            if t == "/anguilla/sensors":
                # The recording's daemon has a head sensor and a tail IMU.
                kinds = [s["kind"] for s in body["sensors"]]
                if kinds != ["head-nav", "tail-imu"]:
                    fail(f"/anguilla/sensors: message {i} lists {kinds}, expected head-nav, tail-imu")
    except (McapError, EOFError, ValueError) as e:
        cut = type(e).__name__
    return counts, schemas, validated, cut


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
            counts, schemas, validated, cut = scan(reader.iter_messages(log_time_order=False))
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
            if validated != counts:
                fail(f"validated {validated}, read {counts}: a JSON channel went unchecked")
            print(f"check_mcap: finished: {counts} ({len(summary.chunk_indexes)} chunks indexed)")
            print(f"check_mcap: finished: validated against their JSON Schemas: {validated}")
        else:
            counts, schemas, validated, cut = scan(stream(f))
            if not counts.get("/anguilla/state"):
                fail(f"nothing readable in a killed daemon's file ({cut})")
            if validated != counts:
                fail(f"validated {validated}, read {counts}: a JSON channel went unchecked")
            print(f"check_mcap: killed: {counts} read before the cut ({cut})")
            print(f"check_mcap: killed: validated against their JSON Schemas: {validated}")


if __name__ == "__main__":
    main()
