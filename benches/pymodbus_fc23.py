#!/usr/bin/env python3
"""The independent client of `drivedeck bench`: pymodbus doing the PDI exchange drivedeck
does, one FC 23 (read/write multiple registers) per cycle: write 5996..5999, read
4996..4999 (or READ registers from 4996: 11 is the PDI and the factory TX image, what
drivedeck's client reads), against the same Modbus TCP server.

    python3 pymodbus_fc23.py HOST PORT SECONDS [READ]

Like drivedeck's bench it never commands anything: it reads the RX registers the drive
holds (FC 3 at 5996) and writes them back. Prints one JSON object with the round-trip
figures; on a failure {"failed": "..."} and exit code 1.
"""

import json
import sys
import time

try:
    import pymodbus
    from pymodbus.client import ModbusTcpClient
except ImportError as e:  # the caller says how to install it
    print(json.dumps({"failed": f"pymodbus is not installed: {e}"}))
    sys.exit(1)

PDI_RX = 5996
PDI_TX = 4996


def main():
    host, port, seconds = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
    read = int(sys.argv[4]) if len(sys.argv) > 4 else 4
    client = ModbusTcpClient(host, port=port, timeout=2, retries=0)
    if not client.connect():
        raise RuntimeError(f"cannot connect to {host}:{port}")
    try:
        r = client.read_holding_registers(PDI_RX, count=4, device_id=0)
        if r.isError():
            raise RuntimeError(f"FC 3 at {PDI_RX}: {r}")
        rx = list(r.registers)
        rtts = []
        start = time.perf_counter()
        while time.perf_counter() - start < seconds:
            sent = time.perf_counter()
            r = client.readwrite_registers(
                read_address=PDI_TX,
                read_count=read,
                write_address=PDI_RX,
                values=rx,
                device_id=0,
            )
            rtts.append(time.perf_counter() - sent)
            if r.isError():
                raise RuntimeError(f"FC 23: {r}")
        span = time.perf_counter() - start
    finally:
        client.close()
    rtts.sort()

    def at(q):
        return rtts[round((len(rtts) - 1) * q)] * 1000.0

    print(
        json.dumps(
            {
                "what": f"pymodbus {pymodbus.__version__} FC 23 (write + read)",
                "count": len(rtts),
                "seconds": span,
                "per_second": len(rtts) / span,
                "min_ms": rtts[0] * 1000.0,
                "median_ms": at(0.5),
                "p99_ms": at(0.99),
                "max_ms": rtts[-1] * 1000.0,
            }
        )
    )


if __name__ == "__main__":
    try:
        main()
    except Exception as e:  # noqa: BLE001 - reported as JSON to the Rust side
        print(json.dumps({"failed": str(e)}))
        sys.exit(1)
