#!/usr/bin/env bash
# Reading speed of each log format acq reads, the same frames in each, and
# python-can's readers on the same files.
#
#   benches/log-formats.sh [FRAMES] [ROUNDS]   (defaults 1,000,000 and 5)
#
# Needs python-can (and asammdf, for MF4) in a scratch virtualenv (made if
# missing, as can/tests/it/mf4.rs does). Makes a candump log of random
# classic and FD frames, has python-can write it as BLF, has acq write it
# as ASC and MF4 (`acq convert`; pc.mf4 is python-can's MF4, transposed
# deflate), then times `acq convert X -o out.log`
# per format (the same candump writing in each, so the difference is the
# reading), the formats alternating, ROUNDS times: the machine is shared,
# so the best of the rounds and the median are given. python-can iterates
# over each file once (it is 10 to 30 times slower). Prints frames per
# second.
set -euo pipefail
cd "$(dirname "$0")/.."
frames=${1:-1000000}
rounds=${2:-5}
venv="${TMPDIR:-/tmp}/acq-python-can-mf4"
"$venv/bin/python" -c "import can, asammdf" 2>/dev/null ||
    { python3 -m venv "$venv" && "$venv/bin/pip" install --quiet python-can==4.6.1 asammdf==8.8.28; }
cargo build --release --quiet
acq=target/release/acq
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$venv/bin/python" - "$frames" "$work" <<'PY'
import random, sys, can
n, work = int(sys.argv[1]), sys.argv[2]
random.seed(1)
t = 1763719200.0
with open(f"{work}/frames.log", "w") as f:
    for i in range(n):
        t += 0.0001
        if i % 10 == 9:
            data = bytes(random.getrandbits(8) for _ in range(12))
            f.write(f"({t:.6f}) can1 {random.randrange(0x800):03X}##5{data.hex().upper()} R\n")
        else:
            data = bytes(random.getrandbits(8) for _ in range(8))
            f.write(f"({t:.6f}) can0 {random.randrange(1 << 29):08X}#{data.hex().upper()} R\n")
with can.BLFWriter(f"{work}/frames.blf") as w:
    for m in can.CanutilsLogReader(f"{work}/frames.log"):
        w.on_message_received(m)
# python-can's MF4, at its default compression (transposed deflate).
with can.MF4Writer(f"{work}/frames.pc.mf4") as w:
    for m in can.CanutilsLogReader(f"{work}/frames.log"):
        w.on_message_received(m)
PY
"$acq" convert "$work/frames.log" -o "$work/frames.asc" 2>/dev/null
"$acq" convert "$work/frames.log" -o "$work/frames.mf4" 2>/dev/null
seconds() { local start end; start=$(date +%s.%N); "$@" >/dev/null 2>&1; end=$(date +%s.%N); echo "$end - $start" | bc -l; }
declare -A times
for round in $(seq 1 "$rounds"); do
    for format in log asc blf mf4 pc.mf4; do
        times[$format]+="$(seconds "$acq" convert "$work/frames.$format" -o "$work/out.log") "
    done
done
best() { tr ' ' '\n' <<<"$1" | grep . | sort -g | head -1; }
median() { tr ' ' '\n' <<<"$1" | grep . | sort -g | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }
printf 'format   size MB   acq best s   acq median s   acq frames/s (best)   python-can s   python-can frames/s   ratio (best)\n'
for format in log asc blf mf4 pc.mf4; do
    file="$work/frames.$format"
    size=$(du -m "$file" | cut -f1)
    ours=$(best "${times[$format]}")
    theirs=$(seconds "$venv/bin/python" -c "
import can, sys
f = sys.argv[1]
r = (can.BLFReader(f) if f.endswith('.blf') else can.ASCReader(f) if f.endswith('.asc')
     else can.MF4Reader(f) if f.endswith('.mf4') else can.CanutilsLogReader(f))
sum(1 for _ in r)" "$file")
    printf '%-7s %8s %12.3f %14.3f %21.0f %14.2f %21.0f %14.1f\n' "$format" "$size" "$ours" \
        "$(median "${times[$format]}")" "$(echo "$frames / $ours" | bc -l)" "$theirs" \
        "$(echo "$frames / $theirs" | bc -l)" "$(echo "$theirs / $ours" | bc -l)"
done
echo "acq's rounds (s): $(for f in log asc blf mf4 pc.mf4; do printf '%s: %s; ' "$f" "${times[$f]}"; done)"
