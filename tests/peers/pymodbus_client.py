#!/usr/bin/env python3
"""A PLC programmer's view of a Nanotec drive over Modbus, with pymodbus and nothing of
drivedeck: the PDI is driven by plain register writes and reads, packed by hand from the
spec (PDI spec §3.2, protocol notes §1.2 to §1.6), never through drivedeck's codec.

    pymodbus_client.py tcp HOST PORT SCENARIO     SCENARIO: move, objects, access, connections
    pymodbus_client.py rtu PATH                   factory settings: slave 5, 19200 8E1

Prints one JSON object on stdout; on a failure it prints {"failed": "..."} and exits 1.
The Rust tests (tests/modbus_peers.rs, tests/modbus_rtu.rs) assert every field.
"""

import errno
import json
import os
import socket
import struct
import sys
import termios
import time

from pymodbus import pymodbus_apply_logging_config
from pymodbus.client import ModbusSerialClient, ModbusTcpClient
from pymodbus.pdu import ModbusPDU

# Registers (0-based PDU addresses), protocol notes §1.2 and §1.3.
PDI_RX = 5996  # SetValue1 hi, SetValue1 lo, SetValue2, SetValue3 (high byte) | Cmd (low byte)
PDI_TX = 4996  # PDI-Status, 603Fh, ReturnValue hi, ReturnValue lo
TX_IMAGE = 5000  # 6041h, dummy|6061h, 6064h hi, 6064h lo, 6044h, 60FDh hi, 60FDh lo

# PDI-Status bits.
TARGET_REACHED = 1 << 3
TOGGLE_CMD = 1 << 14
STATUS_ERROR = 1 << 15
# PDI-Cmd bit 7: the toggle that makes a repeated command new.
CMD_TOGGLE = 0x80

# PDI-Cmd opcodes (PDI spec §2.2).
OD_READ = 14
OD_WRITE = 15
MOVE_ABSOLUTE = 20


class Failed(Exception):
    pass


def pack(value1=0, value2=0, value3=0, cmd=0):
    """Registers 5996..5999 for a PDI command, as the spec lays them out."""
    v1 = value1 & 0xFFFFFFFF
    return [v1 >> 16, v1 & 0xFFFF, value2 & 0xFFFF, ((value3 & 0xFF) << 8) | (cmd & 0xFF)]


def u32(high, low):
    return (high << 16) | low


def s32(high, low):
    return struct.unpack(">i", struct.pack(">HH", high, low))[0]


