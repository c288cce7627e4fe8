#!/bin/sh
# The study runner's overhead on a real FE solver: a 40-run Bayesian
# optimisation of examples/calculix-tensile on 2 local slots. The solver's
# own time is the sum of the logged run times (evaluations.csv, wall_s) over
# the slots; everything else is acq's: proposals, GP fits, logging, reports,
# and a slot left idle while the other run of its batch finishes.
#
#   sh benches/calculix-overhead.sh [MESH] [RUNS]     (default 4x20, 40)
set -eu
mesh=${1:-4x20}
runs=${2:-40}
root=$(cd "$(dirname "$0")/.." && pwd)
acq=${ACQ:-$root/target/release/acq}
[ -x "$acq" ] || { echo "build acq first: cargo build --release" >&2; exit 1; }
work=$(mktemp -d)
[ -n "${KEEP:-}" ] && echo "run directory: $work" >&2 || trap 'rm -rf "$work"' EXIT
cp "$root"/examples/calculix-tensile/tensile.py "$root"/examples/calculix-tensile/measured.csv "$work"/
sed -e "s/\"6x30\"/\"$mesh\"/" -e "s/max_evals = 24/max_evals = $runs/" \
    "$root"/examples/calculix-tensile/spec-bo.toml >"$work"/spec.toml
start=$(date +%s.%N)
"$acq" calibrate external --spec "$work"/spec.toml --out "$work"/run >/dev/null 2>"$work"/stderr.txt
end=$(date +%s.%N)
awk -F, -v wall="$(echo "$end - $start" | bc)" -v mesh="$mesh" '
    NR == 1 { for (i = 1; i <= NF; i++) if ($i == "wall_s") column = i; next }
    { solver += $column; count++ }
    END {
        ideal = solver / 2
        overhead = wall - ideal
        printf "BENCH calculix mesh %s: %d runs, wall %.1f s, solver %.1f s over 2 slots = %.1f s, overhead %.1f s = %.2f %% of the wall\n", mesh, count, wall, solver, ideal, overhead, 100 * overhead / wall
    }' "$work"/run/evaluations.csv
