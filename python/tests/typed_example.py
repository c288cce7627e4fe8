"""The README's notebook steps as a script mypy checks against the stubs."""

import pyarrow as pa

import acq


def rows_of(log: str, rig: str) -> int:
    table: pa.Table = acq.decode(log, rig=rig)
    return int(table.num_rows)


def rhat_of(run_dir: str) -> float:
    run = acq.Run(run_dir)
    summary = run.summary
    value = summary["posterior"]["k_kn_per_mm"]["rhat"]
    return float(value)
