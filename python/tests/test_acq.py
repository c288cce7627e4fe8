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
    with pytest.raises((OSError, ValueError), match="nowhere.log"):
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
