#!/usr/bin/env bash
# acq's tensile twin against an independent FE code on the same problem,
# damage off: the round bar of examples/calculix-tensile (radius 2 mm, half
# length 12.5 mm, 0.5 % cosine imperfection), the Swift flow table K = 1000
# MPa, n = 0.12, E = 210 GPa, nu = 0.3. Both codes run at each mesh of the
# list, the same element counts (CalculiX CAX8R on a uniform mesh, acq F-bar
# quadrilaterals graded toward the neck).
#
# - Accuracy: the first and the last mesh of each code against each other
#   (is it converged?), then the two codes at the last mesh: the largest
#   difference up to the peak force (relative; the goal 0.1 %) and after it
#   (as a share of the peak), and each peak against Considere's closed form.
#   The overlay plot of the last mesh goes to benches/results/twin-vs-calculix.svg.
# - Speed: each run's wall time from outside (process start to exit; acq the
#   best of ACQ_RUNS, CalculiX the best of CCX_RUNS, its Python wrapper
#   included), and the ratio CalculiX / acq at each mesh. CalculiX runs on
#   one thread, as tensile.py runs it (OMP_NUM_THREADS=1); acq on every core.
#   With a baseline build, its runs alternate with this build's: the ratio
#   of the two builds in one run. A yardstick of the machine's pace beside
#   the absolute times: cantools' command line decoding a fixed log, frames/s.
#
# Exits 1 when CalculiX / acq falls below ACQ_MIN_RATIO (the goal, 30) at any
# mesh, or acq's curve leaves CalculiX's by more than 0.1 % before the peak,
# after printing every figure.
#
#   benches/twin-vs-calculix.sh [BASELINE_ACQ]
#   ACQ_MESHES="8x40 12x60 22x139" ACQ_RUNS=3 CCX_RUNS=1 ACQ_MIN_RATIO=30
#
# 22x139 is CalculiX's mesh at 0.09 mm elements (`tensile.py --element-mm
# 0.09`), the element size of the published GTN study.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
acq=${ACQ:-${CARGO_TARGET_DIR:-$root/target}/release/acq}
baseline=${1:-}
meshes=${ACQ_MESHES:-8x40 12x60 22x139}
acq_runs=${ACQ_RUNS:-3}
ccx_runs=${CCX_RUNS:-1}
min_ratio=${ACQ_MIN_RATIO:-30}
[ -x "$acq" ] || { echo "build acq first: cargo build --release" >&2; exit 1; }
[ -z "$baseline" ] || [ -x "$baseline" ] || { echo "no baseline build at $baseline" >&2; exit 1; }
command -v ccx >/dev/null || { echo "ccx is missing: apt-get install calculix-ccx" >&2; exit 1; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cp "$root"/examples/calculix-tensile/tensile.py "$work"/
cd "$work"
python3 tensile.py flow --K 1000 --n 0.12 -o flow.csv
echo '{"K_mpa": 1000, "n": 0.12}' >params.json

seconds_since() { echo "$(date +%s.%N) - $1" | bc -l; }
smaller() { if [ -z "$1" ] || [ "$(echo "$2 < $1" | bc -l)" = 1 ]; then echo "$2"; else echo "$1"; fi; }
# One pull of the bar by an acq build; its wall time from outside.
pull() {
    local binary=$1 mesh=$2 output=$3 start
    start=$(date +%s.%N)
    "$binary" twin gtn --flow-curve flow.csv --param q1=1.5,q2=1,q3=2.25,epsN=0.3,sN=0.1,fN=0,f0=0,m=0 \
        --imperfection 0.005 --end-mm 2.5 --mesh "$mesh" --step-mm 0.0125 -o "$output" >/dev/null
    seconds_since "$start"
}

results=()
for mesh in $meshes; do
    ccx_best=""
    for _ in $(seq "$ccx_runs"); do
        rm -rf "ccx$mesh" && mkdir "ccx$mesh"
        start=$(date +%s.%N)
        (cd "ccx$mesh" && OMP_NUM_THREADS=1 python3 ../tensile.py run --params ../params.json --mesh "$mesh")
        ccx_best=$(smaller "$ccx_best" "$(seconds_since "$start")")
    done
    sed "1s/.*/DISPLACEMENT,FORCE/" "ccx$mesh/curve.csv" >"CalculiX-$mesh.csv"
    acq_best="" baseline_best=""
    for _ in $(seq "$acq_runs"); do
        acq_best=$(smaller "$acq_best" "$(pull "$acq" "$mesh" "acq$mesh.csv")")
        if [ -n "$baseline" ]; then
            baseline_best=$(smaller "$baseline_best" "$(pull "$baseline" "$mesh" "baseline$mesh.csv")")
        fi
    done
    line=$(printf 'BENCH %-7s CalculiX %7.2f s   acq %6.3f s   CalculiX / acq %5.1f x' \
        "$mesh" "$ccx_best" "$acq_best" "$(echo "$ccx_best / $acq_best" | bc -l)")
    if [ -n "$baseline" ]; then
        line+=$(printf '   baseline %6.3f s (%5.1f x), this build / baseline %.3f' "$baseline_best" \
            "$(echo "$ccx_best / $baseline_best" | bc -l)" "$(echo "$acq_best / $baseline_best" | bc -l)")
        if ! cmp -s "acq$mesh.csv" "baseline$mesh.csv"; then
            line+="   (curves differ: see the baseline line below)"
        fi
    fi
    echo "$line"
    results+=("$mesh $ccx_best $acq_best")
done

# The machine's pace: cantools decoding 20,000 frames of the shipped log.
if python=$("$root"/scripts/python-peers dbc 2>/dev/null); then
    for _ in $(seq 334); do cat "$root"/fixtures/logs/excavator_case1.log; done | head -n 20000 >yardstick.log
    best=""
    for _ in 1 2 3; do
        start=$(date +%s.%N)
        "$python" -m cantools decode "$root"/fixtures/dbc/somat_excavator.dbc <yardstick.log >/dev/null
        best=$(smaller "$best" "$(seconds_since "$start")")
    done
    printf 'BENCH yardstick: cantools decode, %.0f frames/s (20,000 frames, best of 3)\n' "$(echo "20000 / $best" | bc -l)"
fi

last=${meshes##* }
first=${meshes%% *}
"$acq" twin gtn --flow-curve flow.csv --param q1=1.5,q2=1,q3=2.25,epsN=0.3,sN=0.1,fN=0,f0=0,m=0 \
    --imperfection 0.005 --mesh "$last" --step-mm 0.0125 --test "CalculiX-$last.csv" \
    --svg "$root/benches/results/twin-vs-calculix.svg" >/dev/null
BASELINE="$baseline" FIRST="$first" LAST="$last" MIN_RATIO="$min_ratio" python3 - "${results[@]}" <<'EOF'
import csv, math, os, sys
def load(path):
    rows = list(csv.reader(open(path)))[1:]
    return [(float(r[0]), float(r[1])) for r in rows]
def at(curve, u):
    for (u0, f0), (u1, f1) in zip(curve, curve[1:]):
        if u0 - 1e-9 <= u <= u1 + 1e-9:
            return f0 + (f1 - f0) * (u - u0) / (u1 - u0) if u1 > u0 else f1
def compare(reference, other):
    peak_u, peak_f = max(reference, key=lambda p: p[1])
    before = max(abs(at(other, u) - f) / f for u, f in reference[1:] if u <= peak_u and at(other, u) is not None)
    after = max(abs(at(other, u) - f) / peak_f for u, f in reference[1:] if u > peak_u and at(other, u) is not None)
    return before, after
first, last = os.environ["FIRST"], os.environ["LAST"]
considere = 1000 * 0.12 ** 0.12 * math.pi * (2 * 0.995) ** 2 * math.exp(-0.12) / 1000
curves = {}
for mesh in {first, last}:
    curves["ccx" + mesh] = load("CalculiX-%s.csv" % mesh)
    curves["acq" + mesh] = load("acq%s.csv" % mesh)
for name, curve in sorted(curves.items()):
    u, f = max(curve, key=lambda p: p[1])
    print("BENCH %s: peak %.4f kN at %.4f mm (Considere %.4f kN, %+.2f %%)" % (name, f, u, considere, 100 * (f / considere - 1)))
# At the points of the first (every ccx increment is a multiple of
# acq's 0.0125 mm output step, so no interpolation blurs the yield knee).
pairs = [("ccx" + last, "acq" + last)]
if first != last:
    pairs = [("ccx" + last, "ccx" + first), ("acq" + last, "acq" + first)] + pairs
for reference, other in pairs:
    before, after = compare(curves[reference], curves[other])
    print("BENCH %s vs %s: up to the peak %.3f %%, after it %.3f %% of the peak" % (other, reference, 100 * before, 100 * after))
failures = []
if before > 0.001:
    failures.append("acq's curve leaves CalculiX's by %.3f %% before the peak at %s (goal 0.1 %%)" % (100 * before, last))
if os.environ["BASELINE"]:
    for mesh in [first, last]:
        b_before, b_after = compare(load("acq%s.csv" % mesh), load("baseline%s.csv" % mesh))
        print("BENCH baseline vs acq %s: up to the peak %.2e %%, after it %.2e %% of the peak" % (mesh, 100 * b_before, 100 * b_after))
minimum = float(os.environ["MIN_RATIO"])
for result in sys.argv[1:]:
    mesh, ccx, acq = result.split()
    ratio = float(ccx) / float(acq)
    if ratio < minimum:
        failures.append("CalculiX / acq is %.1f x at %s, below the goal of %g x" % (ratio, mesh, minimum))
for failure in failures:
    print("twin-vs-calculix: " + failure, file=sys.stderr)
sys.exit(1 if failures else 0)
EOF
