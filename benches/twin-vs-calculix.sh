#!/bin/sh
# acq's tensile twin against an independent FE code on the same problem,
# damage off: the round bar of examples/calculix-tensile (radius 2 mm, half
# length 12.5 mm, 0.5 % cosine imperfection), the Swift flow table K = 1000
# MPa, n = 0.12, E = 210 GPa, nu = 0.3. Each code runs at two meshes (is it
# converged?), then the two codes are compared at their finer meshes: the
# largest difference up to the peak force (relative) and after it (as a
# share of the peak), and each peak against Considere's closed form. Writes
# the overlay plot to benches/results/twin-vs-calculix.svg.
#
#   sh benches/twin-vs-calculix.sh
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
acq=${ACQ:-$root/target/release/acq}
[ -x "$acq" ] || { echo "build acq first: cargo build --release" >&2; exit 1; }
command -v ccx >/dev/null || { echo "ccx is missing: apt-get install calculix-ccx" >&2; exit 1; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cp "$root"/examples/calculix-tensile/tensile.py "$work"/
cd "$work"
python3 tensile.py flow --K 1000 --n 0.12 -o flow.csv
echo '{"K_mpa": 1000, "n": 0.12}' >params.json
for mesh in 8x40 12x60; do
    mkdir "ccx$mesh"
    start=$(date +%s.%N)
    (cd "ccx$mesh" && python3 ../tensile.py run --params ../params.json --mesh "$mesh")
    echo "ccx $mesh: $(echo "$(date +%s.%N) - $start" | bc) s"
    sed "1s/.*/DISPLACEMENT,FORCE/" "ccx$mesh/curve.csv" >"CalculiX-$mesh.csv"
    start=$(date +%s.%N)
    "$acq" twin gtn --flow-curve flow.csv --param q1=1.5,q2=1,q3=2.25,epsN=0.3,sN=0.1,fN=0,f0=0,m=0 \
        --imperfection 0.005 --end-mm 2.5 --mesh "$mesh" --step-mm 0.0125 -o "acq$mesh.csv" >/dev/null
    echo "acq $mesh: $(echo "$(date +%s.%N) - $start" | bc) s"
done
mkdir -p "$root/benches/results"
"$acq" twin gtn --flow-curve flow.csv --param q1=1.5,q2=1,q3=2.25,epsN=0.3,sN=0.1,fN=0,f0=0,m=0 \
    --imperfection 0.005 --mesh 12x60 --step-mm 0.0125 --test CalculiX-12x60.csv \
    --svg "$root/benches/results/twin-vs-calculix.svg" >/dev/null
python3 - <<'EOF'
import csv, math
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
considere = 1000 * 0.12 ** 0.12 * math.pi * (2 * 0.995) ** 2 * math.exp(-0.12) / 1000
files = {"ccx8x40": "CalculiX-8x40", "ccx12x60": "CalculiX-12x60", "acq8x40": "acq8x40", "acq12x60": "acq12x60"}
curves = {name: load(file + ".csv") for name, file in files.items()}
for name, curve in curves.items():
    u, f = max(curve, key=lambda p: p[1])
    print("BENCH %s: peak %.4f kN at %.4f mm (Considere %.4f kN, %+.2f %%)" % (name, f, u, considere, 100 * (f / considere - 1)))
# At the points of the first (every ccx increment is a multiple of
# acq's 0.0125 mm output step, so no interpolation blurs the yield knee).
for reference, other in [("ccx12x60", "ccx8x40"), ("acq12x60", "acq8x40"), ("ccx12x60", "acq12x60")]:
    before, after = compare(curves[reference], curves[other])
    print("BENCH %s vs %s: up to the peak %.3f %%, after it %.3f %% of the peak" % (other, reference, 100 * before, 100 * after))
EOF
