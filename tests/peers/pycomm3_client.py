#!/usr/bin/env python3
"""A PLC programmer's view of a Nanotec drive over EtherNet/IP, with pycomm3 and nothing of
drivedeck: the Nanotec object services (class 64h, instance 1: 32h GetOD, 33h SetOD, 34h
GetOD Rockwell; EtherNet/IP chapter, "Device profile") sent with pycomm3's own
`CIPDriver.generic_message`, the identity through its `list_identity`, `get_module_info`
and `discover`, and the PDI driven by explicit SetOD writes to 2291h. Request data is
packed by hand from the spec, never through drivedeck's codec.

    pycomm3_client.py HOST PORT SCENARIO    SCENARIO: unconnected, shapes, identity, move
    pycomm3_client.py HOST 44818 discover   (pycomm3's discover only ever asks port 44818)

pycomm3 takes the TCP port in its path, "HOST:PORT" (parse_connection_path; 44818 when
none is given), and a CIP route after it: "HOST:PORT/1/0" is port 1 (backplane), slot 0.

Every request and reply goes through a recording subclass of CIPDriver (it calls
pycomm3's own _send and _receive and only keeps the bytes), so the JSON shows what
pycomm3 put on the wire for each request shape. Prints one JSON object on stdout; on a
failure it prints {"failed": "..."} and exits 1. tests/enip_peers.rs asserts every field.
"""

import json
import socket
import struct
import sys
import time

import pycomm3
from pycomm3 import CIPDriver
from pycomm3.cip import SHORT_STRING, UDINT, UINT
from pycomm3.packets import ListIdentityRequestPacket

NANOTEC_CLASS = 0x64
GET_OD = 0x32
SET_OD = 0x33
GET_OD_ROCKWELL = 0x34
IDENTITY_CLASS = 0x01
ASSEMBLY_CLASS = 0x04
GET_ATTRIBUTE_SINGLE = 0x0E
GET_ATTRIBUTES_ALL = 0x01

# PDI (PDI spec §2.1.2): 2291h:01 SetValue1 i32, :02 SetValue2 i16, :03 SetValue3 i8, :04 Cmd u8;
# 2292h:01 PDI-Status i16, :02 ReturnValue i32.
MOVE_ABSOLUTE = 20
TARGET_REACHED = 1 << 3
TOGGLE_CMD = 1 << 14
STATUS_ERROR = 1 << 15

COMMANDS = {
    0x0065: "RegisterSession",
    0x0066: "UnRegisterSession",
    0x0063: "ListIdentity",
    0x006F: "SendRRData",
    0x0070: "SendUnitData",
}
ITEMS = {0x0000: "null", 0x00A1: "connected address", 0x00B1: "connected data", 0x00B2: "unconnected data"}


class Failed(Exception):
    pass


def od(index, sub):
    """GetOD/SetOD request data: index u16 LE, subindex u8 (EtherNet/IP chapter)."""
    return struct.pack("<HB", index, sub)


# ---------------------------------------------------------------------------------------
# The wire, as pycomm3 wrote and read it


class Recorder(CIPDriver):
    """pycomm3's CIPDriver, keeping a copy of every encapsulation message it sends and
    receives. Nothing is changed on the way."""

    def __init__(self, path, **kwargs):
        super().__init__(path, **kwargs)
        self.wire = []

    def _send(self, message):
        self.wire.append((">", bytes(message)))
        return super()._send(message)

    def _receive(self):
        reply = super()._receive()
        self.wire.append(("<", bytes(reply)))
        return reply

    def mark(self):
        return len(self.wire)

    def since(self, mark):
        return [describe(direction, message) for direction, message in self.wire[mark:]]


