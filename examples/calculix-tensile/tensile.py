#!/usr/bin/env python3
"""A user's own FE model, the way acq drives it: a round tensile bar in
CalculiX, calibrated by `acq calibrate external`.

    python3 tensile.py run --params params.json [--mesh 6x30 | --element-mm 0.5] [--out out.json] [--curve curve.csv]
    python3 tensile.py measured --K 1000 --n 0.12 [--noise 0.005] [--seed 1] [--mesh 6x30] -o measured.csv
    python3 tensile.py flow --K 1000 --n 0.12 -o flow.csv   (the *PLASTIC table, for acq twin gtn --flow-curve)

`run` is the solver wrapper acq calls once per evaluation, in the run's own
directory: it writes the deck `bar.inp` (the mesh made from parameters, never
by hand), runs `ccx`, reads the reaction force from `bar.dat`, and writes the
force-displacement curve (`curve.csv`: u_mm, f_kn) and the scalars
(`out.json`: max_force_kn, u_at_max_force_mm, force_at_half_mm_kn,
force_at_end_kn). `--element-mm H` meshes the bar with elements of about H
mm each way (R/H radial, L/H axial, rounded): the size a mesh study
(`acq mesh-study`, `spec-validate.toml`) passes as `{mesh}`. When ccx fails or stops
before the full pull it exits non-zero with the reason on stderr, so acq
logs a failed evaluation and the study goes on.

The model (an axisymmetric quarter of the bar, the published tensile
specimen): radius 2 mm, half gauge length 12.5 mm, the radius 0.5 % smaller
at the mid-plane and blending back along a half cosine (so the neck forms
there; the same shape as acq's own twin), CAX8R elements, `*STEP, NLGEOM`,
the end face pulled 2.5 mm. The material: E = 210 GPa, nu = 0.3, and the
Swift hardening law sigma = K (0.002 + eps_p)^n as a `*PLASTIC` table; K
(MPa) and n are what the study calibrates.

Standard library only (Python 3.8+). For your Abaqus job: replace `deck()`
with your own input file (or a template with the parameters filled in),
`ccx` with `abaqus job=bar interactive`, and `reaction_force()` with a read
of your `.odb` report or `.dat` file.
"""

import argparse
import json
import math
import os
import random
import subprocess
import sys
import tempfile

RADIUS_MM = 2.0
HALF_LENGTH_MM = 12.5
IMPERFECTION = 0.005  # radius 0.5 % smaller at the mid-plane
PULL_MM = 2.5
YOUNGS_MPA = 210000.0
POISSON = 0.3
SWIFT_EPS0 = 0.002
# ccx expands axisymmetric elements into a 2-degree wedge and prints the
# wedge's reaction force: the whole bar carries 180 times as much. Checked
# against the elastic slope E A / L in the tests (acq's tests/calculix.rs).
WEDGE_FACTOR = 180.0


def fail(message):
    print("tensile.py: " + message, file=sys.stderr)
    sys.exit(1)


def parse_mesh(text):
    try:
        radial, axial = (int(part) for part in text.lower().split("x"))
    except ValueError:
        fail("--mesh %r: give RADIALxAXIAL elements, e.g. 6x30" % text)
    if not (1 <= radial <= 64 and 2 <= axial <= 400):
        fail("--mesh %r: 1-64 radial and 2-400 axial elements" % text)
    return radial, axial


def flow_table(k_mpa, n):
    """The Swift law as (true stress MPa, plastic strain) pairs, plastic
    strain from 0 to 3 (a neck reaches about 1), denser at small strains."""
    strains = [0.0] + [3.0 * (i / 60.0) ** 2 for i in range(1, 61)]
    return [(k_mpa * (SWIFT_EPS0 + e) ** n, e) for e in strains]


