#!/usr/bin/env python3
"""A CANopen master as an integrator would write it with python-canopen and python-can,
and nothing of drivedeck, against the simulated drive served by
`drivedeck sim --slcan A --node N` on the other end of a pseudo-terminal pair.

    canopen_master.py PTY NODE

The object dictionary below is written from the spec (PDI objects 2290h-2292h, PDI spec
section 2.1; CiA 301 communication objects, protocol notes §2.2-2.4), not from drivedeck's catalog.
The PDI PDOs are mapped with python-canopen's own PDO API, as spec section 3 prescribes:
RPDO1 = 2291h:01 (32) 2291h:02 (16) 2291h:03 (8) 2291h:04 (8),
TPDO1 = 2292h:01 (16) 603Fh:00 (16) 2292h:02 (32).

Prints one JSON object on stdout; on a failure it prints {"failed": "..."} and exits 1.
The Rust test (tests/canopen_peers.rs) asserts every field.
"""

import json
import sys
import threading
import time
import traceback

import can
import canopen
from canopen import objectdictionary as odm
from canopen.sdo import SdoAbortedError

# How long anything may take on a loaded machine; all is well within a fraction of it.
PATIENCE = 8.0
SDO_TIMEOUT = 2.0

# PDI-Status bits (spec 2.3).
OPERATION_ENABLED = 1 << 0
TARGET_REACHED = 1 << 3
TOGGLE_CMD = 1 << 14
STATUS_ERROR = 1 << 15

# PDI-Cmd opcodes (spec 2.2).
MOVE_ABSOLUTE = 20
MOVE_RELATIVE = 21


class Failed(Exception):
    pass


def variable(name, index, sub, dtype, access):
    var = odm.ODVariable(name, index, sub)
    var.data_type = dtype
    var.access_type = access
    return var


def record(od, name, index, members):
    rec = odm.ODRecord(name, index)
    for sub, (member, dtype, access) in enumerate(members):
        rec.add_member(variable(member, index, sub, dtype, access))
    od.add_object(rec)


def dictionary():
    """The objects this master uses, typed as CiA 301 and the PDI spec say."""
    od = odm.ObjectDictionary()
    for index, name, dtype, access in [
        (0x1000, "Device type", odm.UNSIGNED32, "ro"),
        (0x1008, "Manufacturer device name", odm.VISIBLE_STRING, "const"),
        (0x1017, "Producer heartbeat time", odm.UNSIGNED16, "rw"),
        (0x2290, "PDI-Ctrl", odm.UNSIGNED8, "rw"),
        (0x603F, "Error code", odm.UNSIGNED16, "ro"),
        (0x6041, "Statusword", odm.UNSIGNED16, "ro"),
        (0x6064, "Position actual value", odm.INTEGER32, "ro"),
        (0x6081, "Profile velocity", odm.UNSIGNED32, "rw"),
    ]:
        od.add_object(variable(name, index, 0, dtype, access))
    record(
        od,
        "Identity",
        0x1018,
        [
            ("Number of entries", odm.UNSIGNED8, "ro"),
            ("Vendor-ID", odm.UNSIGNED32, "ro"),
            ("Product code", odm.UNSIGNED32, "ro"),
            ("Revision number", odm.UNSIGNED32, "ro"),
            ("Serial number", odm.UNSIGNED32, "ro"),
        ],
    )
    record(
        od,
        "PDI Input",
        0x2291,
        [
            ("Number of entries", odm.UNSIGNED8, "ro"),
            ("PDI-SetValue1", odm.INTEGER32, "rw"),
            ("PDI-SetValue2", odm.INTEGER16, "rw"),
            ("PDI-SetValue3", odm.INTEGER8, "rw"),
            ("PDI-Cmd", odm.INTEGER8, "rw"),
        ],
    )
    record(
        od,
        "PDI Output",
        0x2292,
        [
            ("Number of entries", odm.UNSIGNED8, "ro"),
            ("PDI-Status", odm.INTEGER16, "ro"),
            ("PDI-ReturnValue", odm.INTEGER32, "ro"),
        ],
    )
    # RPDO1 and TPDO1: communication (1400h/1800h) and mapping (1600h/1A00h).
    record(
        od,
        "RPDO1 communication",
        0x1400,
        [
            ("Highest sub-index", odm.UNSIGNED8, "ro"),
            ("COB-ID", odm.UNSIGNED32, "rw"),
            ("Transmission type", odm.UNSIGNED8, "rw"),
        ],
    )
    record(
        od,
        "TPDO1 communication",
        0x1800,
        [
            ("Highest sub-index", odm.UNSIGNED8, "ro"),
            ("COB-ID", odm.UNSIGNED32, "rw"),
            ("Transmission type", odm.UNSIGNED8, "rw"),
            ("Inhibit time", odm.UNSIGNED16, "rw"),
            ("Reserved", odm.UNSIGNED8, "rw"),
            ("Event timer", odm.UNSIGNED16, "rw"),
        ],
    )
    for index, name in [(0x1600, "RPDO1 mapping"), (0x1A00, "TPDO1 mapping")]:
        record(
            od,
            name,
            index,
            [("Number of mapped objects", odm.UNSIGNED8, "rw")]
            + [(f"Mapped object {n}", odm.UNSIGNED32, "rw") for n in range(1, 9)],
        )
    return od