def describe(direction, message):
    """One encapsulation message in words: command, CPF items, the CIP message (and what an
    Unconnected_Send or a connected data item carries)."""
    command, length, _session, status = struct.unpack_from("<HHII", message, 0)
    out = {"dir": direction, "command": COMMANDS.get(command, f"{command:04X}h")}
    if status:
        out["encap_status"] = status
    body = message[24 : 24 + length]
    if command not in (0x006F, 0x0070) or len(body) < 8:
        return out
    count = struct.unpack_from("<H", body, 6)[0]
    at = 8
    items = []
    for _ in range(count):
        kind, size = struct.unpack_from("<HH", body, at)
        data = body[at + 4 : at + 4 + size]
        at += 4 + size
        items.append(ITEMS.get(kind, f"{kind:04X}h"))
        if kind == 0x00A1:
            out["connection_id"] = struct.unpack("<I", data)[0]
        elif kind == 0x00B1:
            out["sequence"] = struct.unpack_from("<H", data, 0)[0]
            out["cip"] = data[2:].hex()
        elif kind == 0x00B2:
            out["cip"] = data.hex()
            if direction == ">" and data[:1] == b"\x52":
                out["unconnected_send"] = unwrap_unconnected_send(data)
    out["items"] = items
    return out


def unwrap_unconnected_send(cip):
    """52h, path 20 06 24 01, priority/tick, timeout ticks, message length u16, message,
    pad to even, route path size (words) u8, reserved u8, route path."""
    path_words = cip[1]
    at = 2 + 2 * path_words + 2
    size = struct.unpack_from("<H", cip, at)[0]
    at += 2
    embedded = cip[at : at + size]
    at += size + (size % 2)
    rest = cip[at:]
    if len(rest) < 2:
        return {"embedded": embedded.hex(), "route": None, "after_message": rest.hex()}
    words = rest[0]
    return {"embedded": embedded.hex(), "route_words": words, "route": rest[2 : 2 + 2 * words].hex()}


def reply_status(packet):
    """General status and additional status words, read from the reply bytes themselves
    (pycomm3 keeps only the general status)."""
    raw = packet.raw
    connected = raw[:2] == b"\x70\x00"
    base = 48 if connected else 42
    size = raw[base + 1]
    words = list(struct.unpack_from(f"<{size}H", raw, base + 2)) if size else []
    return raw[base], words


# ---------------------------------------------------------------------------------------
# One request, as pycomm3 reports it


SHAPES = {
    # SendRRData with the bare request: the spec's own bytes (the acceptance check).
    "unconnected": dict(connected=False, unconnected_send=False, route_path=False),
    # pycomm3's default for an unconnected message: the driver's route path, padded, after
    # the request data (00 00 for a path with no route).
    "unconnected_default_route": dict(connected=False, unconnected_send=False),
    # Wrapped in Unconnected_Send (52h) to the Connection Manager, with the driver's route.
    "unconnected_send": dict(connected=False, unconnected_send=True),
    # Unconnected_Send with route_path=False: pycomm3 leaves out the route path size and
    # reserved byte, which Unconnected_Send requires.
    "unconnected_send_no_route": dict(connected=False, unconnected_send=True, route_path=False),
    # pycomm3's default: class 3 connection (Large_Forward_Open), SendUnitData.
    "connected": dict(connected=True),
}


def call(driver, shape, service, data=b"", class_code=NANOTEC_CLASS, instance=1, attribute=b"", data_type=None):
    """generic_message as a user writes it; what pycomm3 made of the reply."""
    mark = driver.mark()
    tag = driver.generic_message(
        service=service,
        class_code=class_code,
        instance=instance,
        attribute=attribute,
        request_data=data,
        data_type=data_type,
        return_response_packet=True,
        **SHAPES[shape],
    )
    packet = tag.value
    status, additional = reply_status(packet)
    value = packet.value
    out = {
        "ok": bool(packet),
        "status": status,
        "error": packet.error,
    }
    if additional:
        out["additional"] = additional
    if isinstance(value, (bytes, bytearray)):
        out["data"] = bytes(value).hex()
    elif value is not None:
        out["value"] = value
    # The exchange of this request alone (a connected shape's Forward_Open comes before it).
    exchange = [m for m in driver.since(mark) if m["command"] in ("SendRRData", "SendUnitData")]
    if exchange:
        out["request"] = exchange[-2] if len(exchange) >= 2 else exchange[-1]
        out["reply"] = exchange[-1]
    return out


def brief(result):
    """A result without its wire record."""
    return {k: v for k, v in result.items() if k not in ("request", "reply")}


def get_od(driver, shape, index, sub, **kwargs):
    return call(driver, shape, GET_OD, od(index, sub), **kwargs)


def set_od(driver, shape, index, sub, value):
    return call(driver, shape, SET_OD, od(index, sub) + value)


