#!/usr/bin/env python3
"""Write (or check) protocol/tests/data/candump-corpus/python-can.log with
python-can's own writer (can.CanutilsLogWriter): one message of every kind
it writes (standard, extended, remote, CAN FD with each flag, error frame,
received and transmitted). protocol/tests/candump_corpus.rs reads the file
with anguilla's reader and checks every entry.

    protocol/tools/candump_corpus.py          # rewrite the file
    protocol/tools/candump_corpus.py --check  # exit 1 if python-can now writes otherwise

Needs python-can (pip install python-can). Exit status 0 when the file is
what python-can writes.
"""
import io
import pathlib
import sys

import can

OUT = pathlib.Path(__file__).resolve().parent.parent / "tests/data/candump-corpus/python-can.log"

MESSAGES = [
    can.Message(timestamp=1700000000.000001, arbitration_id=0x123, is_extended_id=False, data=b"\xde\xad\xbe\xef", is_rx=True),
    can.Message(timestamp=1700000000.000002, arbitration_id=0x040, is_extended_id=False, data=b"\x07\x00", is_rx=False),
    can.Message(timestamp=1700000000.000003, arbitration_id=0x12345678, is_extended_id=True, data=b"", is_rx=True),
    can.Message(timestamp=1700000000.000004, arbitration_id=0x1FFFFFFF, is_extended_id=True, data=bytes(range(8)), is_rx=True),
    can.Message(timestamp=1700000000.000005, arbitration_id=0x7FF, is_extended_id=False, is_remote_frame=True, dlc=0, is_rx=True),
    can.Message(timestamp=1700000000.000006, arbitration_id=0x00000001, is_extended_id=True, is_remote_frame=True, dlc=8, is_rx=False),
    can.Message(timestamp=1700000000.000007, arbitration_id=0x010, is_extended_id=False, is_fd=True, data=bytes(12), is_rx=True),
    can.Message(timestamp=1700000000.000008, arbitration_id=0x010, is_extended_id=False, is_fd=True, bitrate_switch=True, data=bytes(range(64)), is_rx=True),
    can.Message(timestamp=1700000000.000009, arbitration_id=0x010, is_extended_id=False, is_fd=True, bitrate_switch=True, error_state_indicator=True, data=b"\x01", is_rx=False),
    can.Message(timestamp=1700000000.000010, arbitration_id=0x1ABCDEF0, is_extended_id=True, is_fd=True, error_state_indicator=True, data=bytes(16), is_rx=True),
    can.Message(timestamp=1700000000.000011, is_error_frame=True, data=bytes(8), is_rx=True),
    can.Message(timestamp=1700000000.000012, is_error_frame=True, data=b"", is_rx=True),
    can.Message(timestamp=1700000000.500000, arbitration_id=0x0C1, is_extended_id=False, data=bytes(8), channel="can1", is_rx=True),
]


def render():
    buf = io.StringIO()
    writer = can.CanutilsLogWriter(buf)
    for msg in MESSAGES:
        writer.on_message_received(msg)
    return buf.getvalue()


def main():
    text = render()
    if "--check" in sys.argv[1:]:
        if OUT.read_text() != text:
            print(f"{OUT} differs from what python-can {can.__version__} writes now; "
                  "rerun protocol/tools/candump_corpus.py and commit", file=sys.stderr)
            return 1
        # And python-can reads back what it wrote, as a sanity check of the corpus.
        back = list(can.CanutilsLogReader(io.StringIO(text)))
        assert len(back) == len(MESSAGES), (len(back), len(MESSAGES))
        print(f"candump corpus: python-can {can.__version__} writes {OUT.name} as committed ({len(MESSAGES)} lines)")
        return 0
    OUT.write_text(text)
    print(f"wrote {OUT}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
