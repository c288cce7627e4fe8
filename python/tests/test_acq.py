"""The Python package against the command line it wraps and the tools it
feeds: run by tests/python_package.rs after `pip install ./python` (the
environment names the acq binary under test and the repository)."""

import json
import os
import shutil
import subprocess
from pathlib import Path

import arviz as az
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

import acq

REPO = Path(os.environ["ACQ_REPO"])
ACQ_BIN = os.environ["ACQ_BIN"]
SESSION = REPO / "fixtures/sessions/excavator_case1"
RIG = SESSION / "rig/excavator.toml"
LOG = REPO / "fixtures/logs/excavator_case1.log"
DBC = REPO / "fixtures/dbc/somat_excavator.dbc"


def cli_parquet(tmp_path: Path, *args: str) -> pa.Table:
    out = tmp_path / "cli.parquet"
    subprocess.run([ACQ_BIN, "decode", *args, "-o", str(out)], check=True, capture_output=True)
    return pq.read_table(out)


def plain(table: pa.Table) -> pa.Table:
    """Dictionary columns as their strings: a table's dictionaries may be
    ordered per batch, a file's per row group; the values are what count."""
    columns = [
        c.cast(c.type.value_type) if pa.types.is_dictionary(c.type) else c for c in table.columns
    ]
    return pa.table(columns, names=table.column_names)


def test_decode_through_a_rig_is_the_clis_parquet(tmp_path: Path) -> None:
    raw = SESSION / "raw.log"
    table = acq.decode(raw, rig=RIG)
    assert table.column_names == ["time_s", "sensor", "value", "unit"]
    assert table.num_rows > 30_000
    cli = cli_parquet(tmp_path, str(raw), "--rig", str(RIG))
    assert table.schema.equals(cli.schema, check_metadata=True)
    assert plain(table).equals(plain(cli))
    # A session directory brings its own rig: the same table.
    assert acq.decode(SESSION).equals(table)
    # The interface as the issue writes it: keywords included.
    assert acq.decode(log_path=raw, rig=RIG).equals(table)
    # Units as the rig gives them, and pandas reads it as it is.
    frame = table.to_pandas()
    assert set(frame.loc[frame.sensor == "tip_force", "unit"]) == {"kN"}


def test_decode_through_a_dbc_is_the_clis_parquet(tmp_path: Path) -> None:
    table = acq.decode(LOG, dbc=DBC)
    assert table.column_names == ["time_s", "iface", "can_id", "message", "signal", "value", "unit"]
    cli = cli_parquet(tmp_path, str(LOG), "--dbc", str(DBC))
    assert table.schema.equals(cli.schema, check_metadata=True)
    assert plain(table).equals(plain(cli))
    labelled = acq.decode(LOG, dbc=[DBC], labels=True)
    assert labelled.column_names[-1] == "label"
    assert labelled.num_rows == table.num_rows


def test_bad_input_is_a_python_error_that_names_the_file(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="give rig="):
        acq.decode(LOG)
    with pytest.raises(ValueError, match="not both"):
        acq.decode(SESSION, rig=RIG, dbc=DBC)
    missing = tmp_path / "nowhere.log"
    with pytest.raises(FileNotFoundError, match="nowhere.log"):
        acq.decode(missing, rig=RIG)
    broken = tmp_path / "broken.log"
    lines = LOG.read_text().splitlines()
    broken.write_text("\n".join(lines[:50] + ["(1763719200.5) can0 123#zz"] + lines[50:100]) + "\n")
    with pytest.raises(ValueError, match="broken.log:51"):
        acq.decode(broken, dbc=DBC)
    # Past the bad line, counted, when asked.
    assert acq.decode(broken, dbc=DBC, skip_bad=True).num_rows > 0
    with pytest.raises(ValueError, match="not a finished run directory"):
        acq.Run(tmp_path)


