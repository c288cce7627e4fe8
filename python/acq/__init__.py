"""acq from Python: the same engine as the ``acq`` command, in process.

- :func:`decode` reads a CAN log (candump, ASC, BLF, MF4) or a session
  directory through a rig or DBC files into a ``pyarrow.Table``, the table
  ``acq decode -o FILE.parquet`` writes (``.to_pandas()`` and
  ``polars.from_arrow`` work on it as usual).
- :func:`calibrate` runs the study a spec describes and returns its
  :class:`Run`.
- :class:`Run` opens a finished run directory: its summary, its
  evaluations, and its posterior as ``arviz.InferenceData``.

Errors are Python's: a bad argument, rig, DBC or spec and malformed input
raise ``ValueError`` (the message names the file and line), a failed read
or write ``OSError``.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any, Callable, Dict, Mapping, Optional, Sequence, Union

import pyarrow as pa
import pyarrow.csv as pa_csv

from . import _acq

__all__ = ["decode", "calibrate", "Run", "__version__"]
__version__: str = _acq.version()

PathLike = Union[str, "os.PathLike[str]"]


def decode(
    log_path: PathLike,
    rig: Optional[PathLike] = None,
    dbc: Union[PathLike, Sequence[PathLike], None] = None,
    *,
    labels: bool = False,
    skip_bad: bool = False,
) -> pa.Table:
    """Decode a log or a session directory into a ``pyarrow.Table``.

    With ``rig`` (or a session directory, which brings its rig) the columns
    are ``time_s`` (UTC timestamp), ``sensor``, ``value`` (null where the
    device sent "not available") and ``unit``; with ``dbc`` (one file or
    several) ``time_s``, ``iface``, ``can_id``, ``message``, ``signal``,
    ``value``, ``unit`` and, with ``labels=True``, ``label``. Each column's
    unit is in its field metadata. ``skip_bad=True`` reads past malformed
    lines (counted) instead of stopping at the first.
    """
    if dbc is None:
        dbc_files = []
    elif isinstance(dbc, (str, os.PathLike)):
        dbc_files = [os.fspath(dbc)]
    else:
        dbc_files = [os.fspath(d) for d in dbc]
    return _acq.decode(
        os.fspath(log_path),
        None if rig is None else os.fspath(rig),
        dbc_files,
        labels,
        skip_bad,
    )


ModelFunction = Callable[[Dict[str, float]], Mapping[str, Any]]


def calibrate(
    spec_path: PathLike,
    out: PathLike,
    model: Optional[ModelFunction] = None,
    *,
    seed: int = 1,
    resume: bool = False,
) -> "Run":
    """Run the study ``spec_path`` (TOML) describes into the directory ``out``.

    As ``acq calibrate external --spec SPEC --out OUT``: progress on the
    terminal, every run logged in ``out/evaluations.csv``, the report and
    ``summary.json`` at the end; ``resume=True`` continues a run directory
    without repeating its runs. Returns the finished :class:`Run`.

    ``model``: a Python function as the model, called in this process. It
    takes the parameters and the case's inputs as a dict of floats and
    returns a dict with every output the spec observes: a float, or for a
    curve a pair ``(x, y)`` of sequences. The spec then needs no
    ``command`` (one it has is not run). An exception in it is a failed
    run, its traceback in the log's ``reason``; the study goes on.
    """
    _acq.calibrate(os.fspath(spec_path), os.fspath(out), seed, resume, model)
    return Run(out)


class Run:
    """A finished (or resumable) run directory of a study."""

    def __init__(self, run_dir: PathLike) -> None:
        self.path = Path(run_dir)
        if not (self.path / "summary.json").is_file():
            raise ValueError(
                f"{self.path}: not a finished run directory (no summary.json); "
                "give the directory a study wrote (acq calibrate ... --out DIR)"
            )

    def __repr__(self) -> str:
        return f"acq.Run({str(self.path)!r})"

    @property
    def summary(self) -> Dict[str, Any]:
        """``summary.json`` as a dict."""
        with open(self.path / "summary.json", encoding="utf-8") as f:
            summary: Dict[str, Any] = json.load(f)
        return summary

    @property
    def evaluations(self) -> pa.Table:
        """Every model run of the study (``evaluations.csv``) as a table."""
        return pa_csv.read_csv(self.path / "evaluations.csv")

    @property
    def posterior(self) -> pa.Table:
        """The posterior's draws (``posterior.csv``: chain, draw, each
        parameter, log_posterior) as a table."""
        path = self.path / "posterior.csv"
        if not path.is_file():
            raise ValueError(
                f"{self.path}: this study sampled no posterior (no posterior.csv); "
                "add [posterior] to its spec"
            )
        return pa_csv.read_csv(path)

    def to_arviz(self) -> Any:
        """The posterior as ``arviz.InferenceData``.

        Its ``posterior`` group holds every parameter of ``posterior.csv``
        with dimensions ``chain`` and ``draw``; ``sample_stats`` holds the
        log posterior (``lp``).
        """
        import arviz as az
        import numpy as np

        table = self.posterior
        chains = np.asarray(table.column("chain").to_numpy())
        draws = np.asarray(table.column("draw").to_numpy())
        chain_ids = np.unique(chains)
        n_draws = int(draws.max())
        order = np.lexsort((draws, chains))

        def shaped(name: str) -> Any:
            values = np.asarray(table.column(name).to_numpy(), dtype=float)[order]
            return values.reshape(len(chain_ids), n_draws)

        names = [n for n in table.column_names if n not in ("chain", "draw", "log_posterior")]
        posterior = {name: shaped(name) for name in names}
        sample_stats = {}
        if "log_posterior" in table.column_names:
            sample_stats["lp"] = shaped("log_posterior")
        return az.from_dict(posterior=posterior, sample_stats=sample_stats)
