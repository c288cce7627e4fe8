"""acq from Python: the same engine as the ``acq`` command, in process.

- :func:`decode` reads a CAN log (candump, ASC, BLF, MF4) or a session
  directory through a rig or DBC files into a ``pyarrow.Table``, the table
  ``acq decode -o FILE.parquet`` writes (``.to_pandas()`` and
  ``polars.from_arrow`` work on it as usual).
- :func:`decode_batches` streams the same table as a
  ``pyarrow.RecordBatchReader``: a log of any length in bounded memory.
- :func:`align` puts a session on one time base, :func:`holds` gives the
  measured values of its steady holds with their uncertainty, and
  :func:`tensile_curve` a tensile test's force-displacement curve: the
  tables ``acq align`` and ``acq extract`` write.
- :func:`twin_excavator` and :func:`twin_gtn` run the twins: outputs as
  dicts, curves as NumPy arrays.
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
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Union

import pyarrow as pa
import pyarrow.csv as pa_csv

from . import _acq

__all__ = [
    "decode",
    "decode_batches",
    "align",
    "holds",
    "tensile_curve",
    "twin_excavator",
    "twin_gtn",
    "calibrate",
    "mesh_study",
    "Run",
    "__version__",
]
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
    ``value``, ``unit`` and, with ``labels=True``, ``label``. A row per
    value: each value's unit is its row's ``unit`` (``align``'s wide table
    has each channel's unit in its field metadata). ``skip_bad=True`` reads past malformed
    lines (counted) instead of stopping at the first.
    """
    table: pa.Table = _acq.decode(
        os.fspath(log_path), _optional_path(rig), _paths(dbc), labels, skip_bad, False
    )
    return table


def decode_batches(
    log_path: PathLike,
    rig: Optional[PathLike] = None,
    dbc: Union[PathLike, Sequence[PathLike], None] = None,
    *,
    labels: bool = False,
    skip_bad: bool = False,
) -> pa.RecordBatchReader:
    """:func:`decode`'s table as a ``pyarrow.RecordBatchReader``.

    Batches of 16,384 rows are decoded on a thread of acq's while Python
    reads the ones before, and at most two wait: a log of any length
    streams in a few MB. Iterate over it, or hand it to
    ``pyarrow.dataset.write_dataset`` or ``polars.from_arrow``. A
    malformed line met on the way raises ``pyarrow.ArrowInvalid`` (a
    ``ValueError``) naming the file and line; a bad argument, rig or DBC
    raises here, before any batch.
    """
    reader: pa.RecordBatchReader = _acq.decode(
        os.fspath(log_path), _optional_path(rig), _paths(dbc), labels, skip_bad, True
    )
    return reader


def _optional_path(path: Optional[PathLike]) -> Optional[str]:
    return None if path is None else os.fspath(path)


def _paths(paths: Union[PathLike, Sequence[PathLike], None]) -> List[str]:
    if paths is None:
        return []
    if isinstance(paths, (str, os.PathLike)):
        return [os.fspath(paths)]
    return [os.fspath(p) for p in paths]


def _time_point(point: Union[float, str, None]) -> Optional[str]:
    return None if point is None else str(point)


def align(
    session: PathLike,
    rig: Optional[PathLike] = None,
    *,
    rate_hz: float = 100.0,
    method: Optional[str] = None,
    max_gap: str = "3x",
    start: Union[float, str, None] = None,
    end: Union[float, str, None] = None,
    filter_hz: Optional[float] = None,
    clock_offsets_ms: Optional[Mapping[str, float]] = None,
) -> pa.Table:
    """A session (or a log with ``rig``) on one time base, as ``acq align
    -o FILE.parquet`` writes it.

    Columns: ``time_s`` (UTC timestamp), then per sensor ``NAME [UNIT]``
    (null in a gap) and ``NAME_gap``. ``method`` is ``"linear"``,
    ``"hold"`` or ``"nearest"`` for every sensor (``None``: each sensor's
    own); ``max_gap`` is a silence that counts as a gap (``"3x"`` sample
    periods, or ``"50ms"``); ``start`` and ``end`` are seconds from the
    session's start or UTC times; ``filter_hz`` a zero-phase Gaussian
    low-pass. The header's notes (clocks, options) are in the schema's
    metadata under ``b"acq.comments"``.
    """
    return _acq.align(
        os.fspath(session),
        _optional_path(rig),
        float(rate_hz),
        method,
        max_gap,
        _time_point(start),
        _time_point(end),
        filter_hz,
        list((clock_offsets_ms or {}).items()),
    )


