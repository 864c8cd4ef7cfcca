#!/usr/bin/env python3
"""pymodbus as a plain Modbus TCP register bank: holding and input registers 4990..6100
(one shared address space, as on a Nanotec drive), device ids 0 and 5, and no FC 43
(pymodbus answers MEI 0Dh with exception 01). It knows nothing of the PDI.

    pymodbus_server.py [PRESET_JSON]     PRESET_JSON: {"4996": 16393, ...} register values

Prints {"port": N} once it listens on 127.0.0.1 (a free port), then one JSON line per
request it receives, as pymodbus decoded it off the wire:
    {"fc": 23, "unit": 0, "write_address": 5996, "values": [...], "read_address": 4996, "read_count": 11}
Exits when stdin closes (the test that started it has gone) or after 120 s.
"""

import asyncio
import json
import os
import sys
import threading

from pymodbus.server import ModbusTcpServer
from pymodbus.simulator import DataType, SimData, SimDevice

FIRST = 4990
LAST = 6100


def describe(pdu):
    """A received request as JSON: which function, which unit, what it writes or reads."""
    line = {"fc": pdu.function_code, "unit": pdu.dev_id}
    if hasattr(pdu, "write_registers"):  # FC 23
        line.update(
            write_address=pdu.write_address,
            values=list(pdu.write_registers),
            read_address=pdu.read_address,
            read_count=pdu.read_count,
        )
    elif pdu.function_code in (6, 16):
        line.update(write_address=pdu.address, values=list(pdu.registers))
    elif pdu.function_code in (3, 4):
        line.update(read_address=pdu.address, read_count=pdu.count)
    return line


def trace(sending, pdu):
    if not sending:
        print(json.dumps(describe(pdu)), flush=True)
    return pdu


def watch_stdin():
    """End the process when whoever started it closes our stdin."""
    try:
        while sys.stdin.buffer.read(4096):
            pass
    finally:
        os._exit(0)


async def main(preset):
    values = [0] * (LAST - FIRST + 1)
    for address, value in preset.items():
        values[int(address) - FIRST] = int(value) & 0xFFFF
    devices = [
        SimDevice(id=unit, simdata=[SimData(FIRST, values=list(values), datatype=DataType.REGISTERS)])
        for unit in (0, 5)
    ]
    server = ModbusTcpServer(devices, address=("127.0.0.1", 0), trace_pdu=trace)
    await server.serve_forever(background=True)
    port = server.transport.sockets[0].getsockname()[1]
    print(json.dumps({"port": port}), flush=True)
    try:
        await asyncio.wait_for(server.serving, timeout=120)
    except asyncio.TimeoutError:
        pass
    await server.shutdown()


if __name__ == "__main__":
    threading.Thread(target=watch_stdin, daemon=True).start()
    asyncio.run(main(json.loads(sys.argv[1]) if len(sys.argv) > 1 else {}))