def abort_code(call):
    """The abort code an SDO call ends with, or None when it succeeds."""
    try:
        call()
    except SdoAbortedError as e:
        return e.code
    return None


def wait_for(what, check, timeout=PATIENCE, seen=None):
    """Poll `check` until it gives a value; `seen` (a list) tells what came instead."""
    deadline = time.monotonic() + timeout
    while True:
        value = check()
        if value:
            return value
        if time.monotonic() > deadline:
            last = f"; last seen {seen[-3:]}" if seen else ""
            raise Failed(f"no {what} within {timeout} s{last}")
        time.sleep(0.005)


class Bus:
    """What went by on the bus for node N, as python-canopen's subscribers see it."""

    def __init__(self, network, node_id):
        self.lock = threading.Lock()
        self.sdo_commands = []  # first byte of every SDO response
        self.heartbeats = []  # NMT states from 700h+N, boot-up = 0
        network.subscribe(0x580 + node_id, self.on_sdo)
        network.subscribe(0x700 + node_id, self.on_heartbeat)

    def on_sdo(self, can_id, data, timestamp):
        with self.lock:
            self.sdo_commands.append(data[0])

    def on_heartbeat(self, can_id, data, timestamp):
        with self.lock:
            self.heartbeats.append(data[0] & 0x7F)

    def heartbeat_count(self):
        with self.lock:
            return len(self.heartbeats)

    def states_since(self, start):
        with self.lock:
            return list(self.heartbeats[start:])

    def take_sdo_commands(self):
        with self.lock:
            out, self.sdo_commands = self.sdo_commands, []
            return out


class TpdoLog:
    """Every TPDO1 python-canopen decoded: (PDI-Status, 603Fh, PDI-ReturnValue)."""

    def __init__(self, pdo_map):
        self.lock = threading.Lock()
        self.images = []
        pdo_map.add_callback(self.on_tpdo)

    def on_tpdo(self, pdo_map):
        values = {(var.index, var.subindex): var.raw for var in pdo_map.map}
        image = (values[(0x2292, 1)], values[(0x603F, 0)], values[(0x2292, 2)])
        with self.lock:
            self.images.append(image)

    def since(self, start):
        with self.lock:
            return list(self.images[start:])

    def count(self):
        with self.lock:
            return len(self.images)