def rockwell(driver, shape, index, sub):
    result = call(driver, shape, GET_OD_ROCKWELL, od(index, sub))
    if result["ok"]:
        data = bytes.fromhex(result["data"])
        kind, length = struct.unpack_from("<HH", data, 0)
        result["decoded"] = {"type": kind, "length": length, "value": data[4:].hex()}
    return result


def text(result):
    return bytes.fromhex(result["data"]).decode("ascii") if result["ok"] else None


def value_int(result, signed=False):
    if not result["ok"]:
        raise Failed(f"read failed: {result}")
    return int.from_bytes(bytes.fromhex(result["data"]), "little", signed=signed)


# ---------------------------------------------------------------------------------------
# Scenarios


def scenario_unconnected(host, port):
    """The acceptance check and the spec's examples, bare SendRRData."""
    shape = "unconnected"
    with Recorder(f"{host}:{port}") as d:
        out = {}
        # 1018h:01, decoded by pycomm3 itself as a UDINT.
        vendor = get_od(d, shape, 0x1018, 1, data_type=UDINT)
        out["vendor_1018_01"] = brief(vendor)
        out["vendor_wire"] = {"request": vendor["request"], "reply": vendor["reply"]}
        name = get_od(d, shape, 0x1008, 0)
        out["name_1008"] = {"text": text(name), "status": name["status"], "error": name["error"]}
        out["rockwell_1018_01"] = brief(rockwell(d, shape, 0x1018, 1))
        out["rockwell_1008"] = rockwell(d, shape, 0x1008, 0)["decoded"]
        out["rockwell_6064"] = rockwell(d, shape, 0x6064, 0)["decoded"]
        # The spec's SetOD example: 00000304h to 2031h:00 (Max Motor Current).
        before = value_int(get_od(d, shape, 0x2031, 0))
        write = set_od(d, shape, 0x2031, 0, bytes.fromhex("04030000"))
        out["set_2031"] = {
            "before": before,
            "ok": write["ok"],
            "status": write["status"],
            "error": write["error"],
            "request_cip": write["request"]["cip"],
            "reply_cip": write["reply"]["cip"],
        }
        out["read_back_2031"] = value_int(get_od(d, shape, 0x2031, 0))
        # Refusals: pycomm3's own status and text.
        out["missing_object_5fff"] = brief(get_od(d, shape, 0x5FFF, 0))
        out["missing_sub_1018_09"] = brief(get_od(d, shape, 0x1018, 9))
        out["read_only_1018_01"] = brief(set_od(d, shape, 0x1018, 1, struct.pack("<I", 1)))
        out["too_long_2031"] = brief(set_od(d, shape, 0x2031, 0, bytes(5)))
        out["too_short_2031"] = brief(set_od(d, shape, 0x2031, 0, bytes(2)))
        out["rockwell_missing_5fff"] = brief(rockwell(d, shape, 0x5FFF, 0))
        # The session is still good after the refusals.
        out["vendor_after_errors"] = value_int(get_od(d, shape, 0x1018, 1))
        return out


def shape_round(d, shape, write_value):
    """The same reads, a write and a refusal in one request shape."""
    vendor = get_od(d, shape, 0x1018, 1)
    out = {
        "vendor_1018_01": vendor.get("data"),
        "vendor_status": vendor["status"],
        "vendor_error": vendor["error"],
        "request": vendor["request"],
        "reply": vendor["reply"],
    }
    if not vendor["ok"]:
        return out
    out["name_1008"] = text(get_od(d, shape, 0x1008, 0))
    out["rockwell_1018_01"] = rockwell(d, shape, 0x1018, 1)["decoded"]
    write = set_od(d, shape, 0x2031, 0, struct.pack("<I", write_value))
    out["set_2031_status"] = write["status"]
    out["read_back_2031"] = value_int(get_od(d, shape, 0x2031, 0))
    missing = get_od(d, shape, 0x5FFF, 0)
    out["missing_object_status"] = missing["status"]
    return out


