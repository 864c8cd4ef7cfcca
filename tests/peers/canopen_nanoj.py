#!/usr/bin/env python3
"""Read the NanoJ program's status and error code as an integrator would, with
python-canopen's SDO client and nothing of drivedeck, from the simulated drive served by
`drivedeck sim --slcan A --node N` on the other end of a pseudo-terminal pair.

    canopen_nanoj.py PTY NODE

The objects are defined here from Nanotec's manuals (2301h NanoJ Status, 2302h NanoJ
Error Code, both UNSIGNED32 read only), not from drivedeck's catalog. Prints one JSON
object: {"status_2301": ..., "error_2302": ...}; on a failure {"failed": "..."}, exit 1.
"""

import json
import sys
import traceback

import canopen
from canopen import objectdictionary as odm


def dictionary():
    od = odm.ObjectDictionary()
    for name, index in (("NanoJ Status", 0x2301), ("NanoJ Error Code", 0x2302)):
        var = odm.ODVariable(name, index, 0)
        var.data_type = odm.UNSIGNED32
        var.access_type = "ro"
        od.add_object(var)
    return od


def main():
    path, node_id = sys.argv[1], int(sys.argv[2])
    network = canopen.Network()
    network.connect(interface="slcan", channel=path, bitrate=1000000, sleep_after_open=0)
    try:
        node = canopen.RemoteNode(node_id, dictionary())
        node.sdo.RESPONSE_TIMEOUT = 2.0
        network.add_node(node)
        out = {
            "status_2301": node.sdo["NanoJ Status"].raw,
            "error_2302": node.sdo["NanoJ Error Code"].raw,
        }
        print(json.dumps(out))
    finally:
        network.disconnect()


if __name__ == "__main__":
    try:
        main()
    except Exception as e:  # noqa: BLE001 - the test wants the reason, whatever it is
        traceback.print_exc()
        print(json.dumps({"failed": f"{type(e).__name__}: {e}"}))
        sys.exit(1)
