#!/bin/sh
# The vcan checks of `acq record` / `acq replay` / `acq simulate` against
# can-utils, run inside the VM by tests/vcan.rs (or natively on a host that
# has vcan0..vcan3: OUT=dir IN=dir sh acq-checks.sh). It only produces
# files in $OUT; tests/vcan.rs compares them and decides pass or fail.
#
# Inputs in $IN: variety.log (2000 frames of every kind, candump -L, on
# can0), rigs/, dbc/, scenarios/short.toml, examples/excavator-rig/ (the
# study at the rig and its hidden truth) with data/excavator/dx55.toml.
set -eu
OUT=${OUT:-/out}
IN=${IN:-/in}
say() { echo "acq-checks: $(date +%T) $*"; }
# candump, the witness of what went over the wire, with a receive buffer of
# 8 MiB (about 10,000 frames) instead of the kernel's default of about 300:
# the guest's CPU is emulated on a shared host, and a stall of a few
# milliseconds dropped 13 of 6525 frames from the witness's default buffer
# while acq's recording kept all of them (CI, 2026-12-05).
WITNESS_RCVBUF=8388608

# Wait until a recorder has opened its sockets (it writes session.toml then).
wait_for_session() {
    i=0
    while [ ! -f "$1/session.toml" ]; do
        i=$((i + 1))
        [ $i -lt 300 ] || { say "recorder did not start: $1"; exit 1; }
        sleep 0.1
    done
}

# vcan0 and vcan1 carry CAN FD frames; can0/can1 are vcans named like the rig's buses.
for dev in vcan0 vcan1; do
    ip link set "$dev" down
    ip link set "$dev" mtu 72
    ip link set "$dev" up
done
for dev in can0 can1; do
    ip link add dev "$dev" type vcan 2>/dev/null || true
    ip link set up "$dev"
done

say "1: canplayer -> acq record"
acq record --iface vcan0 --out "$OUT/c1" --quiet &
rec=$!
wait_for_session "$OUT/c1"
canplayer -I "$IN/variety.log" vcan0=can0
sleep 0.5
kill -INT $rec
wait $rec && echo "c1 exit 0" > "$OUT/c1.exit" || echo "c1 exit $?" > "$OUT/c1.exit"

say "2: acq replay -> candump -L"
candump -L -r "$WITNESS_RCVBUF" vcan1 > "$OUT/c2_candump.log" &
dump=$!
sleep 0.5
acq replay "$IN/variety.log" --iface vcan1 2> "$OUT/c2_replay.txt"
sleep 0.5
kill $dump; wait $dump || true

say "3: acq simulate -> acq record --rig (candump -L beside it)"
candump -L -r "$WITNESS_RCVBUF" can0 can1 > "$OUT/c3_candump.log" &
dump=$!
sleep 0.5
acq record --iface can0 --iface can1 --rig "$IN/rigs/excavator.toml" --out "$OUT/c3" --status-json > "$OUT/c3_status.jsonl" &
rec=$!
wait_for_session "$OUT/c3"
acq simulate --rig "$IN/rigs/excavator.toml" --scenario "$IN/scenarios/short.toml" --iface can0 --iface can1 --seed 11 2> "$OUT/c3_simulate.txt"
sleep 0.3
kill -INT $rec
wait $rec
kill $dump; wait $dump || true

say "4: Ctrl-C during a flood"
candump -L -r "$WITNESS_RCVBUF" vcan2 > "$OUT/c4_candump.log" &
dump=$!
acq record --iface vcan2 --out "$OUT/c4" --quiet &
rec=$!
wait_for_session "$OUT/c4"
cangen vcan2 -g 0 -I i -L 8 -D i -n 400000 &
gen=$!
sleep 1.5
kill -INT $rec
wait $rec
sleep 0.3
kill $gen 2>/dev/null || true
wait $gen 2>/dev/null || true
sleep 0.3
kill $dump; wait $dump || true
say "5: the interface disappears and comes back"
acq record --iface vcan3 --out "$OUT/c5" --quiet &
rec=$!
wait_for_session "$OUT/c5"
cangen vcan3 -g 2 -I 123 -L 8 -D i -n 50
# Let the last frame reach acq's socket: deleting the device drops what is
# still queued in the kernel, which no reader could have seen.
sleep 0.3
ip link del dev vcan3
sleep 1
ip link add dev vcan3 type vcan
ip link set up vcan3
sleep 1.5
cangen vcan3 -g 2 -I 124 -L 8 -D i -n 50
sleep 0.3
kill -INT $rec
wait $rec

say "7: both buses busy with the live page on and 10 viewers, one of them stalled, three reconnecting"
candump -L -r "$WITNESS_RCVBUF" can0 can1 > "$OUT/c7_candump.log" &
dump=$!
acq record --iface can0 --iface can1 --rig "$IN/rigs/excavator.toml" --out "$OUT/c7" --quiet \
    --view 127.0.0.1:8750 2> "$OUT/c7_stderr.txt" &
