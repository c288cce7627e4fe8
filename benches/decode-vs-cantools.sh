#!/usr/bin/env bash
# `acq decode LOG --dbc DBC` against cantools' own command line on the same
# candump log, in one run, as ratios; beside them the time to read the log's
# bytes once (`cat LOG > /dev/null`), the limit no decoder passes.
#
#   benches/decode-vs-cantools.sh [BASELINE]
#
# BASELINE: another build's acq binary (a copy of target/release/acq from an
# earlier commit), timed on the same log in the same run: best of three as
# the rest, and alternated with this build, ACQ_BENCH_PAIRS rounds (default
# 9) of both one after the other (in turn which first), whose median ratio
# is the comparison: a shared machine's load drifts within a run, and best
# of three of each, one binary after the other, did not resolve 5 %.
# ACQ_BENCH_FRAMES: the log's length (default 2,000,000 frames).
#
# The traffic is benches/decode.rs's: the 10 messages of
# fixtures/dbc/somat_excavator.dbc, two float32 signals each, 100 us apart,
# in candump -L form (about 46 bytes a line). acq writes its CSV (two rows
# a frame, `-o /dev/null`) and a Parquet file; cantools decodes the first
# 100,000 lines in its default form and in `--single-line` (one line a
# frame) to /dev/null. Each figure is the best of three runs.
#
# The goal's ratio is measured as the baseline's is: ACQ_BENCH_PEER_ROUNDS
# rounds (default 9) of acq's CSV decode and cantools' default decode one
# after the other (in turn which first), the median of the rounds' ratios
# (per frame). Each figure's best of three, taken minutes apart, moved the
# ratio from 144 to 222 times on the same code within an evening: the shared
# machine's load drifts, and it slows one thread of Python and two of acq
# unequally.
#
# Exits 1 when acq's CSV decode is less than 200 times cantools' default
# decode (the goal, alternated), with the figures above it.
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
cd "$repo"
baseline="${1:-}"
frames="${ACQ_BENCH_FRAMES:-2000000}"
peer_frames=100000
pairs="${ACQ_BENCH_PAIRS:-9}"
peer_rounds="${ACQ_BENCH_PEER_ROUNDS:-9}"
if [ "$peer_rounds" -lt 1 ]; then
  echo "decode-vs-cantools: ACQ_BENCH_PEER_ROUNDS must be at least 1" >&2
  exit 2
fi
goal=200
dbc=fixtures/dbc/somat_excavator.dbc

cargo build --release --quiet --bin acq
acq="${CARGO_TARGET_DIR:-$repo/target}/release/acq"
python="$(scripts/python-peers dbc)"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

# The log, made the way benches/decode.rs makes it.
"$python" - "$frames" "$work/traffic.log" <<'EOF'
import struct, sys
frames, path = int(sys.argv[1]), sys.argv[2]
state = 0x2545F4914F6CDD1D
mask = (1 << 64) - 1
with open(path, "w") as out:
    lines = []
    for i in range(frames):
        state ^= (state << 13) & mask
        state ^= state >> 7
        state ^= (state << 17) & mask
        t_us = 1_763_719_200_000_000 + i * 100
        can_id = 0x300 if i % 10 == 0 else 0x30F + i % 10
        a = ((state & 0xFFFF) - 32768.0) / 40.0
        b = (((state >> 16) & 0xFFFF) - 32768.0) / 40.0
        data = struct.pack("<ff", a, b).hex().upper()
        lines.append(f"({t_us // 1_000_000:010}.{t_us % 1_000_000:06}) can1 {can_id:03X}#{data}\n")
        if len(lines) == 100_000:
            out.write("".join(lines))
            lines.clear()
    out.write("".join(lines))
EOF
head -n "$peer_frames" "$work/traffic.log" >"$work/peer.log"
bytes=$(stat -c %s "$work/traffic.log")

# The best of three wall times of a command, in seconds.
best_of_three() {
  local best="" t
  for _ in 1 2 3; do
    local start end
    start=$(date +%s.%N)
    "$@" >/dev/null 2>&1
    end=$(date +%s.%N)
    t=$(echo "$end - $start" | bc -l)
    if [ -z "$best" ] || [ "$(echo "$t < $best" | bc -l)" = 1 ]; then best=$t; fi
  done
  echo "$best"
}
# The wall time of one run of a command, in seconds.
once() {
  local start end
  start=$(date +%s.%N)
  "$@" >/dev/null 2>&1
  end=$(date +%s.%N)
  echo "$end - $start" | bc -l
}
# The median over $3 rounds (default $pairs) of (the first command's time /
# the second's), each round running both, in turn which first.
paired_ratio() {
  local round this base
  for round in $(seq "${3:-$pairs}"); do
    if [ $((round % 2)) = 1 ]; then
      this=$(once "$1"); base=$(once "$2")
    else
      base=$(once "$2"); this=$(once "$1")
    fi
    echo "$this / $base" | bc -l
  done | sort -g | awk '{r[NR] = $1} END {print r[int((NR + 1) / 2)]}'
}
read_once() { cat "$work/traffic.log"; }
acq_csv() { "$acq" decode "$work/traffic.log" --dbc "$dbc" -o /dev/null; }
baseline_csv() { "$baseline" decode "$work/traffic.log" --dbc "$dbc" -o /dev/null; }
baseline_parquet() { "$baseline" decode "$work/traffic.log" --dbc "$dbc" -o "$work/baseline.parquet"; }
acq_parquet() { "$acq" decode "$work/traffic.log" --dbc "$dbc" -o "$work/out.parquet"; }
cantools_default() { "$python" -m cantools decode "$dbc" <"$work/peer.log"; }
cantools_single_line() { "$python" -m cantools decode --single-line "$dbc" <"$work/peer.log"; }

