# The extension module acq._acq (python/src/lib.rs). Use the package's
# functions (acq.decode, acq.calibrate); these are what they call.
from typing import Any, Callable, Dict, List, Mapping, Optional

import pyarrow as pa

def decode(
    log: str,
    rig: Optional[str] = None,
    dbc: List[str] = ...,
    labels: bool = False,
    skip_bad: bool = False,
) -> pa.Table: ...
def calibrate(
    spec: str,
    out: str,
    seed: int = 1,
    resume: bool = False,
    model: Optional[Callable[[Dict[str, float]], Mapping[str, Any]]] = None,
) -> None: ...
def version() -> str: ...
