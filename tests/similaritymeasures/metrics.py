"""similaritymeasures' value of each metric for each pair of curves in the
JSON file argv[1] ([[measured, simulated], ...], each [[x, y], ...]),
printed as JSON [[pcm, frechet, dtw, area, pcm_measured_reference,
measured_longer, area_unordered], ...].

As acq computes them: both curves normalised by the measured curve's
range on each axis first (PCM normalises so itself, on the raw curves).
acq's PCM always maps the simulated curve onto the measured one; the
library maps the shorter onto the longer. `pcm_measured_reference` is the
library's own code without that swap (the one line marked below); where
the measured curve is the longer (`measured_longer`) it is the library's
value. `area_unordered` is the area without the re-ordering of crossing
quadrilaterals (what 1.3.0 computed): where it differs from `area`, a
quadrilateral crossed itself.
Written for tests/curve_metrics.rs and benches/curve_metrics.rs; the
library lives in a scratch virtualenv, never in acq's dependencies.
"""
import json
import sys
import time

import numpy as np
import similaritymeasures as sm


def normalised(measured, simulated):
    lo = measured.min(axis=0)
    span = measured.max(axis=0) - lo
    return (measured - lo) / span, (simulated - lo) / span


def pcm_measured_reference(exp_data, num_data):
    """similaritymeasures.pcm (1.5.0, norm_seg_length=False) with the
    measured curve always the reference."""
    lib = sm.similaritymeasures
    xi1, eta1, xi2, eta2 = lib.normalizeTwoCurves(
        exp_data[:, 0], exp_data[:, 1], num_data[:, 0], num_data[:, 1])
    le, le_nj, le_sum = lib.get_length(xi1, eta1, False)
    lc, lc_nj, lc_sum = lib.get_length(xi2, eta2, False)
    le = le / le_nj
    le_sum = le_sum / le_nj
    lc = lc / lc_nj
    lc_sum = lc_sum / lc_nj
    # The library swaps the curves here when lc_nj > le_nj.
    n_sum = len(le_sum)
    min_offset = 0.0
    max_offset = le_nj - lc_nj
    if min_offset == max_offset:
        offsets = [min_offset]
        pcm_dists = np.zeros(1)
    else:
        offsets = np.linspace(min_offset, max_offset, 200)
        pcm_dists = np.zeros(200)
    for i, offset in enumerate(offsets):
        xitemp = np.interp(le_sum + offset, lc_sum, xi2)
        etatemp = np.interp(le_sum + offset, lc_sum, eta2)
        d = np.sqrt((eta1 - etatemp) ** 2 + (xi1 - xitemp) ** 2)
        d1 = d[:-1]
        d2 = d[1:n_sum]
        v = 0.5 * (d1 + d2) * le_sum[1:n_sum]
        pcm_dists[i] = np.sum(v)
    return np.min(pcm_dists), le_nj >= lc_nj


def area_unordered(exp_data, num_data):
    """area_between_two_curves with each quadrilateral's shoelace area as
    its vertices come (no makeQuad re-ordering)."""
    lib = sm.similaritymeasures
    make_quad = lib.makeQuad
    lib.makeQuad = lambda x, y: lib.poly_area(x, y)
    try:
        return sm.area_between_two_curves(exp_data, num_data)
    finally:
        lib.makeQuad = make_quad


def metrics(measured, simulated):
    m, s = normalised(measured, simulated)
    reference, measured_longer = pcm_measured_reference(measured, simulated)
    return [
        float(sm.pcm(measured, simulated)),
        float(sm.frechet_dist(m, s)),
        float(sm.dtw(m, s)[0]),
        float(sm.area_between_two_curves(m, s)),
        float(reference),
        1.0 if measured_longer else 0.0,
        float(area_unordered(m, s)),
    ]


def main():
    pairs = json.load(open(sys.argv[1]))
    timing = len(sys.argv) > 2 and sys.argv[2] == "--time"
    out = []
    for measured, simulated in pairs:
        measured = np.array(measured, dtype=float)
        simulated = np.array(simulated, dtype=float)
        if timing:
            m, s = normalised(measured, simulated)
            seconds = []
            for run in (lambda: sm.pcm(measured, simulated),
                        lambda: sm.frechet_dist(m, s),
                        lambda: sm.dtw(m, s),
                        lambda: sm.area_between_two_curves(m, s)):
                start = time.perf_counter()
                run()
                seconds.append(time.perf_counter() - start)
            out.append(seconds)
        else:
            out.append(metrics(measured, simulated))
    print(json.dumps(out))


main()
