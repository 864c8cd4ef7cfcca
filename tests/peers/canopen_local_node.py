#!/usr/bin/env python3
"""A CANopen device that is not drivedeck's: a python-canopen LocalNode (its own SDO
server and NMT slave), reached through an slcan adapter emulated here, so that
drivedeck's master (`canopen+slcan://B?bitrate=1000000&node=N`) can talk to it over a
pseudo-terminal pair.

    canopen_local_node.py PTY NODE

python-canopen has no slcan adapter side (python-can's `slcan` interface is the host),
so this script plays the adapter: it reads Lawicel lines from PTY, answers the commands
(O, L, C, S0-S8, V, v, N, F, Z0/Z1, the empty line) with `\r` (BEL for what it refuses),
puts `t`/`T`/`r`/`R` frames on a python-can `virtual` bus and writes the frames from that
bus back as lines while the channel is open. The LocalNode lives on the same virtual bus.

Stdout, one JSON object a line:
    {"ready": true, "node": N}                   once the adapter listens
    {"written": "2000:00", "hex": "...", "value": ...}   every SDO download the node accepts
    {"adapter": "open" | "closed", "bitrate": ...}       channel changes
The script ends when its stdin closes (the test went away).
"""

import json
import os
import sys
import threading

import can
import canopen
import serial

CHANNEL = "drivedeck-local-node"
BITRATES = [10000, 20000, 50000, 100000, 125000, 250000, 500000, 800000, 1000000]

OUT = threading.Lock()


def say(**fields):
    with OUT:
        print(json.dumps(fields), flush=True)


EDS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "canopen_local_node.eds")


def dictionary(node_id):
    """The device's dictionary from its EDS (canopen_local_node.eds): CiA 301 mandatory
    objects, a name, an identity record, an EMCY COB-ID given as $NODEID+0x80, and a few
    manufacturer objects of different types and access."""
    return canopen.import_od(EDS, node_id)


def encode(msg):
    """A frame from the bus as the adapter reports it."""
    if msg.is_remote_frame:
        kind = "R" if msg.is_extended_id else "r"
    else:
        kind = "T" if msg.is_extended_id else "t"
    ident = f"{msg.arbitration_id:08X}" if msg.is_extended_id else f"{msg.arbitration_id:03X}"
    data = "" if msg.is_remote_frame else bytes(msg.data).hex().upper()
    return f"{kind}{ident}{msg.dlc}{data}\r".encode()


def decode(line):
    """A `t`/`T`/`r`/`R` line from the host as a python-can message, or None."""
    kind = line[:1]
    extended = kind in ("T", "R")
    remote = kind in ("r", "R")
    digits = 8 if extended else 3
    try:
        ident = int(line[1 : 1 + digits], 16)
        dlc = int(line[1 + digits])
        hexdata = line[2 + digits :]
        if dlc > 8 or (not remote and len(hexdata) != 2 * dlc) or (remote and hexdata):
            return None
        data = b"" if remote else bytes.fromhex(hexdata)
    except (ValueError, IndexError):
        return None
    return can.Message(
        arbitration_id=ident,
        is_extended_id=extended,
        is_remote_frame=remote,
        dlc=dlc,
        data=data,
    )


class Adapter:
    """The slcan adapter: serial lines in, virtual bus frames out, and back."""

    def __init__(self, path):
        self.port = serial.Serial(path, baudrate=115200, timeout=0.05)
        self.bus = can.Bus(interface="virtual", channel=CHANNEL)
        self.write_lock = threading.Lock()
        self.open = False
        self.bitrate = None
        self.stopping = threading.Event()

    def write(self, data):
        with self.write_lock:
            self.port.write(data)

    def handle(self, line):
        ok, bel = b"\r", b"\x07"
        if not line:
            return ok
        head = line[0]
        if head in "tTrR":
            msg = decode(line)
            if msg is None or not self.open:
                return bel
            self.bus.send(msg)
            return ok
        if line in ("O", "L"):
            if not self.open:
                self.open = True
                say(adapter="open", bitrate=self.bitrate)
            return ok
        if line == "C":
            if self.open:
                self.open = False
                say(adapter="closed", bitrate=self.bitrate)
            return ok
        if len(line) == 2 and head == "S" and line[1] in "012345678":
            if self.open:
                return bel
            self.bitrate = BITRATES[int(line[1])]
            return ok
        if line == "V":
            return b"V1011\r"
        if line == "v":
            return b"v0101\r"
        if line == "N":
            return b"NPYCO\r"
        if line == "F":
            return b"F00\r" if self.open else bel
        if line in ("Z0", "Z1"):
            return ok
        return bel

    def serial_loop(self):
        pending = b""
        while not self.stopping.is_set():
            try:
                # At least one byte (or nothing after the timeout), then whatever else is
                # there: a plain read(256) would wait for 256 bytes or the timeout.
                chunk = self.port.read(max(1, self.port.in_waiting))
            except (serial.SerialException, OSError):
                return
            if not chunk:
                continue
            pending += chunk
            while b"\r" in pending:
                raw, pending = pending.split(b"\r", 1)
                line = raw.decode("ascii", "replace").strip("\n")
                self.write(self.handle(line))

    def bus_loop(self):
        while not self.stopping.is_set():
            msg = self.bus.recv(timeout=0.05)
            if msg is not None and self.open:
                try:
                    self.write(encode(msg))
                except (serial.SerialException, OSError):
                    return


def main():
    path, node_id = sys.argv[1], int(sys.argv[2])
    adapter = Adapter(path)

    network = canopen.Network()
    network.connect(interface="virtual", channel=CHANNEL)
    node = canopen.LocalNode(node_id, dictionary(node_id))

    def on_write(index, subindex, od, data):
        say(
            written=f"{index:04X}:{subindex:02X}",
            hex=bytes(data).hex(),
            value=od.decode_raw(bytes(data)),
        )

    node.add_write_callback(on_write)
    network.add_node(node)

    threads = [
        threading.Thread(target=adapter.serial_loop, daemon=True),
        threading.Thread(target=adapter.bus_loop, daemon=True),
    ]
    for thread in threads:
        thread.start()
    # Boot-up into Pre-operational (it reaches nobody while the channel is closed).
    node.nmt.state = "PRE-OPERATIONAL"
    say(ready=True, node=node_id)

    # Until the test goes away.
    while sys.stdin.read(1):
        pass
    adapter.stopping.set()
    for thread in threads:
        thread.join(timeout=1)
    network.disconnect()
    os._exit(0)


if __name__ == "__main__":
    main()
