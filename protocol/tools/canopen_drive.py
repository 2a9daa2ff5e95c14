#!/usr/bin/env python3
"""CiA 402 drives made of the Python `canopen` package, for checking
anguilla's CANopen master against an implementation we did not write.

Each drive is a `canopen.LocalNode` built from the simulated drive's EDS
(`sim-backend/eds/anguilla-sim-cia402.eds`): python-canopen's SDO server
answers the master's expedited and segmented transfers from that object
dictionary, its NMT slave follows the master's NMT commands and produces
the heartbeat the master writes into 0x1017. On top, this script does
what a LocalNode leaves to the application: boot-up after a reset,
0x6061 mirroring 0x6060, the PDOs as mapped in the dictionary (RPDO
applied at SYNC, TPDO sent at SYNC, both decoded from 0x1600/0x1A00 as
the master wrote them) and the CiA 402 state machine on the controlword,
with an ideal axis (position actual = target in Operation enabled).

It runs for --seconds (or until SIGTERM/SIGINT) on a python-can bus (e.g. `--interface slcan
--channel /dev/pts/N`) and prints one JSON report: what each drive was
written, its mapping, its NMT and CiA 402 states, the PDOs and SYNCs
seen. `scripts/canopen-check` runs it against `anguilla run`.
"""

import argparse
import json
import signal
import struct
import sys
import threading

import can
import canopen

# Statuswords of the CiA 402 states (bit 9 remote, bit 4 voltage where on).
SWITCH_ON_DISABLED = 0x0250
READY_TO_SWITCH_ON = 0x0231
SWITCHED_ON = 0x0233
OPERATION_ENABLED = 0x0237
QUICK_STOP_ACTIVE = 0x0217
FAULT = 0x0218

NAMES = {
    SWITCH_ON_DISABLED: "switch on disabled",
    READY_TO_SWITCH_ON: "ready to switch on",
    SWITCHED_ON: "switched on",
    OPERATION_ENABLED: "operation enabled",
    QUICK_STOP_ACTIVE: "quick stop active",
    FAULT: "fault",
}

SIZES = {8: "B", 16: "H", 32: "I"}


def next_state(status, cw, prev_cw):
    """CiA 402 transitions on a controlword (quick stop option code 2)."""
    if status == FAULT:
        return SWITCH_ON_DISABLED if (cw & 0x80 and not prev_cw & 0x80) else FAULT
    if status == QUICK_STOP_ACTIVE:
        return SWITCH_ON_DISABLED
    if cw & 0x02 == 0:  # disable voltage
        return SWITCH_ON_DISABLED
    if cw & 0x04 == 0:  # quick stop
        return QUICK_STOP_ACTIVE if status == OPERATION_ENABLED else SWITCH_ON_DISABLED
    low = cw & 0x0F
    if low == 0x06:  # shutdown
        return READY_TO_SWITCH_ON
    if low == 0x07:  # switch on
        return SWITCHED_ON if status in (READY_TO_SWITCH_ON, OPERATION_ENABLED, SWITCHED_ON) else status
    if low == 0x0F:  # enable operation
        return OPERATION_ENABLED if status in (READY_TO_SWITCH_ON, SWITCHED_ON, OPERATION_ENABLED) else status
    return status


