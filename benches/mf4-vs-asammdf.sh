#!/usr/bin/env bash
# Reading a data logger's MF4 file: acq against asammdf, the reference
# reader, on the same files in the same run.
#
#   benches/mf4-vs-asammdf.sh [FRAMES] [ROUNDS]   (defaults 1,000,000 and 5)
#
# Three files of FRAMES frames each (can/tests/mf4/loggers.py --frames):
# two shaped as loggers write them, one unsorted data group each: an older
# CANedge's (DataBytes a VLSD channel group, a float64 master of
# nanoseconds, a virtual BusChannel, DataLength through a table) and fixed
# records in a channel group per bus and id kind (BusChannel, IDE and Dir
# virtual constants, as newer firmware writes them); and one asammdf writes
# (virtual constant members, a table, a float master). acq: the frames read
# column by column into a FrameBatch (`log_frames --count --batch`, the
# whole process), and one by one into Frame values (`--count`, the column
# "one by one s"), each timed inside the process from opening the file to
# its last frame. asammdf 8.8.28: MDF(FILE) and every member's raw array and the
# master of each bus-logging group (its fastest path to the same values,
# vectorized; the import of asammdf not counted). `cat FILE > /dev/null` is
# the floor: reading the bytes once. Best of ROUNDS each (a shared machine).
set -euo pipefail
cd "$(dirname "$0")/.."
frames=${1:-1000000}
rounds=${2:-5}
python=$(scripts/python-peers can-logs)
cargo build --release --quiet -p acq-can --example log_frames
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$python" can/tests/mf4/loggers.py "$work" --frames "$frames"
cat > "$work/asammdf_read.py" <<'PY'
import sys, time
from asammdf import MDF
from asammdf.blocks import v4_constants as v4c
started = time.perf_counter()
mdf = MDF(sys.argv[1])
frames = 0
for index, group in enumerate(mdf.groups):
    if not group.channel_group.flags & v4c.FLAG_CG_BUS_EVENT:
        continue
    names = {channel.name for channel in group.channels}
    in_group = 0
    for member in ("ID", "IDE", "DLC", "DataLength", "DataBytes", "BusChannel", "Dir"):
        if "CAN_DataFrame." + member in names:
            samples = mdf.get("CAN_DataFrame." + member, group=index, raw=True).samples
            in_group = max(in_group, len(samples))
    mdf.get_master(index)
    frames += in_group
print(frames, time.perf_counter() - started)
PY
best() { sort -g | head -1; }
printf '%-20s %8s %10s %12s %16s %12s %14s %8s\n' file MB "cat s" "acq s" "one by one s" "asammdf s" "acq frames/s" ratio
for name in vlsd_cg fixed_unsorted virtual_tab_ns; do
    file="$work/$name.mf4"
    cat_s=$(for _ in $(seq "$rounds"); do
        start=$(date +%s.%N); cat "$file" >/dev/null; end=$(date +%s.%N); echo "$end - $start" | bc -l
    done | best)
    acq() {
        local how=("$@")
        for _ in $(seq "$rounds"); do
            # "Mf4 N frames in S s: ...": the time from opening the file
            # to its last frame, as asammdf's is from MDF() on.
            set -- $(target/release/examples/log_frames --count "${how[@]}" "$file")
            [ "$2" = "$frames" ] || { echo "acq read $2 of $frames frames" >&2; exit 1; }
            echo "$5"
        done | best
    }
    acq_s=$(acq --batch)
    one_by_one_s=$(acq)
    asammdf_s=$(for _ in $(seq "$rounds"); do
        set -- $("$python" "$work/asammdf_read.py" "$file")
        [ "$1" = "$frames" ] || { echo "asammdf read $1 of $frames frames" >&2; exit 1; }
        echo "$2"
    done | best)
    printf '%-20s %8s %10.3f %12.3f %16.3f %12.3f %14.0f %8.2f\n' "$name.mf4" "$(du -m "$file" | cut -f1)" \
        "$cat_s" "$acq_s" "$one_by_one_s" "$asammdf_s" "$(echo "$frames / $acq_s" | bc -l)" "$(echo "$asammdf_s / $acq_s" | bc -l)"
done
