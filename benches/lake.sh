#!/usr/bin/env bash
# The campaign lake against the tools people use for the same job, in one
# run on the same files:
#
#   benches/lake.sh [SECONDS] [ROUNDS] [ROWS]   (defaults 60, 3 and 100,000,000)
#
# 1. Ingest: a logger's MF4 of SECONDS of the four-bus DAQ rig
#    (fixtures/rigs/bench_four_buses.toml: 76 DBC signals at 800 Hz in
#    32,000 frames/s, values moving through a hold with noise) decoded to
#    Parquet by `acq lake ingest` and by an asammdf + pandas script
#    (MDF.extract_bus_logging with the rig's DBC, each decoded message's
#    DataFrame to_parquet, as CAN loggers' MF4-to-Parquet pipelines do).
#    Both are timed as the whole process a user runs, best of ROUNDS; the
#    script's own time from MDF() on (its import left out) beside it. Peak
#    resident memory and CPU seconds (every thread's) by /usr/bin/time.
#    `cat FILE > /dev/null` is the floor.
# 2. Memory bounded: peak resident memory of the ingest of candump logs 4
#    and 16 times as long (every sensor's file past several row groups).
# 3. Size: the lake against the MF4 and the candump log it came from.
# 4. Query: the log ingested as many machines (--device) as make ROWS
#    samples or more, and the same SQL through `acq lake query` (the whole
#    process) and DuckDB (in its process, from the query to the last row;
#    the same number of rows checked), best of ROUNDS each.
#
# Exits 1, after every figure, when a goal is missed: the ingest at least
# 10 times the script (whole processes), the peak memory at 16 x the input
# at most 1.5 times that at 4 x (bounded, not growing with the length),
# and each query within 2 times DuckDB's time.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
rounds=${2:-3}
target_rows=${3:-100000000}
python=$(scripts/python-peers lake)
cargo build --release --quiet
acq="$PWD/target/release/acq"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# The rig's buses as a logger names its channels (can0..can3), its DBC by
# absolute path.
sed -e "s#\"../dbc/#\"$PWD/fixtures/dbc/#" -e 's/iface = "vcan/iface = "can/' \
    fixtures/rigs/bench_four_buses.toml >"$work/rig.toml"
scenario() {
    local hold_s="$1"
    printf 'name = "lake_bench"\n[timeline]\nidle_s = 2.0\nbuild_up_s = 2.0\nhold_s = %s\nrelease_s = 2.0\nafter_s = 2.0\n' "$hold_s"
    printf '[devices]\njitter_us = 20.0\nrelative_noise = 0.002\n'
    for bus in 0 1 2 3; do
        printf '[sensor.tip_force_%s]\nidle = 0.0\nhold = 4%s.6\nnoise = 0.08\n' "$bus" "$bus"
        for gauge in $(seq -w 1 18); do
            printf '[sensor.sg%s_%s]\nidle = 0.0\nhold = %s\nnoise = 2.0\n' "$gauge" "$bus" "$((100 + 37 * 10#$gauge + bus))"
        done
    done
}
make_log() {
    local name="$1" total_s="$2"
    scenario "$((total_s - 8))" >"$work/$name.toml"
    "$acq" simulate --rig fixtures/rigs/bench_four_buses.toml --scenario "$work/$name.toml" \
        --start 1764547200 -o "$work/$name.vcan.log" 2>/dev/null
    sed 's/ vcan/ can/' "$work/$name.vcan.log" >"$work/$name.log"
    rm "$work/$name.vcan.log"
}
make_log short "$seconds"
"$acq" convert "$work/short.log" -o "$work/short.mf4" >/dev/null 2>&1

cat >"$work/asammdf_to_parquet.py" <<'PY'
import os, sys, time
from asammdf import MDF
started = time.perf_counter()
source, dbc, out = sys.argv[1:4]
os.makedirs(out, exist_ok=True)
decoded = MDF(source).extract_bus_logging({"CAN": [(dbc, 0)]})
values = 0
for index in range(len(decoded.groups)):
    frame = decoded.get_group(index)
    if frame.empty:
        continue
    values += frame.select_dtypes("number").size
    frame.to_parquet(os.path.join(out, f"{index}.parquet"))
print(values, time.perf_counter() - started)
PY