# acq must decode every frame (a decode that fails fast would look fast).
decoded=$("$acq" decode "$work/traffic.log" --dbc "$dbc" -o - | tail -n +2 | wc -l)
if [ "$decoded" != $((2 * frames)) ]; then
  echo "decode-vs-cantools: acq wrote $decoded rows, expected $((2 * frames))" >&2
  exit 1
fi

t_cat=$(best_of_three read_once)
t_csv=$(best_of_three acq_csv)
t_parquet=$(best_of_three acq_parquet)
if [ -n "$baseline" ]; then
  if ! cmp -s <("$baseline" decode "$work/traffic.log" --dbc "$dbc" -o - 2>/dev/null) \
      <("$acq" decode "$work/traffic.log" --dbc "$dbc" -o - 2>/dev/null); then
    echo "decode-vs-cantools: $baseline and this build write different CSVs" >&2
    exit 1
  fi
  t_baseline=$(best_of_three baseline_csv)
  t_baseline_parquet=$(best_of_three baseline_parquet)
  paired_csv=$(paired_ratio acq_csv baseline_csv)
  paired_parquet=$(paired_ratio acq_parquet baseline_parquet)
fi
t_cantools=$(best_of_three cantools_default)
t_cantools_single=$(best_of_three cantools_single_line)
# cantools' time over acq's, alternated, then per frame.
paired_cantools=$(paired_ratio cantools_default acq_csv "$peer_rounds")

rate() { echo "$1 / $2" | bc -l; }
r_cat=$(rate "$frames" "$t_cat")
r_csv=$(rate "$frames" "$t_csv")
r_parquet=$(rate "$frames" "$t_parquet")
r_cantools=$(rate "$peer_frames" "$t_cantools")
r_cantools_single=$(rate "$peer_frames" "$t_cantools_single")
ratio_best=$(echo "$r_csv / $r_cantools" | bc -l)
ratio_csv=$(echo "$paired_cantools * $frames / $peer_frames" | bc -l)

printf 'log: %d frames, %.1f MB (%s)\n' "$frames" "$(echo "$bytes / 1000000" | bc -l)" "$(date -u +%Y-%m-%d)"
printf '%-44s %8.3f s  %7.2f M frames/s  %7.0f MB/s\n' \
  "cat LOG > /dev/null (the limit)" "$t_cat" "$(echo "$r_cat / 1000000" | bc -l)" "$(echo "$bytes / $t_cat / 1000000" | bc -l)" \
  "acq decode --dbc -o /dev/null (CSV)" "$t_csv" "$(echo "$r_csv / 1000000" | bc -l)" "$(echo "$bytes / $t_csv / 1000000" | bc -l)" \
  "acq decode --dbc -o FILE.parquet" "$t_parquet" "$(echo "$r_parquet / 1000000" | bc -l)" "$(echo "$bytes / $t_parquet / 1000000" | bc -l)"
printf '%-44s %8.3f s  %7.3f M frames/s  (first %d lines)\n' \
  "cantools decode" "$t_cantools" "$(echo "$r_cantools / 1000000" | bc -l)" "$peer_frames" \
  "cantools decode --single-line" "$t_cantools_single" "$(echo "$r_cantools_single / 1000000" | bc -l)" "$peer_frames"
if [ -n "$baseline" ]; then
  printf '%-44s %8.3f s  (the same CSV; this build takes %.3f of its time; %.3f alternated, median of %d)\n' \
    "baseline: $baseline" "$t_baseline" "$(echo "$t_csv / $t_baseline" | bc -l)" "$paired_csv" "$pairs"
  printf '%-44s %8.3f s  (to Parquet; this build takes %.3f of its time; %.3f alternated, median of %d)\n' \
    "baseline: $baseline" "$t_baseline_parquet" "$(echo "$t_parquet / $t_baseline_parquet" | bc -l)" "$paired_parquet" "$pairs"
fi
printf 'acq CSV / cantools decode:               %6.1f x (goal %d x; alternated, median of %d rounds)\n' "$ratio_csv" "$goal" "$peer_rounds"
printf 'acq CSV / cantools decode, best of three: %6.1f x (each measured apart)\n' "$ratio_best"
printf 'acq CSV / cantools decode --single-line: %6.1f x\n' "$(echo "$r_csv / $r_cantools_single" | bc -l)"
printf 'acq Parquet / cantools decode:           %6.1f x\n' "$(echo "$r_parquet / $r_cantools" | bc -l)"
printf 'acq CSV / cat:                           %6.3f of the read limit\n' "$(echo "$r_csv / $r_cat" | bc -l)"
if [ "$(echo "$ratio_csv < $goal" | bc -l)" = 1 ]; then
  echo "decode-vs-cantools: acq's CSV decode is $(printf '%.1f' "$ratio_csv") x cantools', below the goal of $goal x" >&2
  exit 1
fi