def deck(k_mpa, n, radial, axial):
    """The CalculiX (Abaqus-format) input deck of the bar."""
    columns, rows = 2 * radial + 1, 2 * axial + 1

    def node_id(i, j):
        return j * columns + i + 1

    lines = ["*HEADING", "Round tensile bar, axisymmetric quarter, acq example",
             "*NODE, NSET=NALL"]
    for j in range(rows):
        z = HALF_LENGTH_MM * j / (rows - 1)
        # The mid-plane's smaller radius blends into the nominal along a
        # half cosine: the shape acq's own tensile twin uses.
        shape = 0.5 * (1.0 + math.cos(math.pi * z / HALF_LENGTH_MM))
        radius = RADIUS_MM * (1.0 - IMPERFECTION * shape)
        for i in range(columns):
            if i % 2 == 1 and j % 2 == 1:
                continue  # element centres: CAX8R has no centre node
            r = radius * i / (columns - 1)
            lines.append("%d, %.10g, %.10g" % (node_id(i, j), r, z))
    lines.append("*ELEMENT, TYPE=CAX8R, ELSET=EALL")
    element = 0
    for b in range(axial):
        for a in range(radial):
            i, j = 2 * a, 2 * b
            element += 1
            corners = [node_id(i, j), node_id(i + 2, j), node_id(i + 2, j + 2), node_id(i, j + 2)]
            middles = [node_id(i + 1, j), node_id(i + 2, j + 1), node_id(i + 1, j + 2), node_id(i, j + 1)]
            lines.append("%d, %s" % (element, ", ".join(str(x) for x in corners + middles)))

    def node_set(name, ids):
        lines.append("*NSET, NSET=%s" % name)
        ids = list(ids)
        for start in range(0, len(ids), 16):
            lines.append(", ".join(str(x) for x in ids[start:start + 16]))

    node_set("NAXIS", (node_id(0, j) for j in range(rows)))
    node_set("NMID", (node_id(i, 0) for i in range(columns)))
    node_set("NEND", (node_id(i, rows - 1) for i in range(columns)))
    lines += [
        "*MATERIAL, NAME=STEEL",
        "*ELASTIC",
        "%.10g, %.10g" % (YOUNGS_MPA, POISSON),
        "*PLASTIC",
    ]
    lines += ["%.10g, %.10g" % pair for pair in flow_table(k_mpa, n)]
    lines += [
        "*SOLID SECTION, ELSET=EALL, MATERIAL=STEEL",
        "*BOUNDARY",
        "NAXIS, 1, 1, 0.0",
        "NMID, 2, 2, 0.0",
        "*STEP, NLGEOM, INC=2000",
        "*STATIC",
        "0.01, 1.0, 1e-6, 0.02",
        "*BOUNDARY",
        "NEND, 2, 2, %.10g" % PULL_MM,
        "*NODE PRINT, NSET=NEND, TOTALS=ONLY",
        "RF",
        "*END STEP",
    ]
    return "\n".join(lines) + "\n"


def reaction_force(dat_path):
    """(time, axial reaction force of the whole bar in kN) per increment
    from ccx's .dat file."""
    points = []
    with open(dat_path) as dat:
        lines = dat.read().splitlines()
    for index, line in enumerate(lines):
        if "total force" in line and "time" in line:
            time = float(line.split()[-1])
            # The totals line follows after a blank line.
            for following in lines[index + 1:index + 4]:
                fields = following.split()
                if len(fields) == 3:
                    axial_n = float(fields[1]) * WEDGE_FACTOR
                    points.append((time, axial_n / 1000.0))
                    break
    return points


def simulate(k_mpa, n, radial, axial):
    """Runs ccx in the current directory; the (u_mm, f_kn) curve from 0."""
    with open("bar.inp", "w") as f:
        f.write(deck(k_mpa, n, radial, axial))
    environment = dict(os.environ, OMP_NUM_THREADS=os.environ.get("OMP_NUM_THREADS", "1"))
    try:
        done = subprocess.run(["ccx", "-i", "bar"], stdout=open("ccx.log", "w"),
                              stderr=subprocess.STDOUT, env=environment)
    except FileNotFoundError:
        fail("ccx is not installed (Debian: apt-get install calculix-ccx)")
    log = open("ccx.log").read()
    errors = [line.strip() for line in log.splitlines() if "*ERROR" in line]
    if done.returncode != 0 or errors:
        fail("ccx failed (exit %d): %s" % (done.returncode, " / ".join(errors[-3:]) or log[-300:]))
    points = reaction_force("bar.dat")
    if not points:
        fail("ccx wrote no reaction force in bar.dat")
    last_time = points[-1][0]
    if last_time < 1.0 - 1e-9:
        fail("ccx stopped at %.1f %% of the pull (u = %.4f mm): no convergence"
             % (100 * last_time, last_time * PULL_MM))
    return [(0.0, 0.0)] + [(t * PULL_MM, f) for t, f in points]


def read_params(path):
    try:
        with open(path) as f:
            params = json.load(f)
        return float(params["K_mpa"]), float(params["n"])
    except (OSError, ValueError, KeyError) as error:
        fail("%s: expected {\"K_mpa\": ..., \"n\": ...}: %s" % (path, error))


def write_curve(path, curve, header="u_mm,f_kn"):
    with open(path + ".tmp", "w") as f:
        f.write(header + "\n")
        for u, force in curve:
            f.write("%.10g,%.10g\n" % (u, force))
    os.replace(path + ".tmp", path)