best() { sort -g | head -1; }
# "SECONDS KB CPU" of a whole command: wall time (to the microsecond:
# /usr/bin/time gives hundredths, 4 % of a 0.25 s ingest), peak resident
# memory and CPU seconds (user and system, every thread).
timed() {
    local start end
    start=$(date +%s.%N)
    /usr/bin/time -f '%M %U %S' -o "$work/time.txt" "$@" >"$work/out.txt" 2>"$work/err.txt" || {
        cat "$work/err.txt" >&2; exit 1; }
    end=$(date +%s.%N)
    printf '%.6f %s\n' "$(echo "$end - $start" | bc -l)" \
        "$(awk '{printf "%s %.2f", $1, $2 + $3}' "$work/time.txt")"
}
mb() { du -sm "$1" | cut -f1; }

file="$work/short.mf4"
frames=$(wc -l <"$work/short.log")
cat_s=$(for _ in $(seq "$rounds"); do
    start=$(date +%s.%N); cat "$file" >/dev/null; end=$(date +%s.%N); echo "$end - $start" | bc -l
done | best)
acq_runs=$(for _ in $(seq "$rounds"); do rm -rf "$work/lake"
    timed "$acq" lake ingest "$file" --rig "$work/rig.toml" --lake "$work/lake"; done)
acq_s=$(echo "$acq_runs" | cut -d' ' -f1 | best)
acq_kb=$(echo "$acq_runs" | cut -d' ' -f2 | best)
acq_cpu=$(echo "$acq_runs" | cut -d' ' -f3 | best)
samples=$("$acq" lake query "$work/lake" "SELECT count(*) AS n FROM samples" | tail -1)
script_runs=$(for _ in $(seq "$rounds"); do rm -rf "$work/pandas"
    timed "$python" "$work/asammdf_to_parquet.py" "$file" "$PWD/fixtures/dbc/somat_excavator.dbc" "$work/pandas"
    echo " $(cut -d' ' -f2 "$work/out.txt")"; done | paste -d' ' - -)
script_s=$(echo "$script_runs" | cut -d' ' -f1 | best)
script_kb=$(echo "$script_runs" | cut -d' ' -f2 | best)
script_cpu=$(echo "$script_runs" | cut -d' ' -f3 | best)
script_inner_s=$(echo "$script_runs" | awk '{print $NF}' | best)
script_values=$(cut -d' ' -f1 "$work/out.txt")

echo "== ingest: $frames frames, $(mb "$file") MB of MF4 ($(mb "$work/short.log") MB as candump), $samples samples ($script_values values by asammdf)"
printf '%-28s %10s %14s %14s %12s\n' "" "s" "frames/s" "MB/s" "peak MB"
printf '%-28s %10.3f\n' "cat (the floor)" "$cat_s"
printf '%-28s %10.3f %14.0f %14.1f %12.0f\n' "acq lake ingest" "$acq_s" \
    "$(echo "$frames / $acq_s" | bc -l)" "$(echo "$(mb "$file") / $acq_s" | bc -l)" "$(echo "$acq_kb / 1024" | bc -l)"
printf '%-28s %10.3f %14.0f %14.1f %12.0f\n' "asammdf + pandas script" "$script_s" \
    "$(echo "$frames / $script_s" | bc -l)" "$(echo "$(mb "$file") / $script_s" | bc -l)" "$(echo "$script_kb / 1024" | bc -l)"
printf '%-28s %10.3f\n' "  (from MDF() on)" "$script_inner_s"
printf 'script / acq: %.2f whole processes, %.2f against the script from MDF() on\n' \
    "$(echo "$script_s / $acq_s" | bc -l)" "$(echo "$script_inner_s / $acq_s" | bc -l)"
# The work beside the time: a machine shared with other load takes more
# from the side that uses both cores.
printf 'CPU (user and system, every thread): acq %.2f s, the script %.2f s: %.2f x\n' \
    "$acq_cpu" "$script_cpu" "$(echo "$script_cpu / $acq_cpu" | bc -l)"
missed=()
ingest_ratio=$(echo "$script_s / $acq_s" | bc -l)
if [ "$(echo "$ingest_ratio < 10" | bc -l)" = 1 ]; then
    missed+=("the ingest is $(printf '%.2f' "$ingest_ratio") x the script, below 10 x")
fi

