#!/usr/bin/env bash
# A full read of the built-in catalog (`od list`: every readable object, through the worker
# with the PDI cycle running) per link, in rounds (each round visits every link once, so a
# noisy moment hits them alike), beside what the bus allows on paper.
#
#   bash benches/catalog_read.sh [ROUNDS]     (default 3; needs socat; builds --release)
#
# The paper limits, one object read = one request and one reply, nothing else on the bus:
# - Modbus RTU 19200 baud 8E1: 11 bits a character. FC 43 read of a 4-byte object: request
#   15 bytes (address, 12-byte PDU, CRC), reply 19; 34 x 11 / 19200 = 19.5 ms on the wire,
#   plus the 3 ms silence Nanotec asks after a reply: 22.5 ms, ~44 objects/s. Over a
#   pseudo-terminal the bytes take no time, only the silences are kept: it can beat that.
# - CANopen 1 Mbit/s, expedited SDO upload: two 8-byte frames of 111 bits (47 bits of frame,
#   64 data bits; bit stuffing adds up to ~20 more): 222 to 260 us, ~3 800 to 4 500 objects/s.
#   slcan over a pseudo-terminal carries ASCII at no bit rate: no bus limit applies there.
# - Modbus TCP / EtherNet/IP explicit on 100 Mbit/s Ethernet: ~90-byte request and reply
#   frames (Ethernet, IP, TCP headers and gaps included) take ~15 us: ~65 000 objects/s on
#   the wire; on loopback the limit is a TCP ping-pong, measured by `drivedeck bench`.
# - The built-in simulator and the in-memory CAN bus: no bus; the worker's own cost.
set -euo pipefail
ROUNDS=${1:-3}
cd "$(dirname "$0")/.."
cargo build --release --quiet
BIN=$PWD/target/release/drivedeck
DIR=$(mktemp -d)
PIDS=()
cleanup() { kill "${PIDS[@]}" 2>/dev/null || true; rm -rf "$DIR"; }
trap cleanup EXIT

port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }
MB=$(port); EN=$(port); IO=$(port)
"$BIN" sim --modbus-tcp "127.0.0.1:$MB" >/dev/null 2>&1 & PIDS+=($!)
"$BIN" sim --enip "127.0.0.1:$EN" --enip-io-port "$IO" >/dev/null 2>&1 & PIDS+=($!)
socat pty,raw,echo=0,link="$DIR/canA" pty,raw,echo=0,link="$DIR/canB" & PIDS+=($!)
socat pty,raw,echo=0,link="$DIR/rtuA" pty,raw,echo=0,link="$DIR/rtuB" & PIDS+=($!)
sleep 0.5
"$BIN" sim --slcan "$DIR/canA" --node 1 >/dev/null 2>&1 & PIDS+=($!)
"$BIN" sim --modbus-rtu "$DIR/rtuA" >/dev/null 2>&1 & PIDS+=($!)
sleep 1

NAMES=(
  "built-in simulator|sim|no bus"
  "CANopen, simulated node, in-memory bus (SDO)|canopen+sim://?node=1|no bus"
  "Modbus TCP, served simulator, loopback (FC 43)|modbus-tcp://127.0.0.1:$MB|loopback ping-pong (bench); ~65 000/s on 100 Mbit/s"
  "EtherNet/IP explicit, loopback (GetOD 32h)|enip://127.0.0.1:$EN?io=explicit|loopback ping-pong; ~65 000/s on 100 Mbit/s"
  "EtherNet/IP, class 1 I/O at RPI 10 ms beside|enip://127.0.0.1:$EN?io=pdi&rpi=10|as explicit, less the I/O"
  "CANopen over slcan on a pseudo-terminal (SDO)|canopen+slcan://$DIR/canB?node=1|~3 800-4 500/s on a 1 Mbit/s bus"
  "Modbus RTU on a pseudo-terminal, 19200 8E1 (FC 43)|modbus-rtu://$DIR/rtuB|~44/s at 19200 baud"
)
declare -A RESULTS
for round in $(seq 1 "$ROUNDS"); do
  for entry in "${NAMES[@]}"; do
    IFS='|' read -r name link limit <<<"$entry"
    line=$("$BIN" --link "$link" od list 2>&1 >/dev/null | grep -o 'read [0-9]* of [0-9]* objects in [0-9.]* s' | tail -1 || true)
    echo "round $round  $name: ${line:-no figure}" >&2
    RESULTS[$name]+="${line:+$line;}"
  done
done

echo "| link | objects | time per full read (each round) | objects/s (best) | paper limit, objects/s |"
echo "| --- | ---: | ---: | ---: | --- |"
for entry in "${NAMES[@]}"; do
  IFS='|' read -r name link limit <<<"$entry"
  python3 - "$name" "$limit" "${RESULTS[$name]}" <<'EOF'
import re, sys
name, limit, runs = sys.argv[1], sys.argv[2], sys.argv[3]
figs = [(int(m[0]), int(m[1]), float(m[2])) for m in re.findall(r"read (\d+) of (\d+) objects in ([\d.]+) s", runs)]
if not figs:
    print(f"| {name} | - | no figure | - | {limit} |")
else:
    n = figs[0][1]
    times = " / ".join(f"{t:.2f} s" for _, _, t in figs)
    best = max(r / t for r, _, t in figs if t > 0) if any(t > 0 for _, _, t in figs) else float("inf")
    rate = f"{best:,.0f}".replace(",", " ")
    # The worker prints the time to 10 ms: a read that short is a lower bound of the rate.
    if min(t for _, _, t in figs) < 0.05:
        rate = "≥ " + rate
    print(f"| {name} | {n} | {times} | {rate} | {limit} |")
EOF
done