class Pdi:
    """The PDI as a PLC program drives it: write 5996..5999, poll 4996..4999."""

    def __init__(self, client, unit):
        self.client = client
        self.unit = unit
        # Start from the command byte the drive holds, so the first command is new.
        self.last_cmd = self.read(3, PDI_RX, 4)[3] & 0xFF

    def read(self, fc, address, count):
        call = self.client.read_holding_registers if fc == 3 else self.client.read_input_registers
        r = call(address, count=count, device_id=self.unit)
        if r.isError():
            raise Failed(f"FC {fc} read of {count} at {address}: {r}")
        return list(r.registers)

    def tx(self):
        return self.read(4, PDI_TX, 4)

    def next_cmd(self, opcode):
        """The command byte for `opcode`: the toggle bit flips when it would repeat."""
        byte = opcode | (self.last_cmd & CMD_TOGGLE)
        if byte == self.last_cmd:
            byte ^= CMD_TOGGLE
        return byte

    def wait_toggle(self, before, timeout=2.0):
        """Poll 4996..4999 until PdiStatusToggleCmd differs from `before`; None if never."""
        deadline = time.monotonic() + timeout
        while True:
            tx = self.tx()
            if (tx[0] ^ before) & TOGGLE_CMD:
                return tx
            if time.monotonic() > deadline:
                return None
            time.sleep(0.01)

    def write(self, registers, address=PDI_RX):
        r = self.client.write_registers(address, registers, device_id=self.unit)
        if r.isError():
            raise Failed(f"FC 16 write of {registers} at {address}: {r}")

    def command(self, opcode, value1=0, value2=0, value3=0, fc=16, cmd=None):
        """Send one command and wait for the drive to take it. Returns the TX registers
        with the toggle flipped, or None when the drive never flipped it."""
        before = self.tx()[0]
        byte = self.next_cmd(opcode) if cmd is None else cmd
        registers = pack(value1, value2, value3, byte)
        if fc == 23:
            r = self.client.readwrite_registers(
                read_address=PDI_TX,
                read_count=4,
                write_address=PDI_RX,
                values=registers,
                device_id=self.unit,
            )
            if r.isError():
                raise Failed(f"FC 23 with {registers}: {r}")
            tx = list(r.registers)
            if not (tx[0] ^ before) & TOGGLE_CMD:
                tx = self.wait_toggle(before)
        else:
            self.write(registers)
            tx = self.wait_toggle(before, timeout=2.0 if cmd is None else 0.3)
        self.last_cmd = byte
        return tx

    def od(self, opcode, index, sub, value=0, fc=16, cmd=None):
        tx = self.command(opcode, value, index, sub, fc=fc, cmd=cmd)
        if tx is None:
            return {"toggled": False}
        out = {"toggled": True, "error": bool(tx[0] & STATUS_ERROR)}
        # ReturnValue: the object's value after OD-Read, the error code after a failure;
        # the spec leaves it open after a good OD-Write.
        if opcode == OD_READ or out["error"]:
            out["return_value"] = s32(tx[2], tx[3])
            out["return_value_u32"] = u32(tx[2], tx[3])
        return out


def exception_code(response):
    return response.exception_code if response.isError() else None


class UserFunction(ModbusPDU):
    """Function code 41h (user-defined in the Modbus spec), which a Nanotec drive lacks."""

    function_code = 0x41
    rtu_frame_size = 0

    def encode(self):
        return b"\x00\x01"

    def decode(self, data):
        self.data = data


def tcp_client(host, port):
    client = ModbusTcpClient(host, port=port, timeout=2, retries=0)
    if not client.connect():
        raise Failed(f"cannot connect to {host}:{port}")
    return client


def scenario_move(client):
    """An absolute move to 2000 at 200 rpm, watched through PDI-Status and 5000..5006."""
    pdi = Pdi(client, 0)
    started = time.monotonic()
    tx = pdi.command(MOVE_ABSOLUTE, 2000, 200, 0)
    if tx is None:
        raise Failed("the move was never acknowledged (PdiStatusToggleCmd did not flip)")
    accepted_error = bool(tx[0] & STATUS_ERROR)
    seen_on_the_way = set()
    left_target = False
    deadline = time.monotonic() + 8.0
    while True:
        tx = pdi.tx()
        image = pdi.read(4, TX_IMAGE, 7)
        position = s32(image[2], image[3])
        if not tx[0] & TARGET_REACHED:
            left_target = True
            if 0 < position < 2000:
                seen_on_the_way.add(position)
        elif left_target:
            break
        if time.monotonic() > deadline:
            raise Failed(f"no PdiStatusTargetReached within 8 s; PDI-Status {tx[0]:04X}h, position {position}")
        time.sleep(0.01)
    return {
        "accepted_error": accepted_error,
        "left_target": left_target,
        "positions_on_the_way": len(seen_on_the_way),
        "target_reached": bool(tx[0] & TARGET_REACHED),
        "status_error": bool(tx[0] & STATUS_ERROR),
        "error_code_603f": tx[1],
        "return_value": s32(tx[2], tx[3]),
        "statusword_6041": image[0],
        "mode_6061": image[1] & 0xFF,
        "position_6064": position,
        "velocity_6044": struct.unpack(">h", struct.pack(">H", image[4]))[0],
        "seconds": round(time.monotonic() - started, 3),
    }