def holds(
    session: PathLike,
    rig: Optional[PathLike] = None,
    *,
    windows: Optional[PathLike] = None,
    load: Optional[str] = None,
    steady_std: Optional[float] = None,
    steady_window_s: Optional[float] = None,
    min_hold_s: Optional[float] = None,
    settle_s: Optional[float] = None,
    min_load: Optional[float] = None,
    clock_offsets_ms: Optional[Mapping[str, float]] = None,
) -> pa.Table:
    """The measured values of a session's steady holds, as ``acq extract
    -o FILE.parquet`` writes them.

    One row per window and quantity: ``mean``, ``std``, ``n``, ``n_eff``,
    the 95 % interval of the mean (``ci95_low``, ``ci95_high``), the
    combined standard uncertainty ``u_c`` of the whole measurement chain,
    its coverage factor ``k`` and ``U95``, the errors it shares with other
    values (``shared``), and ``flags`` with a ``note``. ``windows`` is a
    CSV of ``name,start_s,end_s`` instead of the holds found in the load
    (``load``, default the rig's only force sensor); the other options are
    ``acq extract``'s (``None``: its default).
    """
    return _acq.holds(
        os.fspath(session),
        _optional_path(rig),
        _optional_path(windows),
        load,
        steady_std,
        steady_window_s,
        min_hold_s,
        settle_s,
        min_load,
        list((clock_offsets_ms or {}).items()),
    )


def tensile_curve(
    session: PathLike,
    rig: Optional[PathLike] = None,
    *,
    force: Optional[str] = None,
    displacement: Optional[str] = None,
    diameter_mm: Optional[float] = None,
    gauge_length_mm: Optional[float] = None,
    clock_offsets_ms: Optional[Mapping[str, float]] = None,
) -> pa.Table:
    """A tensile test's force-displacement curve, as ``acq extract
    --tensile -o FILE.parquet`` writes it: displacement (mm), force (kN),
    engineering strain and stress, and true strain and stress up to the
    maximum force. The specimen is the rig's unless given.
    """
    return _acq.tensile_curve(
        os.fspath(session),
        _optional_path(rig),
        force,
        displacement,
        diameter_mm,
        gauge_length_mm,
        list((clock_offsets_ms or {}).items()),
    )


def twin_excavator(
    case: PathLike,
    geometry: Optional[PathLike] = None,
    *,
    bucket_stroke_mm: Optional[float] = None,
    arm_stroke_mm: Optional[float] = None,
    boom_stroke_mm: Optional[float] = None,
    force_kn: Optional[float] = None,
    angle_deg: Optional[float] = None,
    envelope: bool = False,
) -> Dict[str, Any]:
    """The excavator twin at a case's nominal inputs, any of them set: the
    dict ``acq twin excavator --json`` prints (cylinder pressures and
    forces, gauge stresses, the pose's points, the largest von Mises
    stresses; with ``envelope=True`` the working envelope).
    """
    text = _acq.twin_excavator(
        os.fspath(case),
        _optional_path(geometry),
        bucket_stroke_mm,
        arm_stroke_mm,
        boom_stroke_mm,
        force_kn,
        angle_deg,
        envelope,
    )
    result: Dict[str, Any] = json.loads(text)
    return result


def twin_gtn(
    test: PathLike,
    params: Mapping[str, float],
    *,
    mesh: str = "6x30",
    element_mm: Optional[float] = None,
    neck_zone_mm: Optional[float] = None,
    step_mm: float = 0.01,
    diameter_mm: float = 4.0,
    strain_length_mm: float = 12.5,
    imperfection: float = 0.001,
) -> Dict[str, Any]:
    """One GTN simulation of a tensile test (``acq twin gtn --test TEST
    --param ...``) with ``params`` (``q1``, ``q2``, ``q3``, ``epsN``,
    ``sN``, ``fN``, ``f0``, ``m`` in MPa; ``fc`` and ``fF`` optional).

    Returns ``mape_pct`` against the test, ``failed_early``,
    ``converged``, ``wall_s``, ``mesh``, and the curves as NumPy arrays:
    ``curve`` (``displacement_mm``, ``force_kn``, ``neck_diameter_mm``,
    ``failed_points``) and ``test`` (``displacement_mm``, ``force_kn``).
    ``element_mm`` meshes the neck at that element size instead of
    ``mesh`` (radial x axial elements).
    """
    import numpy as np

    param = ",".join(f"{name}={float(value)!r}" for name, value in params.items())
    text, simulated, measured = _acq.twin_gtn(
        os.fspath(test),
        param,
        mesh,
        element_mm,
        neck_zone_mm,
        float(step_mm),
        float(diameter_mm),
        float(strain_length_mm),
        float(imperfection),
    )
    result: Dict[str, Any] = json.loads(text)
    names = ["displacement_mm", "force_kn", "neck_diameter_mm", "failed_points"]
    result["curve"] = {n: np.asarray(c) for n, c in zip(names, simulated)}
    result["curve"]["failed_points"] = result["curve"]["failed_points"].astype(int)
    result["test"] = {n: np.asarray(c) for n, c in zip(names, measured)}
    return result