class Drive:
    def __init__(self, network, node_id, eds):
        self.id = node_id
        self.network = network
        self.node = canopen.LocalNode(node_id, eds)
        network.add_node(self.node)
        self.node.add_write_callback(self.on_write)
        self.lock = threading.Lock()
        self.writes = []
        self.pending_rpdo = None
        self.status = SWITCH_ON_DISABLED
        self.prev_cw = 0
        self.states_seen = [NAMES[self.status]]
        self.rpdos = 0
        self.tpdos = 0
        self.syncs = 0
        self.targets = []
        self.nmt_seen = []
        self.set(0x6041, 0, SWITCH_ON_DISABLED, 16)
        network.subscribe(0x000, self.on_nmt)
        network.subscribe(0x080, self.on_sync)
        network.subscribe(0x200 + node_id, self.on_rpdo)

    def get(self, index, sub):
        return self.node.get_data(index, sub, check_readable=False)

    def store(self, index, sub, data):
        """The drive's own update of an entry (mirrors, applied PDOs,
        statusword): straight into the LocalNode's data store, so that the
        write callbacks, and with them the report's `writes`, see only the
        master's SDO downloads."""
        self.node._find_object(index, sub)  # raises if the EDS has no such entry
        self.node.data_store.setdefault(index, {})[sub] = bytes(data)

    def set(self, index, sub, value, bits, signed=False):
        fmt = SIZES[bits].lower() if signed else SIZES[bits]
        self.store(index, sub, struct.pack("<" + fmt, value))

    def on_write(self, index, subindex, od, data):
        # Called by LocalNode.set_data, which only the SDO server calls.
        self.writes.append([f"0x{index:04X}:{subindex:02X}", data.hex()])
        if index == 0x6060:
            # Modes of operation display follows the mode.
            self.store(0x6061, 0, data)

    def on_nmt(self, can_id, data, timestamp):
        cmd, node = data[0], data[1]
        if node not in (0, self.id):
            return
        self.nmt_seen.append(cmd)
        if cmd in (0x81, 0x82):
            # Reset: send the boot-up message, then pre-operational (the
            # heartbeat of 0x1017 starts there).
            self.node.nmt.send_command(0x82)
            self.node.nmt.send_command(0x80)

    def on_rpdo(self, can_id, data, timestamp):
        with self.lock:
            self.pending_rpdo = bytes(data)

    def mapping(self, base):
        """The (index, sub, bits) entries of a PDO mapping as written."""
        count = struct.unpack("<B", self.get(base, 0))[0]
        out = []
        for k in range(1, count + 1):
            entry = struct.unpack("<I", self.get(base, k))[0]
            out.append((entry >> 16, (entry >> 8) & 0xFF, entry & 0xFF))
        return out

    def on_sync(self, can_id, data, timestamp):
        if self.node.nmt.state != "OPERATIONAL":
            return
        with self.lock:
            rpdo, self.pending_rpdo = self.pending_rpdo, None
            self.syncs += 1
            if rpdo is not None:
                self.rpdos += 1
                at = 0
                for index, sub, bits in self.mapping(0x1600):
                    n = bits // 8
                    self.store(index, sub, rpdo[at:at + n])
                    at += n
                cw = struct.unpack("<H", self.get(0x6040, 0))[0]
                new = next_state(self.status, cw, self.prev_cw)
                self.prev_cw = cw
                if new != self.status:
                    self.status = new
                    self.states_seen.append(NAMES[new])
                self.set(0x6041, 0, self.status, 16)
                if self.status == OPERATION_ENABLED:
                    target = struct.unpack("<i", self.get(0x607A, 0))[0]
                    self.targets.append(target)
                    self.set(0x6064, 0, target, 32, signed=True)
            cob = struct.unpack("<I", self.get(0x1800, 1))[0]
            if cob & 0x8000_0000:
                return
            payload = b"".join(
                self.get(index, sub)[: bits // 8] for index, sub, bits in self.mapping(0x1A00)
            )
            self.network.send_message(cob & 0x7FF, payload)
            self.tpdos += 1

    def report(self):
        targets = self.targets
        return {
            "node": self.id,
            "nmt_state": self.node.nmt.state,
            "nmt_commands": self.nmt_seen,
            "writes": self.writes,
            "rpdo1": [f"0x{i:04X}:{s:02X}/{b}" for i, s, b in self.mapping(0x1600)],
            "tpdo1": [f"0x{i:04X}:{s:02X}/{b}" for i, s, b in self.mapping(0x1A00)],
            "states": self.states_seen,
            "syncs": self.syncs,
            "rpdos": self.rpdos,
            "tpdos": self.tpdos,
            "target_span": (max(targets) - min(targets)) if targets else 0,
        }


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--interface", default="slcan")
    p.add_argument("--channel", required=True)
    p.add_argument("--bitrate", type=int, default=1_000_000)
    p.add_argument("--nodes", default="1,2", help="drive node ids, comma separated")
    p.add_argument("--eds", required=True)
    p.add_argument("--seconds", type=float, default=10.0)
    a = p.parse_args()
    bus = can.Bus(interface=a.interface, channel=a.channel, bitrate=a.bitrate)
    network = canopen.Network(bus)
    drives = [Drive(network, int(n), a.eds) for n in a.nodes.split(",")]
    network.notifier = can.Notifier(bus, network.listeners, 0.05)
    # Runs --seconds, or until SIGTERM or SIGINT (handled here: a shell
    # starts background jobs with SIGINT ignored), then reports.
    done = threading.Event()
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: done.set())
    print("ready", flush=True)
    done.wait(a.seconds)
    network.notifier.stop()
    report = [d.report() for d in drives]
    bus.shutdown()
    json.dump(report, sys.stdout)
    print()


if __name__ == "__main__":
    main()
