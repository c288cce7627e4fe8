#!/bin/sh
# Live-acquisition benchmarks on a real vcan, acq beside can-utils in one
# run (the machine is shared and noisy: compare within the run). Runs in the
# VM via benches/vcan-bench, or natively: OUT=dir IN=dir sh vcan-bench.sh.
set -eu
OUT=${OUT:-/out}
IN=${IN:-/in}
TICKS=100  # CLK_TCK on Linux x86-64
say() { echo "BENCH $*" | tee -a "$OUT/bench.txt"; }

wait_for_session() {
    i=0
    while [ ! -f "$1/session.toml" ]; do
        i=$((i + 1)); [ $i -lt 300 ] || exit 1; sleep 0.1
    done
}
cpu_ticks() { awk '{print $14 + $15}' "/proc/$1/stat"; }
frames_of() { awk -F' = ' '/^frames = /{print $2; exit}' "$1/session.toml"; }
drops_of() { awk -F' = ' '/^dropped_by_kernel = /{print $2; exit}' "$1/session.toml"; }

# --- A: cangen -g 0 flood, acq record and candump -L side by side ---------
for run in 1 2 3; do
    candump -L vcan0 > /tmp/flood_candump.log &
    dump=$!
    acq record --iface vcan0 --out /tmp/flood$run --quiet &
    rec=$!
    wait_for_session /tmp/flood$run
    cangen vcan0 -g 0 -I i -L 8 -D i -n 100000
    sleep 1
    kill -INT $rec; wait $rec
    kill $dump; wait $dump || true
    seen=$(wc -l < /tmp/flood_candump.log)
    got=$(frames_of /tmp/flood$run)
    say "flood run $run: sent 100000; candump -L captured $seen (lost $((100000 - seen))); acq record captured $got (lost $((100000 - got)), kernel drops reported $(drops_of /tmp/flood$run))"
    rm -rf /tmp/flood$run /tmp/flood_candump.log
done

# --- B: four buses at 8000 frames/s each, CPU of the recorder -------------
acq record --iface vcan0 --iface vcan1 --iface vcan2 --iface vcan3 --rig "$IN/rigs/bench_four_buses.toml" --out /tmp/four --quiet &
rec=$!
candump -L vcan0 vcan1 vcan2 vcan3 > /tmp/four_candump.log &
dump=$!
wait_for_session /tmp/four
sleep 0.5
start=$(date +%s)
rec0=$(cpu_ticks $rec); dump0=$(cpu_ticks $dump); up0=$(awk '{print $1}' /proc/uptime)
acq simulate --rig "$IN/rigs/bench_four_buses.toml" --scenario "$IN/scenarios/bench_four_buses.toml" \
    --iface vcan0 --iface vcan1 --iface vcan2 --iface vcan3 2> /tmp/four_simulate.txt
rec1=$(cpu_ticks $rec); dump1=$(cpu_ticks $dump); up1=$(awk '{print $1}' /proc/uptime)
kill -INT $rec; wait $rec
kill $dump; wait $dump || true
frames=$(frames_of /tmp/four)
awk -v r0="$rec0" -v r1="$rec1" -v d0="$dump0" -v d1="$dump1" -v u0="$up0" -v u1="$up1" -v t="$TICKS" -v f="$frames" \
    'BEGIN { w = u1 - u0; printf "BENCH four buses: %d frames in %.1f s (%.0f frames/s); CPU of one core: acq record --rig (live decode) %.1f %%, candump -L (4 ifaces, no decode) %.1f %%, ratio %.2f\n", f, w, f / w, 100 * (r1 - r0) / t / w, 100 * (d1 - d0) / t / w, (r1 - r0) / ((d1 - d0) > 0 ? (d1 - d0) : 1) }' \
    | tee -a "$OUT/bench.txt"
cat /tmp/four_simulate.txt >> "$OUT/bench.txt"