ModelFunction = Callable[[Dict[str, float]], Mapping[str, Any]]


def calibrate(
    spec_path: PathLike,
    out: PathLike,
    model: Optional[ModelFunction] = None,
    *,
    seed: int = 1,
    resume: bool = False,
    progress: Union[bool, Callable[[Dict[str, Any]], None], None] = None,
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
    run, its traceback in the log's ``reason``; the study goes on. Runs
    at once (``parallel`` in the spec) are calls from as many threads: they
    overlap where the function releases the GIL (NumPy, a subprocess, a
    solver in C), and take turns where it computes in Python.

    ``progress``: ``True`` draws a bar with tqdm (``tqdm.auto``: a widget
    in a notebook, a line in a terminal); a function is called after
    every run with a dict of ``done``, ``total`` (the budget), ``failed``,
    ``reused`` (from the log of a resumed study), ``best_loss`` and
    ``elapsed_s``. The progress lines go to ``sys.stderr`` either way.
    """
    observer: Optional[Callable[[Dict[str, Any]], None]] = None
    bar: Any = None
    if progress is True:
        from tqdm.auto import tqdm

        bar = tqdm(desc="acq study", unit="run")

        def observer(numbers: Dict[str, Any]) -> None:
            bar.total = numbers["total"]
            bar.n = numbers["done"]
            best = numbers["best_loss"]
            bar.set_postfix(best_loss="-" if best is None else f"{best:.4g}", failed=numbers["failed"])

    elif callable(progress):
        observer = progress
    try:
        _acq.calibrate(os.fspath(spec_path), os.fspath(out), seed, resume, model, observer)
    finally:
        if bar is not None:
            bar.close()
    return Run(out)


def mesh_study(
    spec_path: PathLike,
    out: PathLike,
    model: Optional[ModelFunction] = None,
    *,
    resume: bool = False,
) -> "Run":
    """Run the mesh study of a spec (its ``[mesh_study] sizes``) into
    ``out``, as ``acq mesh-study --spec SPEC --out OUT``, and return the
    :class:`Run`: ``run.summary["mesh_study"]`` holds, per scalar output,
    the observed order, the extrapolated value, the fine grid's GCI, the
    ``u_num`` V&V 20 takes and the convergence named. With ``model=`` a
    Python function is the model; it gets the element size as
    ``inputs["mesh"]``.
    """
    _acq.mesh_study(os.fspath(spec_path), os.fspath(out), resume, model)
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
        log posterior (``lp``). Where the study ran the model at posterior
        draws (``[posterior] predictive_runs``), ``posterior_predictive``
        holds each case's outputs with measurement error added, one draw
        per run (``predictive.csv``'s ``with_error``; chain 1), and
        ``observed_data`` the measured values, each named ``CASE.OUTPUT``
        with one ``observation``: ``az.plot_ppc`` draws them together.
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
        predictive, observed = self._predictive()
        return az.from_dict(
            posterior=posterior,
            sample_stats=sample_stats,
            posterior_predictive=predictive or None,
            observed_data=observed or None,
            dims={name: ["observation"] for name in observed},
        )

    def _predictive(self) -> "tuple[Dict[str, Any], Dict[str, Any]]":
        """``predictive.csv``'s draws with error, per ``CASE.OUTPUT``, as
        (chain 1, draw, observation 1), and the measured values."""
        import numpy as np

        path = self.path / "predictive.csv"
        if not path.is_file():
            return {}, {}
        rows = pa_csv.read_csv(path).to_pylist()
        measured = self.summary.get("predictive", {})
        draws: Dict[str, List[float]] = {}
        for row in sorted(rows, key=lambda r: int(r["run"])):
            # A curve's row is its MAPE at a run, with no draw with error
            # (empty): no predictive draw of an observed value.
            if row["with_error"] is None:
                continue
            draws.setdefault(f"{row['case']}.{row['output']}", []).append(float(row["with_error"]))
        predictive = {name: np.asarray(v).reshape(1, len(v), 1) for name, v in draws.items()}
        observed = {}
        for name in predictive:
            case, output = name.split(".", 1)
            value = measured.get(case, {}).get(output, {}).get("measured")
            if value is not None:
                observed[name] = np.asarray([float(value)])
        return predictive, observed
