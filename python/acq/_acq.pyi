# The extension module acq._acq (python/src/lib.rs). Use the package's
# functions (acq.decode, acq.calibrate); these are what they call.
from typing import Any, Callable, Dict, List, Mapping, Optional, Tuple

import pyarrow as pa

def decode(
    log: str,
    rig: Optional[str] = None,
    dbc: List[str] = ...,
    labels: bool = False,
    skip_bad: bool = False,
    stream: bool = False,
) -> Any: ...
def align(
    input: str,
    rig: Optional[str],
    rate_hz: float,
    method: Optional[str],
    max_gap: str,
    start: Optional[str],
    end: Optional[str],
    filter_hz: Optional[float],
    clock_offsets_ms: List[Tuple[str, float]],
) -> pa.Table: ...
def holds(
    input: str,
    rig: Optional[str],
    windows: Optional[str],
    load: Optional[str],
    steady_std: Optional[float],
    steady_window_s: Optional[float],
    min_hold_s: Optional[float],
    settle_s: Optional[float],
    min_load: Optional[float],
    clock_offsets_ms: List[Tuple[str, float]],
) -> pa.Table: ...
def tensile_curve(
    input: str,
    rig: Optional[str],
    force: Optional[str],
    displacement: Optional[str],
    diameter_mm: Optional[float],
    gauge_length_mm: Optional[float],
    clock_offsets_ms: List[Tuple[str, float]],
) -> pa.Table: ...
def twin_excavator(
    case: str,
    geometry: Optional[str],
    bucket_stroke_mm: Optional[float],
    arm_stroke_mm: Optional[float],
    boom_stroke_mm: Optional[float],
    force_kn: Optional[float],
    angle_deg: Optional[float],
    envelope: bool,
) -> str: ...
def twin_gtn(
    test: str,
    param: str,
    mesh: str,
    element_mm: Optional[float],
    neck_zone_mm: Optional[float],
    step_mm: float,
    diameter_mm: float,
    strain_length_mm: float,
    imperfection: float,
) -> Tuple[str, List[List[float]], List[List[float]]]: ...
def calibrate(
    spec: str,
    out: str,
    seed: int = 1,
    resume: bool = False,
    model: Optional[Callable[[Dict[str, float]], Mapping[str, Any]]] = None,
    progress: Optional[Callable[[Dict[str, Any]], None]] = None,
) -> None: ...
def mesh_study(
    spec: str,
    out: str,
    resume: bool = False,
    model: Optional[Callable[[Dict[str, float]], Mapping[str, Any]]] = None,
) -> None: ...
def version() -> str: ...
