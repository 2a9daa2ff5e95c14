#!/usr/bin/env python3
"""Reads a recorded session's MCAP file: the head's heading and depth over time.

    read_mcap.py SESSION.mcap [--every N]

Written from docs/data.md alone, with the `mcap` package from PyPI
(`pip install mcap`). Prints one line per Nth `/anguilla/state` message (time
in s since the controller started, mode, heading, depth, what the autopilot
holds), then the log lines of `/log`, then a summary line. CI runs it on a
daemon's recording (scripts/check-mcap). Exits 1 if the file has no state.
"""

import argparse
import json
import sys

from mcap.reader import make_reader


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("path", help="a session.mcap")
    ap.add_argument("--every", type=int, default=10, metavar="N",
                    help="print every Nth state (default 10)")
    args = ap.parse_args()

    states, logs = [], []
    with open(args.path, "rb") as f:
        # Messages in log-time order; the log time is the daemon's clock
        # (ns since the controller started), the same as the state's time_ns.
        for _schema, channel, message in make_reader(f).iter_messages(
                topics=["/anguilla/state", "/log"]):
            body = json.loads(message.data)
            if channel.topic == "/anguilla/state":
                states.append((message.log_time, body))
            else:
                logs.append((message.log_time, body["level"], body["message"]))

    if not states:
        print(f"{args.path}: no /anguilla/state message")
        sys.exit(1)
    print(f"{'t (s)':>8}  {'mode':<9} {'heading (deg)':>13} {'depth (m)':>9}  hold")
    holds = {0: "manual", 1: "heading", 2: "depth", 3: "heading+depth"}
    for k, (t, s) in enumerate(states):
        if k % args.every:
            continue
        nav = s["nav"]
        # A float that is not finite is recorded as null.
        heading = "-" if nav["heading_deg"] is None else f"{nav['heading_deg']:.1f}"
        depth = "-" if nav["depth_m"] is None else f"{nav['depth_m']:.3f}"
        print(f"{t / 1e9:8.2f}  {s['mode']:<9} {heading:>13} {depth:>9}  {holds[nav['hold']]}")
    for t, level, text in logs:
        print(f"{t / 1e9:8.2f}  log level {level}: {text}")
    first, last = states[0][0] / 1e9, states[-1][0] / 1e9
    sensor = states[-1][1]["nav"]["sensor"]
    print(f"read_mcap: {len(states)} states from {first:.2f} s to {last:.2f} s, "
          f"{len(logs)} log lines, head sensor {sensor}")


if __name__ == "__main__":
    main()