@pytest.fixture(scope="module")
def spring_run(tmp_path_factory: pytest.TempPathFactory) -> "acq.Run":
    example = tmp_path_factory.mktemp("example")
    for name in ("spec.toml", "spring.sh"):
        shutil.copy(REPO / "examples/validation" / name, example / name)
    # One run at a time: runs at once finish in either order, and the
    # search fits its GP to the log in that order; one at a time, two
    # models that compute the same numbers take the same path.
    spec = example / "spec.toml"
    text = spec.read_text()
    assert "parallel = 2" in text
    spec.write_text(text.replace("parallel = 2", "parallel = 1"))
    return acq.calibrate(example / "spec.toml", out=example / "run")


def test_a_study_run_from_python_reads_back(spring_run: "acq.Run") -> None:
    summary = spring_run.summary
    with open(spring_run.path / "summary.json") as f:
        assert summary == json.load(f)
    evaluations = spring_run.evaluations
    assert evaluations.num_rows == summary["evaluations"]


def test_the_posterior_as_arviz_matches_the_summary(spring_run: "acq.Run") -> None:
    idata = spring_run.to_arviz()
    posterior = spring_run.posterior
    names = [n for n in posterior.column_names if n not in ("chain", "draw", "log_posterior")]
    assert sorted(idata.posterior.data_vars) == sorted(names)
    chains = len(set(posterior.column("chain").to_pylist()))
    for name in names:
        assert idata.posterior[name].dims == ("chain", "draw")
        assert idata.posterior[name].shape == (chains, posterior.num_rows // chains)
    # acq's convergence figures are ArviZ's own.
    rhat = az.rhat(idata)
    ess = az.ess(idata, method="bulk")
    for name, stats in spring_run.summary["posterior"].items():
        assert float(rhat[name]) == pytest.approx(stats["rhat"], rel=1e-9)
        assert float(ess[name]) == pytest.approx(stats["ess_bulk"], rel=1e-9)
    # The draws themselves, in chain and draw order.
    first = names[0]
    column = posterior.column(first).to_pylist()
    assert float(idata.posterior[first][0, 0]) == column[0]


def spring(inputs: dict) -> dict:
    """spring.sh in Python: a seated spring's deflection at two loads."""
    k, d = inputs["k_kn_per_mm"], inputs["offset_mm"]
    f1, f2, s = inputs["f_low_kn"], inputs["f_high_kn"], inputs["softening_per_kn"]
    return {"u_low_mm": f1 / k + d + s * f1 * f1, "u_high_mm": f2 / k + d + s * f2 * f2}


def runs_of(run: "acq.Run") -> list:
    """The log's runs as (case, parameters, outputs) rows, in a fixed order
    (parallel runs finish in either order)."""
    table = run.evaluations.to_pylist()
    keep = [c for c in run.evaluations.column_names if c not in ("id", "status", "wall_s", "reason")]
    assert all(row["status"] == "ok" for row in table)
    return sorted(tuple(float(row[c]) for c in keep) for row in table)


def test_a_python_model_is_the_command_run_for_run(
    spring_run: "acq.Run", tmp_path: Path
) -> None:
    # The spec without its command: a model given to the study needs none.
    text = (spring_run.path.parent / "spec.toml").read_text()
    kept = [l for l in text.splitlines() if not l.startswith(("command", "output_file", "copy_files"))]
    spec = tmp_path / "spec.toml"
    spec.write_text("\n".join(kept) + "\n")
    with pytest.raises(ValueError, match="command is empty"):
        acq.calibrate(spec, out=tmp_path / "no-model")
    # A folder of other files is no run directory, said in Python's words.
    busy = tmp_path / "busy"
    busy.mkdir()
    (busy / "notes.txt").write_text("mine\n")
    with pytest.raises(ValueError, match="no run to resume") as refused:
        acq.calibrate(spec, out=busy, model=spring)
    assert "--" not in str(refused.value)
    assert (busy / "notes.txt").read_text() == "mine\n" and not (busy / "evaluations.csv").exists()
    run = acq.calibrate(spec_path=spec, out=tmp_path / "python", model=spring)
    python_runs, command_runs = runs_of(run), runs_of(spring_run)
    assert len(python_runs) == len(command_runs) > 20
    for ours, theirs in zip(python_runs, command_runs):
        assert ours == pytest.approx(theirs, rel=1e-12), (ours, theirs)
    assert run.summary["posterior"].keys() == spring_run.summary["posterior"].keys()


def test_an_exception_in_the_model_is_a_failed_run_with_its_traceback(
    spring_run: "acq.Run", tmp_path: Path
) -> None:
    def stiff_only(inputs: dict) -> dict:
        if inputs["k_kn_per_mm"] < 1.5:
            raise ZeroDivisionError("too soft for this model")
        return spring(inputs)

    run = acq.calibrate(spring_run.path.parent / "spec.toml", out=tmp_path / "failing", model=stiff_only)
    reasons = [r for r in run.evaluations.column("reason").to_pylist() if r]
    assert reasons, "the latin hypercube puts one of its 8 runs below k = 1.5"
    for reason in reasons:
        assert "Traceback (most recent call last)" in reason
        assert "ZeroDivisionError: too soft for this model" in reason
        assert "stiff_only" in reason


def test_a_model_that_misses_an_output_says_which(spring_run: "acq.Run", tmp_path: Path) -> None:
    run = acq.calibrate(
        spring_run.path.parent / "spec.toml",
        out=tmp_path / "missing",
        model=lambda inputs: spring(inputs) if inputs["k_kn_per_mm"] < 4.0 else {"u_low_mm": 1.0},
    )
    reasons = set(run.evaluations.column("reason").to_pylist())
    assert any('ValueError: the model returned no output "u_high_mm"' in (r or "") for r in reasons), reasons


def test_ctrl_c_stops_the_study_and_resume_finishes_it_as_if_never_stopped(
    spring_run: "acq.Run", tmp_path: Path
) -> None:
    import signal
    import threading
    import time

    def slow_spring(inputs: dict) -> dict:
        time.sleep(0.05)
        return spring(inputs)

    spec = spring_run.path.parent / "spec.toml"
    out = tmp_path / "interrupted"
    # Ctrl-C, as a notebook's interrupt button sends it, into a running study.
    timer = threading.Timer(0.6, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    with pytest.raises(KeyboardInterrupt, match="resume=True"):
        acq.calibrate(spec, out=out, model=slow_spring)
    timer.join()
    logged = (out / "evaluations.csv").read_text().splitlines()
    assert 2 <= len(logged) < 31, "stopped inside the search, its finished runs logged"
    assert not (out / "summary.json").exists()
    resumed = acq.calibrate(spec, out=out, model=slow_spring, resume=True)
    assert runs_of(resumed) == runs_of(spring_run), "the same runs as a study never stopped"


@pytest.mark.filterwarnings("ignore:acq. .*CANopen node")  # the nodes boot 60 times
def test_a_long_log_streams_in_batches_in_bounded_memory(tmp_path: Path) -> None:
    """decode_batches gives decode's table in batches, and its memory does
    not grow with the log: measured in fresh interpreters, against
    decode() of the same log."""
    import sys

    raw = (SESSION / "raw.log").read_text().splitlines()
    first, last = (float(line[1 : line.index(")")]) for line in (raw[0], raw[-1]))
    span = last - first + 0.01
    big = tmp_path / "long.log"
    repeats = 60  # 1.37 M frames, 14 minutes of the session again and again
    with open(big, "w") as f:
        for k in range(repeats):
            shift = k * span
            f.write(
                "\n".join(
                    f"({float(line[1:line.index(')')]) + shift:.6f}){line[line.index(')') + 1:]}"
                    for line in raw
                )
                + "\n"
            )
    streamed = acq.decode_batches(big, rig=RIG)
    sizes = [batch.num_rows for batch in streamed]
    whole = acq.decode(big, rig=RIG)
    assert sum(sizes) == whole.num_rows == repeats * acq.decode(SESSION).num_rows
    assert max(sizes) == 16_384 and len(sizes) > 100
    assert pa.Table.from_batches(
        list(acq.decode_batches(big, rig=RIG)), schema=whole.schema
    ).equals(whole)
    table_mb = whole.nbytes / 1e6
    del whole

    def peak_mb(code: str) -> float:
        # VmHWM, the peak of this process's memory since its exec
        # (getrusage's ru_maxrss keeps the forking pytest's peak).
        script = (
            "import re, sys, acq\n"
            f"log, rig = sys.argv[1], sys.argv[2]\n{code}\n"
            "status = open('/proc/self/status').read()\n"
            "print(int(re.search(r'VmHWM:\\s+(\\d+) kB', status).group(1)) / 1e3)\n"
        )
        out = subprocess.run(
            [sys.executable, "-c", script, str(big), str(RIG)],
            capture_output=True,
            text=True,
            cwd=tmp_path,  # not the source tree, whose acq/ has no extension module
        )
        assert out.returncode == 0, out.stderr
        return float(out.stdout.split()[-1])

    baseline = peak_mb("import pyarrow")
    streaming = peak_mb("rows = sum(b.num_rows for b in acq.decode_batches(log, rig=rig))")
    collected = peak_mb("table = acq.decode(log, rig=rig)")
    # The whole table costs its size; the stream a few batches (16 Ki rows,
    # 0.4 MB each) and the decoder's buffers, whatever the log's length.
    assert collected - baseline > 0.8 * table_mb, (baseline, collected, table_mb)
    assert streaming - baseline < 0.25 * table_mb, (baseline, streaming, table_mb)


def test_a_stream_stopped_early_and_a_bad_line_in_a_stream(tmp_path: Path) -> None:
    reader = acq.decode_batches(SESSION)
    assert reader.read_next_batch().num_rows > 0
    reader.close()  # the decoding thread stops at its next batch
    broken = tmp_path / "broken.log"
    lines = LOG.read_text().splitlines()
    broken.write_text("\n".join(lines[:50] + ["(1763719200.5) can0 123#zz"]) + "\n")
    with pytest.raises(ValueError, match="broken.log:51"):
        acq.decode_batches(broken, dbc=DBC).read_all()


def test_only_what_a_user_must_act_on_is_a_python_warning(tmp_path: Path) -> None:
    """A node's normal start-up (boot-up, operational) is no warning; a node
    that stops is, naming it."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # any warning fails the test
        acq.decode(SESSION)
    raw = (SESSION / "raw.log").read_text().splitlines()
    last = float(raw[-1][1 : raw[-1].index(")")])
    stopped = tmp_path / "stopped.log"
    # Node 0x23's heartbeat: state 4, stopped (CiA 301).
    stopped.write_text("\n".join(raw + [f"({last + 0.001:.6f}) can0 723#04"]) + "\n")
    with pytest.warns(UserWarning, match="CANopen node 0x23 .arm_head_pressure. is Stopped") as said:
        acq.decode(stopped, rig=RIG)
    assert not any("is Operational" in str(w.message) for w in said), [str(w.message) for w in said]


def cli_table(tmp_path: Path, *args: str) -> pa.Table:
    out = tmp_path / "cli.parquet"
    subprocess.run([ACQ_BIN, *args, "-o", str(out)], check=True, capture_output=True)
    return pq.read_table(out)


def test_align_holds_and_curve_are_the_clis_parquet(tmp_path: Path) -> None:
    aligned = acq.align(SESSION, rate_hz=50, max_gap="100ms", start=2.0, end=12.5)
    cli = cli_table(
        tmp_path, "align", str(SESSION), "--rate", "50", "--max-gap", "100ms",
        "--from", "2", "--to", "12.5",
    )
    # Units in each field's metadata; the file's notes (clocks, options),
    # which a Parquet file keeps in its footer, in the schema's metadata.
    assert aligned.schema.remove_metadata().equals(cli.schema.remove_metadata(), check_metadata=True)
    footer = pq.ParquetFile(tmp_path / "cli.parquet").metadata.metadata
    assert aligned.schema.metadata[b"acq.comments"] == footer[b"acq.comments"]
    assert plain(aligned).equals(plain(cli))
    assert aligned.num_rows == 526  # 2.0 .. 12.5 s at 50 Hz, both ends in
    with pytest.raises(ValueError, match='method="cubic"'):
        acq.align(SESSION, method="cubic")

    values = acq.holds(SESSION)
    cli = cli_table(tmp_path, "extract", str(SESSION))
    assert values.schema.equals(cli.schema, check_metadata=True)
    assert plain(values).equals(plain(cli))
    # The session replays the published case 1: its first hold's arm
    # pressure is the published measured value (data/excavator/case1.toml)
    # within the transducer's expanded uncertainty, which is the budget's
    # (about a bar of accuracy), not the hold's 0.02 bar of scatter.
    rows = values.to_pandas().set_index(["window", "quantity"])
    arm = rows.loc[("hold1", "arm_head_pressure")]
    assert abs(arm["mean"] - 193.46) < arm["U95"]
    assert arm["u_c"] > 20 * arm["std"] / arm["n_eff"] ** 0.5

    curve = acq.tensile_curve(REPO / "fixtures/sessions/tensile_p91_20c")
    cli = cli_table(tmp_path, "extract", "--tensile", str(REPO / "fixtures/sessions/tensile_p91_20c"))
    assert curve.schema.equals(cli.schema, check_metadata=True)
    assert curve.equals(cli)
    # Engineering stress is force over the rig's 4 mm bar's area.
    frame = curve.to_pandas()
    import math

    area_mm2 = math.pi * 4.0**2 / 4
    peak = frame["FORCE"].idxmax()
    assert frame["STRESS"][peak] == pytest.approx(frame["FORCE"][peak] * 1e3 / area_mm2, rel=1e-12)


def test_a_session_imported_from_a_loggers_file_reads_as_the_recorded_one(tmp_path: Path) -> None:
    # The recording as a logger's MF4, made a session by `acq import`: the
    # package reads it as it reads the recorded one. Only the windows'
    # times differ: they count from the session's start, which a log
    # cannot know (its first frame stands in).
    mf4 = tmp_path / "00000001.MF4"
    subprocess.run([ACQ_BIN, "convert", str(SESSION / "raw.log"), "-o", str(mf4)], check=True, capture_output=True)
    imported = tmp_path / "imported"
    subprocess.run(
        [ACQ_BIN, "import", str(mf4), "--rig", str(RIG), "--out", str(imported)], check=True, capture_output=True
    )
    times = ["start_s", "end_s"]
    recorded_values = acq.holds(SESSION)
    imported_values = acq.holds(imported)
    assert imported_values.num_rows == recorded_values.num_rows > 20
    assert plain(imported_values.drop_columns(times)).equals(plain(recorded_values.drop_columns(times)))
    aligned = acq.align(imported, rate_hz=50)
    assert aligned.schema.names == acq.align(SESSION, rate_hz=50).schema.names


def test_the_twins_from_python_are_the_commands(tmp_path: Path) -> None:
    import numpy as np

    case = REPO / "data/excavator/case1.toml"
    outputs = acq.twin_excavator(case, arm_stroke_mm=208.0)
    cli = subprocess.run(
        [ACQ_BIN, "twin", "excavator", "--case", str(case), "--arm-stroke", "208", "--json"],
        check=True, capture_output=True, text=True,
    )
    assert outputs == json.loads(cli.stdout)
    # Every cylinder holds the load in its loaded chamber: a positive
    # pressure, below the DX55's relief pressure.
    for cylinder, bar in outputs["pressure_bar"].items():
        assert 0 < bar < 300, (cylinder, bar)

    test = REPO / "data/tensile/P91_20_2_DF_SS.csv"
    params = dict(q1=1.332, q2=0.9952, q3=2.295, epsN=0.29, sN=0.1671, fN=0.03869, f0=0.00137, m=534.1)
    run = acq.twin_gtn(test, params)
    out = tmp_path / "curve.csv"
    param = ",".join(f"{k}={v}" for k, v in params.items())
    cli = subprocess.run(
        [ACQ_BIN, "twin", "gtn", "--test", str(test), "--param", param, "-o", str(out), "--json"],
        check=True, capture_output=True, text=True,
    )
    summary = json.loads(cli.stdout)
    assert run["mape_pct"] == summary["mape"]
    assert run["failed_early"] == summary["failed_early"]
    written = np.genfromtxt(out, delimiter=",", names=True)
    assert isinstance(run["curve"]["force_kn"], np.ndarray)
    np.testing.assert_array_equal(run["curve"]["displacement_mm"], written["DISPLACEMENT"])
    np.testing.assert_array_equal(run["curve"]["force_kn"], written["FORCE"])
    # The published parameters' bar carries the test's maximum force
    # within 3 % (tensile-gtn.md: MAPE below 2 % after calibration).
    assert run["curve"]["force_kn"].max() == pytest.approx(run["test"]["force_kn"].max(), rel=0.03)
    with pytest.raises(ValueError, match="q1"):
        acq.twin_gtn(test, {**params, "q1": -1.0})


def test_the_posterior_predictive_and_the_observed_data_in_arviz(spring_run: "acq.Run") -> None:
    import numpy as np

    idata = spring_run.to_arviz()
    summary = spring_run.summary["predictive"]
    names = {f"{case}.{output}" for case, outputs in summary.items() for output in outputs}
    assert set(idata.posterior_predictive.data_vars) == names
    assert set(idata.observed_data.data_vars) == names
    for name in names:
        case, output = name.split(".")
        stats = summary[case][output]
        draws = idata.posterior_predictive[name]
        assert draws.dims == ("chain", "draw", "observation")
        assert draws.shape == (1, 20, 1)  # [posterior] predictive_runs = 20
        values = draws.values.ravel()
        assert values.mean() == pytest.approx(stats["mean"], rel=1e-12)
        assert np.quantile(values, [0.05, 0.95]) == pytest.approx([stats["q05"], stats["q95"]], rel=1e-12)
        assert float(idata.observed_data[name][0]) == stats["measured"]
    # The validate case C, which the calibration never saw, lies inside
    # its own predictive band (the spring's physics carries to ten times
    # the load).
    c_high = idata.posterior_predictive["C.u_high_mm"].values.ravel()
    assert c_high.min() < float(idata.observed_data["C.u_high_mm"][0]) < c_high.max()


def test_a_runs_curve_rows_in_predictive_csv_are_no_draws(spring_run: "acq.Run", tmp_path: Path) -> None:
    """predictive.csv gives a curve's MAPE per run with `with_error` empty
    (acq writes no draw with error for a curve): to_arviz() leaves those
    rows out, and keeps every scalar's draws."""
    run = tmp_path / "run"
    shutil.copytree(spring_run.path, run)
    predictive = run / "predictive.csv"
    lines = predictive.read_text().splitlines()
    curve_rows = [f"{k},A,force_curve,{0.5 + 0.01 * k}," for k in range(1, 21)]
    predictive.write_text("\n".join(lines[:1] + curve_rows + lines[1:]) + "\n")
    idata = acq.Run(run).to_arviz()
    assert "A.force_curve" not in idata.posterior_predictive.data_vars
    assert set(idata.posterior_predictive.data_vars) == set(spring_run.to_arviz().posterior_predictive.data_vars)


def test_progress_is_told_of_every_run(
    spring_run: "acq.Run", tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import sys

    told: list = []
    run = acq.calibrate(
        spring_run.path.parent / "spec.toml", out=tmp_path / "told", model=spring, progress=told.append
    )
    assert [n["done"] for n in told] == list(range(1, run.summary["evaluations"] + 1))
    assert {n["total"] for n in told} == {30}  # the spec's max_evals
    best = [n["best_loss"] for n in told]
    assert all(b is None or a is None or b <= a for a, b in zip(best, best[1:])), "best only improves"
    assert best[-1] == pytest.approx(run.summary["best_loss_pct"], rel=1e-9)
    # A progress function that raises is reported, and the study goes on.
    def broken(numbers: dict) -> None:
        raise RuntimeError("a broken bar")

    reported: list = []
    monkeypatch.setattr(sys, "unraisablehook", reported.append)
    run = acq.calibrate(
        spring_run.path.parent / "spec.toml", out=tmp_path / "broken", model=spring, progress=broken
    )
    assert run.summary["evaluations"] == len(told)
    assert len(reported) == len(told)
    assert str(reported[0].exc_value) == "a broken bar"


def test_a_progress_bar_with_tqdm(
    spring_run: "acq.Run", tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    run = acq.calibrate(spring_run.path.parent / "spec.toml", out=tmp_path / "bar", model=spring, progress=True)
    bar = capsys.readouterr().err
    assert f"{run.summary['evaluations']}/30" in bar, bar[-300:]


def test_the_progress_lines_go_through_sys_stderr(
    spring_run: "acq.Run", tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    """A notebook shows sys.stderr, not file descriptor 2: the study's own
    progress lines (no bar asked for) reach the former."""
    run = acq.calibrate(spring_run.path.parent / "spec.toml", out=tmp_path / "lines", model=spring)
    err = capsys.readouterr().err
    assert f"{run.summary['evaluations']}/30 evaluations" in err, err[-300:]


def test_the_guides_worked_example_runs(tmp_path: Path) -> None:
    """docs/src/python.md's cells, as one script, from the repository root."""
    import re
    import sys

    page = (REPO / "docs/src/python.md").read_text()
    cells = re.findall(r"```python\n(.*?)```", page, flags=re.S)
    assert len(cells) == 1, "the guide shows one worked example"
    script = cells[0].replace('"target/guide-spring"', repr(str(tmp_path / "spring")))
    script += "\nassert rows == table.num_rows and len(arm) > 0 and gtn['mape_pct'] < 5\n"
    script += "assert set(idata.groups()) >= {'posterior', 'posterior_predictive', 'observed_data'}\n"
    done = subprocess.run(
        [sys.executable, "-c", script],
        cwd=REPO,
        env={**os.environ, "MPLBACKEND": "Agg"},
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr[-3000:]


def test_a_mesh_study_with_a_python_model_gives_the_closed_form(tmp_path: Path) -> None:
    spec = tmp_path / "spec.toml"
    spec.write_text(
        """
[[parameter]]
name = "k"
lower = 1.0
upper = 3.0

[[output]]
name = "stress_mpa"
measured = 100.0

[mesh_study]
sizes = [0.4, 0.2, 0.1]
"""
    )

    def solver(inputs: dict) -> dict:
        # 100 MPa with a second-order discretisation error.
        return {"stress_mpa": 100.0 + 50.0 * inputs["mesh"] ** 2}

    run = acq.mesh_study(spec, out=tmp_path / "mesh", model=solver)
    study = run.summary["mesh_study"]["stress_mpa"]
    assert study["convergence"] == "monotonic"
    assert study["order"] == pytest.approx(2.0, rel=1e-9)
    assert study["extrapolated"] == pytest.approx(100.0, rel=1e-12)
    # GCI = 1.25 * 50 * 0.1^2 / phi(0.1) in %; u_num is the error itself.
    assert study["gci_fine_pct"] == pytest.approx(125.0 * 50.0 * 0.01 / 100.5, rel=1e-9)
    assert study["u_num"] == pytest.approx(0.5, rel=1e-9)