def connected_open(d, mark):
    """What the Forward_Open before the first connected request looked like."""
    wire = d.since(mark)
    opens = [m for m in wire if m["dir"] == ">" and m.get("cip", "")[:2] in ("54", "5b")]
    if not opens:
        return None
    request = bytes.fromhex(opens[0]["cip"])
    reply = next(m for m in wire[wire.index(opens[0]) + 1 :] if m["dir"] == "<")
    reply_cip = bytes.fromhex(reply["cip"])
    path_words = request[1]
    at = 2 + 2 * path_words
    body = request[at:]
    large = request[0] == 0x5B
    # Forward_Open data: tick, ticks, O→T id, T→O id, serial u16, vendor u16, originator
    # serial u32, multiplier u8, 3 reserved, O→T RPI u32, O→T params (u32 large / u16),
    # T→O RPI, T→O params, transport, path size (words), path.
    params = "<I" if large else "<H"
    psize = 4 if large else 2
    at = 2 + 8 + 8 + 1 + 3
    ot_rpi = struct.unpack_from("<I", body, at)[0]
    ot_params = struct.unpack_from(params, body, at + 4)[0]
    at += 4 + psize
    to_rpi = struct.unpack_from("<I", body, at)[0]
    at += 4 + psize
    transport = body[at]
    words = body[at + 1]
    path = body[at + 2 : at + 2 + 2 * words]
    # The reply: service | 0 | status | 0 | O→T id | T→O id | serial, vendor, originator
    # serial (the triad) | O→T API | T→O API | ...
    ot_id, to_id = struct.unpack_from("<II", reply_cip, 4)
    return {
        "service": request[0],
        "transport": transport,
        "connection_path": path.hex(),
        "rpi_us": [ot_rpi, to_rpi],
        "ot_params": ot_params,
        "reply_service": reply_cip[0],
        "reply_status": reply_cip[2],
        "reply_apis_equal_rpis": list(struct.unpack_from("<II", reply_cip, 4 + 16)) == [ot_rpi, to_rpi],
        "reply_to_id_is_pycomm3s": to_id == struct.unpack_from("<I", body, 6)[0],
        "reply_triad_echoed": reply_cip[12:20] == body[10:18],
        # Where pycomm3 keeps the id it sends with (CIPDriver._target_cid).
        "ot_id": ot_id,
        "to_id": to_id,
    }


def connection_ids(message, opened):
    """A connected message's address item in words: whose id it carries."""
    names = {opened["ot_id"]: "O->T id of the Forward_Open reply", opened["to_id"]: "T->O id"}
    if "connection_id" in message:
        message = dict(message)
        message["connection_id"] = names.get(message["connection_id"], message["connection_id"])
    return message


def scenario_shapes(host, port):
    """Every request shape pycomm3 can make, on a plain path and on a backplane route."""
    out = {}
    value = 0x300
    for suffix, label in (("", ""), ("/1/0", "_backplane")):
        for shape in SHAPES:
            if label and shape in ("unconnected", "unconnected_send_no_route"):
                continue  # no route in it: the same bytes as without one
            value += 1
            with Recorder(f"{host}:{port}{suffix}") as d:
                mark = d.mark()
                result = shape_round(d, shape, value)
                result["wrote_2031"] = value
                if shape == "connected":
                    result["forward_open"] = connected_open(d, mark)
                    sequences = [m["sequence"] for m in d.since(mark) if m["dir"] == ">" and "sequence" in m]
                    echoed = [m["sequence"] for m in d.since(mark) if m["dir"] == "<" and "sequence" in m]
                    result["sequences_sent"] = sequences
                    result["sequences_echoed"] = sequences == echoed
                    opened = result["forward_open"]
                    result["request"] = connection_ids(result["request"], opened)
                    result["reply"] = connection_ids(result["reply"], opened)
                    result["connection_ids_sent"] = sorted(
                        {
                            connection_ids(m, opened)["connection_id"]
                            for m in d.since(mark)
                            if m["dir"] == ">" and "connection_id" in m
                        }
                    )
                    del opened["ot_id"], opened["to_id"]
                close_mark = d.mark()
            # Leaving the with block: Forward_Close (connected only) and UnRegisterSession.
            closing = d.since(close_mark)
            result["closing"] = [
                f'{m["command"]} {m["cip"][:2]}' if "cip" in m else m["command"] for m in closing
            ]
            if shape == "connected":
                # Forward_Close: its reply status, and the triad echoed (serial, vendor,
                # originator serial: 8 bytes after priority/tick and timeout ticks).
                close = next(bytes.fromhex(m["cip"]) for m in closing if m["dir"] == ">" and m["cip"][:2] == "4e")
                reply = next(bytes.fromhex(m["cip"]) for m in closing if m["dir"] == "<")
                close_body = close[2 + 2 * close[1] :]
                result["forward_close"] = {
                    "reply_service": reply[0],
                    "reply_status": reply[2],
                    "triad_echoed": reply[4:12] == close_body[2:10],
                    "path": close_body[12 : 12 + 2 * close_body[10]].hex(),
                }
            out[shape + label] = result
    return out


