#!/usr/bin/env python3
"""python-canopen masters two simulated drives on one CAN bus, as an integrator would,
against `drivedeck sim --slcan A --node 5 --node 6` on the other end of a pseudo-terminal
pair.

    canopen_two_nodes.py PTY

The object dictionary and the polling helper are canopen_master.py's (written from the
spec, not from drivedeck's catalog). Each drive is moved through the PDI over SDO (spec
2.2.11: set values first, Cmd last) while the other one's position is read between the
first one's SDO transfers.

Prints one JSON object on stdout; on a failure it prints {"failed": "..."} and exits 1.
The Rust test (tests/multi_drive_sim.rs) asserts every field.
"""

import json
import sys
import threading
import time
import traceback

import canopen

from canopen_master import (
    MOVE_ABSOLUTE,
    SDO_TIMEOUT,
    TARGET_REACHED,
    TOGGLE_CMD,
    dictionary,
    wait_for,
)

NODES = (5, 6)


class Heartbeats:
    """The NMT states each node sent on 700h+N (boot-up = 0)."""

    def __init__(self, network):
        self.lock = threading.Lock()
        self.states = {node: [] for node in NODES}
        for node in NODES:
            network.subscribe(0x700 + node, self.on_frame)

    def on_frame(self, can_id, data, timestamp):
        with self.lock:
            self.states[can_id - 0x700].append(data[0] & 0x7F)

    def mark(self):
        with self.lock:
            return {node: len(states) for node, states in self.states.items()}

    def since(self, mark):
        with self.lock:
            return {node: list(self.states[node][mark[node]:]) for node in NODES}


def move(mover, other, target):
    """Move `mover` to `target` over SDO; `other`'s position, read between the polls."""
    status0 = mover.sdo[0x2292][1].raw
    mover.sdo[0x2291][1].raw = target
    mover.sdo[0x2291][2].raw = 300
    mover.sdo[0x2291][4].raw = MOVE_ABSOLUTE
    others = []
    polled = []

    def arrived():
        status = mover.sdo[0x2292][1].raw
        position = mover.sdo[0x6064].raw
        others.append(other.sdo[0x6064].raw)
        polled.append((status, position))
        if (status ^ status0) & TOGGLE_CMD and status & TARGET_REACHED:
            return position
        return None

    position = wait_for(f"node {mover.id} at {target}", arrived, seen=polled)
    on_the_way = len({p for _, p in polled if p != position})
    return position, sorted(set(others)), on_the_way


def run(path):
    out = {}
    network = canopen.Network()
    network.connect(
        interface="slcan", channel=path, bitrate=1000000, sleep_after_open=0
    )
    try:
        network.scanner.search()
        wait_for(
            "answers to the scan",
            lambda: all(n in network.scanner.nodes for n in NODES),
        )
        time.sleep(0.2)
        out["scanner_nodes"] = sorted(network.scanner.nodes)

        heartbeats = Heartbeats(network)
        nodes = {}
        for node_id in NODES:
            node = canopen.RemoteNode(node_id, dictionary())
            node.sdo.RESPONSE_TIMEOUT = SDO_TIMEOUT
            network.add_node(node)
            nodes[node_id] = node

        # NMT reset communication to all (node id 0): every node boots again.
        mark = heartbeats.mark()
        network.nmt.send_command(0x82)
        wait_for(
            "both boot-ups",
            lambda: all(0 in s for s in heartbeats.since(mark).values()),
        )
        out["booted"] = sorted(n for n, s in heartbeats.since(mark).items() if 0 in s)
        # Each node its own heartbeat time, then NMT start to all: both Operational.
        for node_id, node in nodes.items():
            node.sdo[0x1017].raw = 40 + node_id
        mark = heartbeats.mark()
        network.nmt.state = "OPERATIONAL"
        wait_for(
            "both Operational",
            lambda: all(5 in s for s in heartbeats.since(mark).values()),
        )
        out["operational"] = sorted(
            n for n, s in heartbeats.since(mark).items() if 5 in s
        )
        # Each node answers its own SDOs: 1014h is the EMCY COB-ID, 80h + node id.
        out["emcy_cob_1014"] = {
            str(n): int.from_bytes(node.sdo.upload(0x1014, 0), "little")
            for n, node in nodes.items()
        }
        out["heartbeat_1017"] = {str(n): node.sdo[0x1017].raw for n, node in nodes.items()}

        for node in nodes.values():
            node.sdo[0x2290].raw = 1
        # Node 5 moves, node 6 stands; then node 6 moves, node 5 stays where it went.
        position, others, on_the_way = move(nodes[5], nodes[6], 1200)
        out["node_5_moved"] = {
            "position": position,
            "on_the_way": on_the_way > 0,
            "node_6_seen_at": others,
        }
        position, others, on_the_way = move(nodes[6], nodes[5], -600)
        out["node_6_moved"] = {
            "position": position,
            "on_the_way": on_the_way > 0,
            "node_5_seen_at": others,
        }
    finally:
        network.disconnect()
    return out


def main():
    try:
        out = run(sys.argv[1])
    except Exception as e:  # noqa: BLE001 - every failure becomes the JSON line
        traceback.print_exc()
        print(json.dumps({"failed": f"{type(e).__name__}: {e}"}), flush=True)
        sys.exit(1)
    print(json.dumps(out), flush=True)


if __name__ == "__main__":
    main()
