#!/usr/bin/env python3
"""Check the committed DBC files with Python cantools (third-party reader).

Loads protocol/anguilla.dbc, protocol/anguilla_fd.dbc, protocol/odrive.dbc
(ODrive CANSimple axes 1..=24) and protocol/mit.dbc (MIT-mode drives 1..=24), then decodes the sample candump logs
protocol/tests/data/sample{,_fd,_odrive,_mit}.log with cantools' own log parser
and DBC decoder and compares every signal with the value the Rust codec read
(sample{,_fd,_odrive,_mit}.json, kept current by tests/interop.rs).
Exit status 0 when everything agrees.
"""
import json
import pathlib
import sys

import cantools
from cantools.logreader import Parser

ROOT = pathlib.Path(__file__).resolve().parent.parent


def check(dbc_name, stem, fd):
    db = cantools.database.load_file(ROOT / dbc_name)
    for msg in db.messages:
        assert msg.is_fd == fd, f"{dbc_name}: {msg.name} is_fd={msg.is_fd}"
    expected = [json.loads(line) for line in (ROOT / "tests/data" / f"{stem}.json").read_text().splitlines()]
    with open(ROOT / "tests/data" / f"{stem}.log") as f:
        frames = list(Parser(f))
    assert len(frames) == len(expected), f"{stem}: {len(frames)} frames, {len(expected)} expected"
    checked = 0
    for n, (frame, want) in enumerate(zip(frames, expected), start=1):
        assert frame.frame_id == want["id"], f"{stem}.log line {n}: id {frame.frame_id:#x}"
        # Truncated: the original firmware's 6-byte MIT reply; a signal the frame
        # does not reach is then missing, which the loop below names.
        got = db.decode_message(frame.frame_id, frame.data, decode_choices=False, allow_truncated=True)
        for name, value in want["signals"].items():
            assert name in got, f"{stem}.log line {n}: cantools has no signal {name}"
            assert abs(got[name] - value) <= 1e-9 * max(1.0, abs(value)), (
                f"{stem}.log line {n} {name}: cantools {got[name]} rust {value}"
            )
            checked += 1
    print(f"cantools {cantools.__version__}: {dbc_name} loads ({len(db.messages)} messages); "
          f"{len(frames)} frames of {stem}.log, {checked} signal values agree with the Rust codec")


check("anguilla.dbc", "sample", fd=False)
check("anguilla_fd.dbc", "sample_fd", fd=True)
check("odrive.dbc", "sample_odrive", fd=False)
check("mit.dbc", "sample_mit", fd=False)
