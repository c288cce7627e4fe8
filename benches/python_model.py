"""A study whose model is a Python function: acq's own time per run, and
what running runs at once gains (python/ issue 54's speed target: under
0.2 ms a run beside a model of 1 ms).

    target/tmp/acq-python-dev/bin/python benches/python_model.py

The study: one parameter on [1, 5], one case, one measured output; the
search's start design is the whole study (`start_runs = max_evals`), so
every run is proposed, called and logged, and no surrogate is fitted (its
cost belongs to the method, not to the per-run plumbing).

- acq's time per run: from the start of one model call to the start of
  the next, less the model's own time, over a study of 600 runs (the
  model notes both instants). What a study does once (its start design,
  the surrogate it fits for the report, the report) is printed apart:
  it does not grow with the runs' cost. Each study is timed 3 times; the
  best counts.
- parallel = 2 with a model that sleeps 1 ms (time.sleep releases the GIL,
  as NumPy, a subprocess or an FE library's solver do), and with one that
  computes in pure Python for 1 ms (holds the GIL): each against
  parallel = 1, the same runs.
"""

import shutil
import tempfile
import time
from pathlib import Path

import acq

SPEC = """
parallel = {parallel}

[[parameter]]
name = "k"
lower = 1.0
upper = 5.0

[[case]]
name = "A"
inputs = {{ load = 2.0 }}
measured = {{ u = {{ value = 0.8, uncertainty = 0.01 }} }}

[search]
method = "bo"
start = "lhs"
start_runs = {runs}
max_evals = {runs}
"""

calls = []  # (start, end) of each model call


def sleeping(inputs):
    """1 ms of waiting, the GIL released (a solver in C, a subprocess)."""
    start = time.perf_counter()
    time.sleep(0.001)
    calls.append((start, time.perf_counter()))
    return {"u": inputs["load"] / inputs["k"]}


def computing(inputs):
    """1 ms of pure Python arithmetic, the GIL held."""
    start = time.perf_counter()
    x = 0.0
    while time.perf_counter() - start < 0.001:
        x += 1.0
    calls.append((start, time.perf_counter()))
    return {"u": inputs["load"] / inputs["k"] + 0.0 * x}


def study(work: Path, runs: int, parallel: int, model) -> "tuple[float, float, float]":
    """(wall s, from the first call's start to the last call's end s,
    model s) of the best of 3 studies."""
    best = (float("inf"), 0.0, 0.0)
    for attempt in range(3):
        spec = work / f"spec-{runs}-{parallel}.toml"
        spec.write_text(SPEC.format(runs=runs, parallel=parallel))
        out = work / f"run-{runs}-{parallel}-{attempt}"
        calls.clear()
        start = time.perf_counter()
        run = acq.calibrate(spec, out=out, model=model)
        wall = time.perf_counter() - start
        assert run.summary["evaluations"] == runs == len(calls), run.summary["evaluations"]
        shutil.rmtree(out)
        runs_span = calls[-1][1] - calls[0][0]
        model_s = sum(end - begin for begin, end in calls)
        best = min(best, (wall, runs_span, model_s))
    return best


def main() -> None:
    with tempfile.TemporaryDirectory(dir=Path(__file__).resolve().parent.parent / "target") as tmp:
        work = Path(tmp)
        runs = 600
        wall, span, model_s = study(work, runs, 1, sleeping)
        per_run_ms = span / runs * 1e3
        model_ms = model_s / runs * 1e3
        print(f"1 ms model (sleep), one run at a time: {per_run_ms:.3f} ms a run, the model {model_ms:.3f} ms")
        print(f"acq's own time per run: {per_run_ms - model_ms:.3f} ms (target: under 0.2 ms)")
        print(f"once a study ({runs} runs): {wall - span:.2f} s (start design, surrogate, report)")
        for name, model in (("sleep, GIL released", sleeping), ("pure Python, GIL held", computing)):
            _, one, _ = study(work, runs, 1, model)
            _, two, _ = study(work, runs, 2, model)
            print(f"parallel = 2 vs 1, {name}: {two:.2f} s vs {one:.2f} s, {one / two:.2f} x")


if __name__ == "__main__":
    main()
