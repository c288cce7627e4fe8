#!/usr/bin/env bash
# A day of logger files into a session and its measured values, with
# memory bounded: `acq import` then `acq extract` on FEW and on MANY split
# MF4 files of the same logger (the shipped excavator_case1 recording,
# repeated end to end, 14 s a repeat, as a logger that splits its log
# every REPEATS repeats would write it). Memory is bounded when the peak
# resident size does not grow with the number of files: the figure is the
# ratio of MANY's peak to FEW's, beside the frames each run read.
#
#   benches/import-day.sh [FEW] [MANY] [REPEATS]   (defaults 2, 8 and 60)
set -euo pipefail
cd "$(dirname "$0")/.."
few=${1:-2}
many=${2:-8}
repeats=${3:-60}
cargo build --release --quiet
acq=target/release/acq
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
session=fixtures/sessions/excavator_case1
# One file: REPEATS copies of the recording, each shifted by 14 s.
make_file() {
    local index=$1
    awk -v repeats="$repeats" -v index0="$index" '
        { lines[NR] = $0 }
        END {
            for (r = 0; r < repeats; r++) {
                shift = (index0 * repeats + r) * 14.0
                for (i = 1; i <= NR; i++) {
                    split(lines[i], parts, " ")
                    t = substr(parts[1], 2, length(parts[1]) - 2) + shift
                    printf "(%.6f) %s %s\n", t, parts[2], parts[3]
                }
            }
        }' "$session/raw.log" > "$work/part.log"
    "$acq" convert "$work/part.log" -o "$work/files/$(printf '%08d' "$index").MF4" 2>/dev/null
}
mkdir -p "$work/files"
for index in $(seq 0 $((many - 1))); do make_file "$index"; done
rm -f "$work/part.log"
peak_kb() { awk '/Maximum resident set size/ { print $6 }' "$1"; }
printf '%-6s %10s %8s %14s %14s %12s %12s\n' files frames MB "import peak MB" "extract peak MB" "import s" "extract s"
for count in "$few" "$many"; do
    files=()
    for index in $(seq 0 $((count - 1))); do files+=("$work/files/$(printf '%08d' "$index").MF4"); done
    rm -rf "$work/session"
    start=$(date +%s.%N)
    /usr/bin/time -v "$acq" import "${files[@]}" --rig "$session/rig/excavator.toml" --out "$work/session" \
        2>"$work/import.time" >/dev/null
    mid=$(date +%s.%N)
    /usr/bin/time -v "$acq" extract "$work/session" -o "$work/measured.csv" 2>"$work/extract.time" >/dev/null
    end=$(date +%s.%N)
    frames=$(awk -F' = ' '/^frames = / { print $2; exit }' "$work/session/session.toml")
    windows=$(($(wc -l < "$work/measured.csv") - 1))
    [ "$windows" -gt 0 ] || { echo "no measured value from $count files" >&2; exit 1; }
    printf '%-6s %10s %8s %14.1f %14.1f %12.2f %12.2f\n' "$count" "$frames" \
        "$(du -cm "${files[@]}" | tail -1 | cut -f1)" \
        "$(echo "$(peak_kb "$work/import.time") / 1024" | bc -l)" \
        "$(echo "$(peak_kb "$work/extract.time") / 1024" | bc -l)" \
        "$(echo "$mid - $start" | bc -l)" "$(echo "$end - $mid" | bc -l)"
done