def scenario_identity(host, port):
    out = {}
    # pycomm3's public classmethod: its own driver, RegisterSession, ListIdentity (TCP).
    identity = CIPDriver.list_identity(f"{host}:{port}")
    out["list_identity"] = jsonable(identity)
    with Recorder(f"{host}:{port}") as d:
        # The raw ListIdentity reply, for what pycomm3's dict leaves out (the vendor number,
        # the sockaddr's port).
        mark = d.mark()
        d.send(ListIdentityRequestPacket())
        raw = d.wire[mark + 1][1]
        item = raw[24 + 2 :]
        kind, _size, _version = struct.unpack_from("<HHH", item, 0)
        family, sin_port = struct.unpack_from(">hH", item, 6)
        sin_addr = socket.inet_ntoa(item[10:14])
        vendor, device_type, product_code = struct.unpack_from("<HHH", item, 22)
        out["list_identity_raw"] = {
            "item_type": kind,
            "sin_family": family,
            "sin_port": sin_port,
            "sin_addr": sin_addr,
            "vendor": vendor,
            "device_type": device_type,
            "product_code": product_code,
        }
        # get_module_info: Get_Attributes_All of Identity through Unconnected_Send, route
        # backplane slot 0.
        mark = d.mark()
        info = d.get_module_info(0)
        out["module_info"] = jsonable(info)
        sent = next(m for m in d.since(mark) if m["dir"] == ">")
        out["module_info_request"] = sent["unconnected_send"]
        # Get_Attribute_Single, decoded by pycomm3's types.
        shape = "unconnected"
        single = {}
        for attribute, data_type in ((1, UINT), (2, UINT), (3, UINT), (5, UINT), (6, UDINT), (7, SHORT_STRING)):
            r = call(d, shape, GET_ATTRIBUTE_SINGLE, class_code=IDENTITY_CLASS, attribute=attribute, data_type=data_type)
            single[str(attribute)] = r.get("value") if r["ok"] else r["error"]
        revision = call(d, shape, GET_ATTRIBUTE_SINGLE, class_code=IDENTITY_CLASS, attribute=4)
        single["4"] = revision.get("data")
        out["get_attribute_single"] = single
        missing = call(d, shape, GET_ATTRIBUTE_SINGLE, class_code=IDENTITY_CLASS, attribute=99)
        out["identity_attribute_99"] = brief(missing)
        # The same attributes in a class 3 connection.
        r = call(d, "connected", GET_ATTRIBUTE_SINGLE, class_code=IDENTITY_CLASS, attribute=7, data_type=SHORT_STRING)
        out["connected_product_name"] = r.get("value")
        # Assemblies: attribute 4 is the size, attribute 3 the data.
        out["assembly_sizes"] = {
            str(instance): call(d, shape, GET_ATTRIBUTE_SINGLE, class_code=ASSEMBLY_CLASS, instance=instance, attribute=4, data_type=UINT).get("value")
            for instance in (100, 101, 104, 105)
        }
        out["assembly_104_len"] = len(bytes.fromhex(call(d, shape, GET_ATTRIBUTE_SINGLE, class_code=ASSEMBLY_CLASS, instance=104, attribute=3)["data"]))
    return out


def scenario_discover(host, port):
    """pycomm3's discover: a ListIdentity datagram to broadcast_address, port 44818 (fixed
    in pycomm3), from a socket bound to each IPv4 address of this host's name."""
    if port != 44818:
        raise Failed("pycomm3's discover only asks port 44818")
    started = time.monotonic()
    devices = CIPDriver.discover(broadcast_address=host)
    return {
        "devices": [jsonable(d) for d in devices],
        "seconds": round(time.monotonic() - started, 3),
    }


