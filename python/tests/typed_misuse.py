"""Calls the stubs forbid: mypy must refuse each (the test reads its lines)."""

import acq

acq.decode(42)  # misuse: a log is a path
acq.Run("run").to_arviz(chains=2)  # misuse: no such argument
acq.calibrate("spec.toml", "out", seed="one")  # misuse: a seed is an int