def force_at(curve, u_mm):
    """The curve's force at `u_mm`, linearly interpolated."""
    for (u0, f0), (u1, f1) in zip(curve, curve[1:]):
        if u0 <= u_mm <= u1:
            return f0 + (f1 - f0) * (u_mm - u0) / (u1 - u0) if u1 > u0 else f1
    fail("the curve does not reach u = %g mm" % u_mm)


def scalars(curve):
    """What a test report states: the maximum force and where it is, the
    force at 0.5 mm (in the hardening, before the neck), and the force at
    the end of the pull (deep in the neck, where the mesh matters)."""
    u_max, f_max = max(curve, key=lambda p: p[1])
    return {"max_force_kn": f_max, "u_at_max_force_mm": u_max,
            "force_at_half_mm_kn": force_at(curve, 0.5),
            "force_at_end_kn": curve[-1][1]}


def mesh_of_size(element_mm):
    """Radial and axial element counts for elements of about `element_mm`."""
    if not (0.05 <= element_mm <= RADIUS_MM):
        fail("--element-mm %g: give 0.05 to %g mm" % (element_mm, RADIUS_MM))
    return max(1, round(RADIUS_MM / element_mm)), max(2, round(HALF_LENGTH_MM / element_mm))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    commands = parser.add_subparsers(dest="command", required=True)
    run = commands.add_parser("run", help="one model run (what acq calls)")
    run.add_argument("--params", required=True)
    run.add_argument("--mesh", default="6x30")
    run.add_argument("--element-mm", type=float, help="element size instead of --mesh")
    run.add_argument("--out", default="out.json")
    run.add_argument("--curve", default="curve.csv")
    measured = commands.add_parser("measured", help="a synthetic test: the model at a truth plus noise")
    measured.add_argument("--K", type=float, required=True, dest="k_mpa")
    measured.add_argument("--n", type=float, required=True)
    measured.add_argument("--noise", type=float, default=0.005, help="relative force noise (std)")
    measured.add_argument("--seed", type=int, default=1)
    measured.add_argument("--mesh", default="6x30")
    measured.add_argument("-o", "--output", required=True)
    flow = commands.add_parser("flow", help="the Swift *PLASTIC table as acq reads it")
    flow.add_argument("--K", type=float, required=True, dest="k_mpa")
    flow.add_argument("--n", type=float, required=True)
    flow.add_argument("-o", "--output", required=True)
    args = parser.parse_args()
    if args.command == "flow":
        with open(args.output, "w") as f:
            f.write("PLASTIC_STRAIN,TRUE_STRESS_MPA\n")
            for stress, strain in flow_table(args.k_mpa, args.n):
                f.write("%.10g,%.10g\n" % (strain, stress))
        return
    radial, axial = parse_mesh(args.mesh)
    if getattr(args, "element_mm", None) is not None:
        radial, axial = mesh_of_size(args.element_mm)
    if args.command == "run":
        k_mpa, n = read_params(args.params)
        curve = simulate(k_mpa, n, radial, axial)
        write_curve(args.curve, curve)
        with open(args.out + ".tmp", "w") as f:
            json.dump(scalars(curve), f)
        os.replace(args.out + ".tmp", args.out)
    else:
        output = os.path.abspath(args.output)
        with tempfile.TemporaryDirectory() as scratch:
            os.chdir(scratch)  # ccx's files stay out of the way
            curve = simulate(args.k_mpa, args.n, radial, axial)
        args.output = output
        noise = random.Random(args.seed)
        noisy = [(u, f * (1.0 + args.noise * noise.gauss(0.0, 1.0)) if u > 0 else 0.0)
                 for u, f in curve]
        write_curve(args.output, noisy, header="DISPLACEMENT,FORCE")
        # The measured scalars carry the same relative noise; their standard
        # uncertainty is stated beside them.
        measured_scalars = {name: value * (1.0 + args.noise * noise.gauss(0.0, 1.0))
                            for name, value in scalars(curve).items()
                            if name != "u_at_max_force_mm"}
        summary = {"truth": {"K_mpa": args.k_mpa, "n": args.n},
                   "noise": args.noise, "seed": args.seed, "mesh": args.mesh,
                   "measured": measured_scalars,
                   "uncertainty": {name: abs(value) * args.noise
                                   for name, value in measured_scalars.items()}}
        with open(os.path.splitext(args.output)[0] + ".json", "w") as f:
            json.dump(summary, f, indent=1)
            f.write("\n")


if __name__ == "__main__":
    main()
