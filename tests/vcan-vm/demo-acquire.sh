#!/bin/sh
# The acquisition half of `acq demo` on a real vcan, run inside the VM by
# tests/vcan.rs (or natively on a host with vcan0/vcan1: OUT=dir IN=dir sh
# demo-acquire.sh): the shipped sessions in $IN/fixtures/sessions played on
# vcan0/vcan1 with their original timing and recorded again from them. A
# candump on each interface is the independent witness of what went over
# the bus. The host analyses the recordings (acq demo --sessions).
set -eu
OUT=${OUT:-/out}
IN=${IN:-/in}
# The witnesses' receive buffer: 8 MiB, as in acq-checks.sh (why: there).
WITNESS_RCVBUF=8388608
candump -L -r "$WITNESS_RCVBUF" vcan0 > "$OUT/candump_vcan0.log" &
dump0=$!
candump -L -r "$WITNESS_RCVBUF" vcan1 > "$OUT/candump_vcan1.log" &
dump1=$!
sleep 0.5
acq demo --iface vcan0 --iface vcan1 --acquire-only --data "$IN" --out "$OUT/demo"
echo "demo-acquire: acq demo exit $?"
sleep 0.5
kill -INT $dump0 $dump1
wait $dump0 $dump1 || true