memory=""
declare -A peak_kb
for times in 4 16; do
    make_log "x$times" "$((times * seconds))"
    rm -rf "$work/lake-x"
    run=$(timed "$acq" lake ingest "$work/x$times.log" --rig "$work/rig.toml" --lake "$work/lake-x")
    peak_kb[$times]=$(echo "$run" | cut -d' ' -f2)
    memory="$memory, $(echo "$run" | cut -d' ' -f2 | awk '{printf "%.0f", $1 / 1024}') MB for ${times}x ($(mb "$work/x$times.log") MB of candump)"
    rm -rf "$work/lake-x" "$work/x$times.log"
done
echo "== memory: peak $((acq_kb / 1024)) MB for the MF4 above$memory"
if [ "$(echo "${peak_kb[16]} > 1.5 * ${peak_kb[4]}" | bc -l)" = 1 ]; then
    missed+=("peak memory grows with the input: ${peak_kb[16]} kB at 16 x, ${peak_kb[4]} kB at 4 x")
fi
echo "== size: lake $(du -sk "$work/lake/samples" | cut -f1) kB of samples for $(du -sk "$file" | cut -f1) kB of MF4 and $(du -sk "$work/short.log" | cut -f1) kB of candump; asammdf + pandas wrote $(du -sk "$work/pandas" | cut -f1) kB"

rm -rf "$work/lake" "$work/pandas"
devices=$(((target_rows + samples - 1) / samples))
# A source is a file (its id is its path): each machine its own name for
# the same bytes, a hard link.
for device in $(seq 1 "$devices"); do
    ln "$work/short.log" "$work/machine-$device.log"
    "$acq" lake ingest "$work/machine-$device.log" --rig "$work/rig.toml" --lake "$work/lake" \
        --device "machine-$device" >/dev/null 2>&1
done
rows=$("$acq" lake query "$work/lake" "SELECT count(*) AS n FROM samples" | tail -1)
echo "== query: $rows rows ($devices machines), $(mb "$work/lake") MB of lake"
cat >"$work/duckdb_query.py" <<'PY'
import sys, time
import duckdb
lake, sql = sys.argv[1:3]
connection = duckdb.connect()
connection.execute(
    f"CREATE VIEW samples AS SELECT * FROM read_parquet('{lake}/samples/**/*.parquet', hive_partitioning = true)"
)
started = time.perf_counter()
rows = connection.execute(sql).fetch_arrow_table()
print(rows.num_rows, time.perf_counter() - started)
PY
queries=(
    "SELECT sensor, count(*) AS n, avg(value) AS mean, min(value) AS low, max(value) AS high FROM samples GROUP BY sensor ORDER BY sensor"
    "SELECT device, date_trunc('second', time) AS second, avg(value) AS mean FROM samples WHERE sensor = 'sg05_2' GROUP BY device, second ORDER BY device, second"
    "SELECT device, count(*) AS n FROM samples WHERE value > 600 GROUP BY device ORDER BY device"
)
printf '%-6s %10s %10s %10s\n' query "acq s" "duckdb s" "acq/duckdb"
for index in "${!queries[@]}"; do
    sql="${queries[$index]}"
    acq_q=$(for _ in $(seq "$rounds"); do timed "$acq" lake query "$work/lake" "$sql"; done | cut -d' ' -f1 | best)
    acq_rows=$(($(wc -l <"$work/out.txt") - 1))
    duck_q=$(for _ in $(seq "$rounds"); do
        set -- $("$python" "$work/duckdb_query.py" "$work/lake" "$sql")
        [ "$1" = "$acq_rows" ] || { echo "duckdb gave $1 rows, acq $acq_rows: $sql" >&2; exit 1; }
        echo "$2"
    done | best)
    printf '%-6s %10.3f %10.3f %10.2f   %s\n' "$((index + 1))" "$acq_q" "$duck_q" "$(echo "$acq_q / $duck_q" | bc -l)" "$sql"
    if [ "$(echo "$acq_q > 2 * $duck_q" | bc -l)" = 1 ]; then
        missed+=("query $((index + 1)) takes $(printf '%.2f' "$(echo "$acq_q / $duck_q" | bc -l)") x DuckDB's time, above 2 x")
    fi
done
if [ "${#missed[@]}" -gt 0 ]; then
    printf 'lake: goal missed: %s\n' "${missed[@]}" >&2
    exit 1
fi