def scenario_objects(client):
    """OD-Read and OD-Write through the PDI, with the toggle for repeated commands."""
    pdi = Pdi(client, 0)
    out = {}
    # OD-Read 1018h:01 in one FC 23 transaction.
    out["read_1018_01"] = pdi.od(OD_READ, 0x1018, 1, fc=23)
    # The same command byte again (only the subindex differs): not a new command.
    same = pdi.last_cmd
    out["repeat_without_toggle"] = pdi.od(OD_READ, 0x1018, 2, cmd=same)
    out["return_value_after_ignored_repeat"] = s32(*pdi.tx()[2:4])
    # With the toggle bit flipped it is.
    out["repeat_with_toggle"] = pdi.od(OD_READ, 0x1018, 2)
    out["cmd_byte_of_repeat"] = pdi.last_cmd
    # OD-Write then OD-Read back.
    out["write_203b_01"] = pdi.od(OD_WRITE, 0x203B, 1, value=1000)
    out["read_203b_01"] = pdi.od(OD_READ, 0x203B, 1)
    # A value that needs both words and its sign: NanoJ input 2400h:01, i32.
    out["write_2400_01"] = pdi.od(OD_WRITE, 0x2400, 1, value=-100000)
    out["read_2400_01"] = pdi.od(OD_READ, 0x2400, 1)
    # A missing object: PdiStatusError and the abort code in ReturnValue.
    out["read_2fff_00"] = pdi.od(OD_READ, 0x2FFF, 0)
    # The next good command clears PdiStatusError.
    out["read_after_error"] = pdi.od(OD_READ, 0x1018, 1)
    return out


def scenario_access(client):
    """Function codes and exceptions on the register map."""
    out = {}
    pdi = Pdi(client, 0)

    def regs(fc, address, count):
        call = client.read_holding_registers if fc == 3 else client.read_input_registers
        r = call(address, count=count, device_id=0)
        return None if r.isError() else list(r.registers)

    # Set values first, command byte untouched: nothing runs.
    before = pdi.tx()[0]
    pdi.write(pack(0, 0x1018, 0, 0)[:3])
    time.sleep(0.3)
    out["toggled_by_set_values_alone"] = bool((pdi.tx()[0] ^ before) & TOGGLE_CMD)
    # FC 6 on 5999 alone: SetValue3 = subindex 1 in the high byte, OD-Read in the low byte.
    cmd = pdi.next_cmd(OD_READ)
    r = client.write_register(PDI_RX + 3, (1 << 8) | cmd, device_id=0)
    out["fc6_exception"] = exception_code(r)
    tx = pdi.wait_toggle(before)
    out["fc6_toggled"] = tx is not None
    out["fc6_return_value"] = s32(tx[2], tx[3]) if tx else None
    # FC 3 and FC 4 read the same registers (holding and input share one address space).
    out["fc3_tx"] = regs(3, PDI_TX, 11)
    out["fc4_tx"] = regs(4, PDI_TX, 11)
    out["fc3_rx"] = regs(3, PDI_RX, 4)
    out["fc4_rx"] = regs(4, PDI_RX, 4)
    # Exceptions.
    out["fc3_at_100"] = exception_code(client.read_holding_registers(100, count=1, device_id=0))
    out["fc4_at_100"] = exception_code(client.read_input_registers(100, count=1, device_id=0))
    out["fc16_at_100"] = exception_code(client.write_registers(100, [1], device_id=0))
    out["fc4_past_tx_image"] = exception_code(client.read_input_registers(PDI_TX, count=12, device_id=0))
    out["fc22_mask_write"] = exception_code(
        client.mask_write_register(address=PDI_RX + 3, and_mask=0xFFFF, or_mask=0, device_id=0)
    )
    client.register(UserFunction)
    out["fc41_user_function"] = exception_code(client.execute(False, UserFunction(dev_id=0)))
    # The link still works after the exceptions.
    out["fc4_after_exceptions"] = regs(4, PDI_TX, 4) is not None
    return out


