# The extension module acq._acq (python/src/lib.rs). Use the package's
# functions (acq.decode, acq.calibrate); these are what they call.
from typing import List, Optional

import pyarrow as pa

def decode(
    log: str,
    rig: Optional[str] = None,
    dbc: List[str] = ...,
    labels: bool = False,
    skip_bad: bool = False,
) -> pa.Table: ...
def calibrate(spec: str, out: str, seed: int = 1, resume: bool = False) -> None: ...
def version() -> str: ...