def scenario_move(host, port):
    """The PDI over explicit messages (spec 2.2.11): set values first, Cmd last, then poll
    2292h:01 for the toggle and TargetReached and 6064h for the position."""
    shape = "unconnected"
    with Recorder(f"{host}:{port}") as d:
        out = {}
        status0 = value_int(get_od(d, shape, 0x2292, 1), signed=True) & 0xFFFF
        cmd0 = value_int(get_od(d, shape, 0x2291, 4))
        out["cmd_before"] = cmd0
        writes = [
            (1, struct.pack("<i", 2000)),  # SetValue1: target position
            (2, struct.pack("<h", 200)),  # SetValue2: speed
            (3, struct.pack("<b", 0)),  # SetValue3
            (4, bytes([MOVE_ABSOLUTE if cmd0 != MOVE_ABSOLUTE else MOVE_ABSOLUTE | 0x80])),
        ]
        out["writes"] = [set_od(d, shape, 0x2291, sub, value)["status"] for sub, value in writes]
        started = time.monotonic()
        polled = []
        deadline = started + 20
        while True:
            status = value_int(get_od(d, shape, 0x2292, 1), signed=True) & 0xFFFF
            position = value_int(get_od(d, shape, 0x6064, 0), signed=True)
            polled.append((status, position))
            if (status ^ status0) & TOGGLE_CMD and status & TARGET_REACHED and position == 2000:
                break
            if time.monotonic() > deadline:
                raise Failed(f"no arrival at 2000 within 20 s: last polls {polled[-5:]}")
            time.sleep(0.02)
        out["move_seconds"] = round(time.monotonic() - started, 3)
        out["positions_on_the_way"] = len({p for _, p in polled if 0 < p < 2000})
        out["left_target_reached"] = any(not s & TARGET_REACHED for s, _ in polled)
        out["arrived"] = {
            "toggled": bool((status ^ status0) & TOGGLE_CMD),
            "target_reached": bool(status & TARGET_REACHED),
            "error": bool(status & STATUS_ERROR),
            "position_6064": position,
            "return_value": value_int(get_od(d, shape, 0x2292, 2), signed=True),
            "error_code_603f": value_int(get_od(d, shape, 0x603F, 0)),
        }
        out["statusword_6041"] = value_int(get_od(d, shape, 0x6041, 0))
        out["rx_2291_read_back"] = [
            value_int(get_od(d, shape, 0x2291, sub), signed=True) for sub in (1, 2, 3, 4)
        ]
        # The PDI's T→O assembly (104) as a PLC would read it explicitly: PDI-Status,
        # 603Fh, ReturnValue.
        image = bytes.fromhex(
            call(d, shape, GET_ATTRIBUTE_SINGLE, class_code=ASSEMBLY_CLASS, instance=104, attribute=3)["data"]
        )
        pdi_status, error_code, return_value = struct.unpack_from("<HHi", image, 0)
        out["assembly_104"] = {
            "status_equals_2292_01": pdi_status == status,
            "error_code": error_code,
            "return_value": return_value,
        }
        return out


def jsonable(value):
    if isinstance(value, dict):
        return {k: jsonable(v) for k, v in value.items()}
    if isinstance(value, (bytes, bytearray)):
        return bytes(value).hex()
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    return value


def main(argv):
    if len(argv) != 4:
        raise Failed(f"usage: {argv[0]} HOST PORT SCENARIO")
    host, port, scenario = argv[1], int(argv[2]), argv[3]
    scenarios = {
        "unconnected": scenario_unconnected,
        "shapes": scenario_shapes,
        "identity": scenario_identity,
        "discover": scenario_discover,
        "move": scenario_move,
    }
    if scenario not in scenarios:
        raise Failed(f"unknown scenario {scenario}")
    out = scenarios[scenario](host, port)
    out["pycomm3"] = pycomm3.__version__
    return out


if __name__ == "__main__":
    try:
        print(json.dumps(main(sys.argv)), flush=True)
    except Exception as e:  # noqa: BLE001 - report anything as JSON for the Rust test
        print(json.dumps({"failed": f"{type(e).__name__}: {e}"}), flush=True)
        sys.exit(1)
