#!/bin/sh
# Smoke test for the vcan VM (and an example of the guest-script convention):
#   - plain POSIX sh (the VM has busybox ash, no bash);
#   - outputs go to "$OUT" (the VM sets OUT=/out and ships it back to run --out);
#   - uses vcan0 and vcan1, which the VM creates (natively: create them yourself).
# Natively on a host with vcan:  OUT=/tmp/smoke-out sh tests/vcan-vm/smoke.sh
# In the VM:                     tests/vcan-vm/run --script tests/vcan-vm/smoke.sh --out /tmp/vm-smoke
set -eu

OUT=${OUT:-/out}
mkdir -p "$OUT"
N=200

# Give candump a moment to bind before traffic starts (it prints nothing when ready).
settle() { sleep 0.5; }

# Wait until FILE has N lines (candump writes as frames arrive), at most ~10 s.
wait_lines() {
    i=0
    while [ "$(wc -l < "$1")" -lt "$2" ] && [ "$i" -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
}

stop() {
    kill "$1" 2>/dev/null || true
    wait "$1" 2>/dev/null || true
}

echo "smoke: uname -r = $(uname -r)"
ip link show

# 1. cangen -> vcan0, captured by candump.
candump -L vcan0 > "$OUT/dump.log" &
dump0=$!
settle
cangen vcan0 -n "$N" -g 1
wait_lines "$OUT/dump.log" "$N"
stop "$dump0"
got=$(wc -l < "$OUT/dump.log")
echo "smoke: candump captured $got/$N frames on vcan0"
[ "$got" -eq "$N" ] || { echo "smoke: FAIL: expected $N frames on vcan0"; exit 1; }

# 2. Replay the log onto vcan1 (log interface vcan0 -> vcan1) and capture it again.
candump -L vcan1 > "$OUT/replay.log" &
dump1=$!
settle
canplayer -I "$OUT/dump.log" vcan1=vcan0
wait_lines "$OUT/replay.log" "$N"
stop "$dump1"
got=$(wc -l < "$OUT/replay.log")
echo "smoke: replay captured $got/$N frames on vcan1"
[ "$got" -eq "$N" ] || { echo "smoke: FAIL: expected $N replayed frames on vcan1"; exit 1; }

# Same frames (id#data), in the same order: strip the timestamp and interface columns.
cut -d' ' -f3 "$OUT/dump.log" > "$OUT/frames0.txt"
cut -d' ' -f3 "$OUT/replay.log" > "$OUT/frames1.txt"
if ! cmp -s "$OUT/frames0.txt" "$OUT/frames1.txt"; then
    echo "smoke: FAIL: replayed frames differ from the original capture"
    exit 1
fi
echo "smoke: replayed frames identical to the original"
echo "smoke: PASS"