def second_client(host, port):
    """A raw second connection: 'closed' when the server drops it, 'answered' otherwise."""
    s = socket.create_connection((host, port), timeout=2)
    try:
        # FC 4, 4 registers at 4996, transaction 7, unit 0.
        s.sendall(bytes([0, 7, 0, 0, 0, 6, 0, 4, 0x13, 0x84, 0, 4]))
        data = s.recv(256)
        return "answered" if data else "closed"
    except (ConnectionResetError, BrokenPipeError):
        return "closed"
    except socket.timeout:
        return "silent"
    finally:
        s.close()


def scenario_connections(client, host, port):
    """One Modbus TCP connection at a time, like the drive."""
    out = {}
    pdi = Pdi(client, 0)
    out["first_reads"] = len(pdi.tx()) == 4
    out["second_client"] = second_client(host, port)
    out["first_reads_after_second"] = len(pdi.tx()) == 4
    client.close()
    # Once the first has gone, a new client gets in.
    deadline = time.monotonic() + 3.0
    released = False
    while time.monotonic() < deadline and not released:
        again = ModbusTcpClient(host, port=port, timeout=1, retries=0)
        try:
            if again.connect():
                r = again.read_input_registers(PDI_TX, count=4, device_id=0)
                released = not r.isError()
        except Exception:  # noqa: BLE001 - refused while the old one is still closing
            released = False
        finally:
            again.close()
        if not released:
            time.sleep(0.05)
    out["new_client_after_first_left"] = released
    return out


def tolerate_pty_parity():
    """On a pseudo-terminal the kernel drops PARENB (a pty carries no parity bits), and
    glibc's tcsetattr then reports EINVAL whenever nothing else changed. pyserial applies
    the settings twice when pymodbus opens the port, so parity E could never open a pty.
    Accept exactly that case; anything else still fails."""
    original = termios.tcsetattr
    state = {"used": False}

    def tcsetattr(fd, when, attributes):
        try:
            original(fd, when, attributes)
        except termios.error as e:
            if e.args[0] != errno.EINVAL or not os.ttyname(fd).startswith("/dev/pts/"):
                raise
            # Only the parity bits may have been dropped: size, stop bits and receiver stay.
            kept = termios.CSIZE | termios.CSTOPB | termios.CREAD
            if termios.tcgetattr(fd)[2] & kept != attributes[2] & kept:
                raise
            state["used"] = True

    termios.tcsetattr = tcsetattr
    return state


def scenario_rtu(path):
    # Every frame on stderr, with times: shown only when the test fails.
    pymodbus_apply_logging_config("DEBUG")
    shim = tolerate_pty_parity()
    client = ModbusSerialClient(port=path, baudrate=19200, parity="E", stopbits=1, bytesize=8, timeout=2, retries=0)
    if not client.connect():
        raise Failed(f"cannot open {path}")
    try:
        pdi = Pdi(client, 5)
        first = pdi.tx()
        read = pdi.od(OD_READ, 0x1018, 1)
        return {
            "tx_registers": first,
            "read_1018_01": read,
            "pty_parity_shim": shim["used"],
        }
    finally:
        client.close()


def main(argv):
    if len(argv) >= 2 and argv[1] == "rtu":
        return scenario_rtu(argv[2])
    if len(argv) != 5 or argv[1] != "tcp":
        raise Failed(f"usage: {argv[0]} tcp HOST PORT SCENARIO | rtu PATH")
    host, port, scenario = argv[2], int(argv[3]), argv[4]
    client = tcp_client(host, port)
    try:
        if scenario == "move":
            return scenario_move(client)
        if scenario == "objects":
            return scenario_objects(client)
        if scenario == "access":
            return scenario_access(client)
        if scenario == "connections":
            return scenario_connections(client, host, port)
        raise Failed(f"unknown scenario {scenario}")
    finally:
        client.close()


if __name__ == "__main__":
    try:
        print(json.dumps(main(sys.argv)), flush=True)
    except Exception as e:  # noqa: BLE001 - report anything as JSON for the Rust test
        print(json.dumps({"failed": f"{type(e).__name__}: {e}"}), flush=True)
        sys.exit(1)
