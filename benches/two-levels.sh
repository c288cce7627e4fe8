#!/bin/sh
# The GTN calibration at 0.09 mm by two levels against all fine, on one
# test curve (BENCHMARKS.md, "Coarse and fine runs together"):
#
#   sh benches/two-levels.sh TEST.csv [OUT_DIR]
#
# runs, one after the other with the release build,
#   all fine:   acq calibrate gtn --element-mm 0.09 --max-evals 40
#   two levels: acq calibrate gtn --element-mm 0.09 --cheap-element-mm 0.33
#               --max-evals 400 --max-fine-runs 20
# (both --target-mape 0 --seed 1), then prints the all-fine search's best
# and the simulation time to it, and how many fine runs the two levels
# needed to come within 0.1 points of it, their simulation time then
# (both levels' runs) and its ratio to the all-fine time. The time is the
# sum of the runs' wall times in evaluations.csv, so two benches may run
# side by side on two cores and each still compares like with like.
set -eu
test_csv=${1:?usage: sh benches/two-levels.sh TEST.csv [OUT_DIR]}
out=${2:-$(mktemp -d)}
cd "$(dirname "$0")/.."
cargo build --release --quiet --bin acq
acq=target/release/acq
mkdir -p "$out"
# A search already finished in OUT_DIR is read, not run again.
if [ ! -f "$out/all-fine/summary.json" ]; then
    $acq calibrate gtn --test "$test_csv" --element-mm 0.09 --target-mape 0 --seed 1 \
        --max-evals 40 --out "$out/all-fine" >"$out/all-fine.log" 2>&1
fi
if [ ! -f "$out/two-levels/summary.json" ]; then
    $acq calibrate gtn --test "$test_csv" --element-mm 0.09 --target-mape 0 --seed 1 \
        --cheap-element-mm 0.33 --max-evals 400 --max-fine-runs 20 \
        --out "$out/two-levels" >"$out/two-levels.log" 2>&1
fi

# Each fine run in order: its count, the simulation time so far (every
# level's runs) and the best MAPE so far. All-fine logs have no mesh column.
path() {
    awk -F, 'NR == 1 { for (i = 1; i <= NF; i++) column[$i] = i; next }
        {
            seconds += $column["wall_s"]
            if ("mesh" in column && $column["mesh"] != 0.09) next
            fine += 1
            if ($column["status"] == "ok" && (best == "" || $column["mape_pct"] + 0 < best)) best = $column["mape_pct"] + 0
            printf "%d %.1f %s\n", fine, seconds, best
        }' "$1/evaluations.csv"
}
path "$out/all-fine" >"$out/all-fine.path"
path "$out/two-levels" >"$out/two-levels.path"
# The all-fine best, and the time of the run that first reached it.
best=$(tail -n 1 "$out/all-fine.path" | cut -d' ' -f3)
at_s=$(awk -v best="$best" '$3 == best { print $2; exit }' "$out/all-fine.path")
echo "all fine: best MAPE $best % after 40 fine runs, reached after $at_s s of runs"
awk -v best="$best" -v at_s="$at_s" '
    $3 != "" && $3 <= best + 0.1 && !hit { hit = 1; printf "two levels: within 0.1 points after %d fine runs, %.1f s of runs (ratio %.2f)\n", $1, $2, $2 / at_s }
    $1 == 17 { at17 = $3 } $1 == 20 { at20 = $3 }
    END {
        if (!hit) print "two levels: not within 0.1 points in 20 fine runs"
        printf "two levels: best %s %% after 17 fine runs, %s %% after 20\n", at17, at20
    }' "$out/two-levels.path"
echo "runs and logs in $out"