rec=$!
wait_for_session "$OUT/c7"
viewers=""
for i in 1 2 3 4 5 6 7 8 9; do
    wget -q -O /dev/null http://127.0.0.1:8750/api/events 2>/dev/null &
    viewers="$viewers $!"
done
# The stalled viewer: connected, its request sent, never reading. nc
# writes into a pipe nobody reads, so the socket's window fills up.
mkfifo /tmp/stall
sleep 600 < /tmp/stall &
holder=$!
(printf 'GET /api/events HTTP/1.1\r\nHost: 127.0.0.1:8750\r\n\r\n'; sleep 600) | nc 127.0.0.1 8750 > /tmp/stall &
stalled=$!
sleep 0.5
# A frame every 0.25 ms asked on each bus (the emulated CPU, shared with
# the generators, candump, the page and its viewers, sends a few thousand
# a second): TPDO1 of the bucket head pressure transducer (node 0x21) on
# can0, every frame decoded and plotted; random ids on can1. Check 4 is
# the flood at the VM's full rate, without the page: there the generator
# itself takes the CPU the readers need.
cangen can0 -g 0.25 -I 1A1 -L 8 -D i -n 400000 &
gen=$!
cangen can1 -g 0.25 -I i -L 8 -D i -n 400000 &
gen1=$!
sleep 1.5
# Three viewers leave mid-flood and three others come.
set -- $viewers
kill "$1" "$2" "$3" 2>/dev/null || true
viewers="$4 $5 $6 $7 $8 $9"
for i in 1 2 3; do
    wget -q -O /dev/null http://127.0.0.1:8750/api/events 2>/dev/null &
    viewers="$viewers $!"
done
sleep 1.5
wget -q -O "$OUT/c7_state.json" http://127.0.0.1:8750/api/state || true
kill -INT $rec
wait $rec && echo "0" > "$OUT/c7.exit" || echo "$?" > "$OUT/c7.exit"
sleep 0.3
kill $gen $gen1 2>/dev/null || true
wait $gen $gen1 2>/dev/null || true
sleep 0.3
kill $dump; wait $dump || true
kill $viewers $stalled $holder 2>/dev/null || true

say "8: a study at the rig updates while both buses are busy"
# The twin-driven virtual rig plays three holds at a hidden truth onto the
# rig's buses while a flood on ids the rig does not use fills both; the
# study samples its posterior after each hold on the same CPU, below the
# recorder's priority. The stop comes once the study has updated after
# the first hold (or after two minutes); the recorder then waits for it to
# take the last holds, and the flood goes on until the recorder has exited,
# so every update runs while the buses are busy.
candump -L -r "$WITNESS_RCVBUF" can0 can1 > "$OUT/c8_candump.log" &
dump=$!
acq record --iface can0 --iface can1 --rig "$IN/rigs/excavator.toml" --out "$OUT/c8" --quiet \
    --study "$IN/examples/excavator-rig/study.toml" 2> "$OUT/c8_stderr.txt" &
rec=$!
wait_for_session "$OUT/c8"
# Every 5 s: the time and how many updates the study has printed.
( while kill -0 $rec 2>/dev/null; do
    echo "$(date +%T) $(grep -c 'study: after' "$OUT/c8_stderr.txt")"
    sleep 5
done ) > "$OUT/c8_progress.txt" &
cangen can0 -g 2 -I 7F0 -L 8 -D i -n 400000 &
gen=$!
cangen can1 -g 2 -I 7F1 -L 8 -D i -n 400000 &
gen1=$!
acq simulate --rig "$IN/rigs/excavator.toml" --scenario "$IN/examples/excavator-rig/hidden_truth.toml" \
    --iface can0 --iface can1 --seed 8 2> "$OUT/c8_simulate.txt"
say "8: the virtual rig is done; waiting for the study"
i=0
while ! grep -q "study: after 1 hold(s)" "$OUT/c8_stderr.txt" && [ $i -lt 240 ]; do
    sleep 0.5
    i=$((i + 1))
done
# What the study had said while the buses were busy, before the stop.
cp "$OUT/c8_stderr.txt" "$OUT/c8_stderr_before_stop.txt"
kill -INT $rec
wait $rec && echo "0" > "$OUT/c8.exit" || echo "$?" > "$OUT/c8.exit"
sleep 0.3
kill $gen $gen1 2>/dev/null || true
wait $gen $gen1 2>/dev/null || true
sleep 0.3
kill $dump; wait $dump || true

say "6: the disk fills up during a recording"
mkdir -p /mnt/small
mount -t tmpfs -o size=2m tmpfs /mnt/small
acq record --iface vcan2 --out /mnt/small/c6 --quiet 2> "$OUT/c6_stderr.txt" &
rec=$!
wait_for_session /mnt/small/c6
cangen vcan2 -g 0 -I i -L 8 -D i -n 100000 &
gen=$!
code=0
wait $rec || code=$?
echo "$code" > "$OUT/c6.exit"
kill $gen 2>/dev/null || true
wait $gen 2>/dev/null || true
cp -r /mnt/small/c6 "$OUT/c6"
umount /mnt/small
say "done"