def run(path, node_id):
    out = {}
    network = canopen.Network()
    # sleep_after_open: python-can waits 2 s for a real adapter to settle; a pty needs none.
    network.connect(
        interface="slcan", channel=path, bitrate=1000000, sleep_after_open=0
    )
    try:
        # python-canopen's own scanner: SDO 1000h to every node id, then listen.
        network.scanner.search()
        wait_for("answer to the scan", lambda: node_id in network.scanner.nodes)
        time.sleep(0.2)
        out["scanner_nodes"] = sorted(network.scanner.nodes)

        # The frame log subscribes first: python-canopen calls subscribers in order, so
        # every SDO response is logged before the SDO client returns with it.
        bus = Bus(network, node_id)
        node = canopen.RemoteNode(node_id, dictionary())
        node.sdo.RESPONSE_TIMEOUT = SDO_TIMEOUT
        network.add_node(node)

        # Boot-up: NMT reset communication makes the node boot again (its first boot-up
        # went out before python-can opened the adapter's channel).
        before = bus.heartbeat_count()
        node.nmt.send_command(0x82)
        wait_for("boot-up", lambda: 0 in bus.states_since(before))
        out["boot_up"] = True
        # Heartbeat every 50 ms: 1017h is UNSIGNED16 in ms.
        node.sdo[0x1017].raw = 50
        out["heartbeat_1017"] = node.sdo[0x1017].raw
        before = bus.heartbeat_count()
        wait_for("heartbeats", lambda: len(bus.states_since(before)) >= 2)
        out["state_after_boot"] = bus.states_since(before)[-1]

        # Identity and name.
        bus.take_sdo_commands()
        out["vendor_1018_01"] = node.sdo[0x1018][1].raw
        out["product_1018_02"] = node.sdo[0x1018][2].raw
        out["expedited_1018_01"] = bus.take_sdo_commands()[0]
        out["name_1008"] = node.sdo[0x1008].raw
        commands = bus.take_sdo_commands()
        # Segmented: initiate response 41h (size given), then segments, the last with c = 1.
        out["segmented_1008"] = {
            "initiate": commands[0],
            "segments": len(commands) - 1,
            "last_segment_c": commands[-1] & 1,
        }
        out["device_type_1000"] = node.sdo[0x1000].raw

        # A download and the value read back; raw bytes as well as the decoded value.
        node.sdo[0x6081].raw = 1234
        out["read_back_6081"] = node.sdo[0x6081].raw
        node.sdo.download(0x6081, 0, (4321).to_bytes(4, "little"))
        out["read_back_6081_raw"] = node.sdo.upload(0x6081, 0).hex()

        # Aborts, with the codes of CiA 301 (protocol notes §2.5).
        out["abort_missing_object"] = abort_code(lambda: node.sdo.upload(0x2FFF, 0))
        out["abort_missing_sub"] = abort_code(lambda: node.sdo.upload(0x1018, 9))
        out["abort_read_only"] = abort_code(
            lambda: node.sdo.download(0x1018, 1, b"\x01\x00\x00\x00")
        )
        out["abort_too_long"] = abort_code(
            lambda: node.sdo.download(0x2290, 0, b"\x01\x00\x00\x00")
        )
        # Block transfer (CiA 301 optional): refused with "command specifier not valid",
        # so a client falls back to segmented transfers.
        out["abort_block_upload"] = abort_code(
            lambda: node.sdo.open(0x1008, 0, "rb", block_transfer=True).read()
        )
        # A segmented download of four bytes (python-canopen would send them expedited).
        node.sdo.download(0x6081, 0, (777).to_bytes(4, "little"), force_segment=True)
        out["segmented_download_6081"] = node.sdo[0x6081].raw
        # After the aborts the server answers as before.
        out["vendor_after_aborts"] = node.sdo.upload(0x1018, 1).hex()

        # The PDOs, with python-canopen's PDO API: read what the node holds, then map the
        # PDI as spec section 3 says.
        node.rpdo.read()
        node.tpdo.read()
        out["rpdo1_before"] = {
            "cob_id": node.rpdo[1].cob_id,
            "enabled": node.rpdo[1].enabled,
            "mapped": len(node.rpdo[1].map),
        }
        rpdo = node.rpdo[1]
        rpdo.clear()
        for sub in (1, 2, 3, 4):
            rpdo.add_variable(0x2291, sub)
        rpdo.cob_id = 0x200 + node_id
        rpdo.trans_type = 255
        rpdo.enabled = True
        tpdo = node.tpdo[1]
        tpdo.clear()
        tpdo.add_variable(0x2292, 1)
        tpdo.add_variable(0x603F, 0)
        tpdo.add_variable(0x2292, 2)
        tpdo.cob_id = 0x180 + node_id
        tpdo.trans_type = 255
        tpdo.inhibit_time = 20  # 100 µs units: 2 ms
        tpdo.event_timer = 100  # ms
        tpdo.enabled = True
        rpdo.save()
        tpdo.save()

        # Read back through the PDO API and entry by entry.
        node.rpdo.read()
        node.tpdo.read()
        out["rpdo1_mapping"] = [
            f"{v.index:04X}:{v.subindex:02X}/{v.length}" for v in node.rpdo[1].map
        ]
        out["tpdo1_mapping"] = [
            f"{v.index:04X}:{v.subindex:02X}/{v.length}" for v in node.tpdo[1].map
        ]
        out["rpdo1_cob_id"] = node.rpdo[1].cob_id
        out["tpdo1_cob_id"] = node.tpdo[1].cob_id
        out["tpdo1_enabled"] = node.tpdo[1].enabled
        out["tpdo1_event_timer"] = node.tpdo[1].event_timer
        out["tpdo1_inhibit"] = node.tpdo[1].inhibit_time
        out["raw_1a00"] = [
            f"{int.from_bytes(node.sdo.upload(0x1A00, sub), 'little'):08X}"
            for sub in (1, 2, 3)
        ]
        out["raw_1600"] = [
            f"{int.from_bytes(node.sdo.upload(0x1600, sub), 'little'):08X}"
            for sub in (1, 2, 3, 4)
        ]
        log = TpdoLog(node.tpdo[1])

        # PDI on (2290h bit 0), NMT start: Operational in the heartbeat, TPDO1 comes.
        node.sdo[0x2290].raw = 1
        out["pdi_ctrl_2290"] = node.sdo[0x2290].raw
        before = bus.heartbeat_count()
        node.nmt.state = "OPERATIONAL"
        wait_for("Operational", lambda: 5 in bus.states_since(before))
        out["state_after_start"] = 5
        wait_for("TPDO1", lambda: log.count() >= 1)
        status0, _, _ = log.since(0)[-1]

        # A move through RPDO1: SetValue1 = 2000 (0.1°), SetValue2 = 200 rpm, Cmd 20.
        start = log.count()
        # By position in the mapping: 2291h:01, :02, :03, :04.
        for var, value in zip(rpdo.map, [2000, 200, 0, MOVE_ABSOLUTE]):
            var.raw = value
        rpdo.transmit()
        started = time.monotonic()

        def reached():
            for status, error, value in log.since(start):
                toggled = (status ^ status0) & TOGGLE_CMD
                if toggled and status & TARGET_REACHED and value == 2000:
                    return (status, error, value)
            return None

        status, error, value = wait_for(
            "the target in TPDO1", reached, seen=log.images
        )
        images = log.since(start)
        out["move_seconds"] = round(time.monotonic() - started, 3)
        out["move_tpdo"] = {
            "toggled": bool((status ^ status0) & TOGGLE_CMD),
            "target_reached": bool(status & TARGET_REACHED),
            "operation_enabled": bool(status & OPERATION_ENABLED),
            "error": bool(status & STATUS_ERROR),
            "error_code_603f": error,
            "return_value": value,
        }
        # The position was live on the way: ReturnValues between start and target.
        out["tpdo_positions_on_the_way"] = len(
            {v for _, _, v in images if 0 < v < 2000}
        )
        out["position_6064"] = node.sdo[0x6064].raw
        out["statusword_6041"] = node.sdo[0x6041].raw

        # The PDI over SDO, as spec 2.2.11 describes it: set values first, Cmd last.
        status0 = node.sdo[0x2292][1].raw
        node.sdo[0x2291][1].raw = -500
        node.sdo[0x2291][2].raw = 300
        node.sdo[0x2291][4].raw = MOVE_RELATIVE

        polled = []

        def arrived():
            status = node.sdo[0x2292][1].raw
            position = node.sdo[0x6064].raw
            polled.append((status, position))
            toggled = (status ^ status0) & TOGGLE_CMD
            if toggled and status & TARGET_REACHED and position == 1500:
                return (status, position)
            return None

        status, position = wait_for("the relative move over SDO", arrived, seen=polled)
        out["sdo_move"] = {
            "toggled": True,
            "target_reached": bool(status & TARGET_REACHED),
            "error": bool(status & STATUS_ERROR),
            "position_6064": position,
            "return_value": node.sdo[0x2292][2].raw,
        }
        out["rx_2291_read_back"] = [node.sdo[0x2291][sub].raw for sub in (1, 2, 3, 4)]

        # NMT stop: the heartbeat says Stopped (04h).
        before = bus.heartbeat_count()
        node.nmt.state = "STOPPED"
        wait_for("Stopped", lambda: 4 in bus.states_since(before))
        out["state_after_stop"] = 4
    finally:
        network.disconnect()
    return out


def main():
    path, node_id = sys.argv[1], int(sys.argv[2])
    try:
        out = run(path, node_id)
    except Exception as e:  # noqa: BLE001 - every failure becomes the JSON line
        traceback.print_exc()
        print(json.dumps({"failed": f"{type(e).__name__}: {e}"}), flush=True)
        sys.exit(1)
    print(json.dumps(out), flush=True)


if __name__ == "__main__":
    main()
