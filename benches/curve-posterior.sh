#!/usr/bin/env bash
# A curve study's posterior where the model is cheap, end to end:
#
#   benches/curve-posterior.sh [BASELINE_ACQ]
#
# Twelve points of a decay y = a exp(-b x) (x = 0.25 to 3, a = 3, b = 0.7)
# measured with noise of sd 0.02 as a force transducer reads it, a Python
# solver (about 30 ms a run, the interpreter's start), 40 runs of Bayesian
# optimisation, then the posterior on the emulator of those runs:
# `acq calibrate external --seed 1`. Prints the wall time, the
# calibrated line and the convergence line of this build, and of
# BASELINE_ACQ (an acq built before) on the same files when given, with
# the ratio.
#
# Fails loudly (exit 1) when this build's posterior has not converged,
# its 90 % intervals miss the truth, or the whole calibration takes 60 s
# or more: a cheap model's posterior takes seconds.
set -euo pipefail
cd "$(dirname "$0")/.."
baseline=${1:-}
cargo build --release --quiet
acq="$PWD/target/release/acq"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cat >"$work/model.py" <<'EOF'
import math, sys
a, b = float(sys.argv[1]), float(sys.argv[2])
with open("curve.csv", "w") as out:
    out.write("x,y\n")
    for i in range(1, 13):
        x = 0.25 * i
        out.write(f"{x!r},{a * math.exp(-b * x)!r}\n")
EOF
python3 - "$work/measured.csv" <<'EOF'
import math, random, sys
random.seed(5)
with open(sys.argv[1], "w") as out:
    out.write("x,y\n")
    for i in range(1, 13):
        x = 0.25 * i
        out.write(f"{x!r},{3.0 * math.exp(-0.7 * x) + random.gauss(0, 0.02)!r}\n")
EOF
cat >"$work/spec.toml" <<EOF
command = ["python3", "$work/model.py", "{a}", "{b}"]
parallel = 2

[[curve]]
name = "decay"
file = "curve.csv"
x = "x"
y = "y"
measured_file = "measured.csv"
measured_x = "x"
measured_y = "y"

[search]
method = "bo"
max_evals = 40

[[parameter]]
name = "a"
lower = 1.0
upper = 5.0

[[parameter]]
name = "b"
lower = 0.2
upper = 1.5

[posterior]
EOF

# One calibration by `binary`: its wall time (s) on stdout, its answer on stderr.
calibrate() {
    local binary="$1" out="$2" started ended
    started=$(date +%s.%N)
    "$binary" calibrate external --spec "$work/spec.toml" --out "$out" --seed 1 \
        >"$out.log" 2>&1 || { cat "$out.log" >&2; return 1; }
    ended=$(date +%s.%N)
    grep -E '^(calibrated|convergence)' "$out.log" >&2
    echo "$ended - $started" | bc
}

echo "this build ($acq):" >&2
now=$(calibrate "$acq" "$work/now")
printf '  %.1f s\n' "$now" >&2
if [ -n "$baseline" ]; then
    echo "baseline ($baseline):" >&2
    before=$(calibrate "$baseline" "$work/before")
    printf '  %.1f s; this build takes %.3f of its time\n' "$before" "$(echo "$now / $before" | bc -l)" >&2
fi

failed=0
grep -q '^convergence: converged' "$work/now.log" || {
    echo "curve-posterior: the posterior has not converged" >&2
    failed=1
}
python3 - "$work/now/summary.json" <<'EOF' || failed=1
import json, sys
posterior = json.load(open(sys.argv[1]))["posterior"]
for name, truth in (("a", 3.0), ("b", 0.7)):
    low, high = posterior[name]["q05"], posterior[name]["q95"]
    if not low <= truth <= high:
        sys.exit(f"curve-posterior: {name}'s 90 % interval [{low}, {high}] misses {truth}")
EOF
if [ "$(echo "$now >= 60" | bc)" = 1 ]; then
    echo "curve-posterior: ${now} s; a cheap model's posterior should take seconds" >&2
    failed=1
fi
exit "$failed"
