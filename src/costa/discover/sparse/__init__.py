"""The sparse route: discovery on partial measurements (some channels, sampled now and then, noisy).

It reads measured channels (a ``partial`` or ``plant`` sensor set, or your own sparse
table), estimates the unmeasured states with an augmented Kalman filter and smoother
through the cell's sensors, scores each hypothesis by the likelihood it gains, fits and
corrects in rounds, and writes a :class:`.pipeline.PartialResult` (rounds, gap on the
measured channels, noise floor) for the findings.  It imports the shared core
(:mod:`costa.discover.core`), never the full-state route.
"""
