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
