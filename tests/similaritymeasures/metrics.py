"""similaritymeasures' value of each metric for each pair of curves in the
JSON file argv[1] ([[measured, simulated], ...], each [[x, y], ...]),
printed as JSON [[pcm, frechet, dtw, area], ...].

As acq computes them: both curves normalised by the measured curve's
range on each axis first (PCM normalises so itself, on the raw curves).
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


def metrics(measured, simulated):
    m, s = normalised(measured, simulated)
    return [
        float(sm.pcm(measured, simulated)),
        float(sm.frechet_dist(m, s)),
        float(sm.dtw(m, s)[0]),
        float(sm.area_between_two_curves(m, s)),
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
