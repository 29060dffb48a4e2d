"""The sparse route: discovery on partial measurements (some channels, sampled now and then, noisy).

It reads measured channels (a ``partial``, ``plant`` or ``pot_line`` sensor set, or your own
sparse table), estimates the unmeasured states with an augmented Kalman filter and smoother
through the cell's sensors, and decides each round by one of two routes over a shared layer:

- :mod:`.filter`: each hypothesis a random-walk delta(t) in the filter, scored by the likelihood
  it gains, its closed form regressed on the smoothed delta, round after round;
- :mod:`.shooting`: closed forms fitted by multiple shooting (a pot line's hourly and 8-hourly
  samples: :mod:`costa.discover.route`), one round.

The shared layer: the records as arrays (:mod:`.observations`), the filter and smoother
(:mod:`.estimator`, :mod:`.observed`), the round's result (:mod:`.rounds`), "measure next"
(:mod:`.measure_next`) and the gap (:mod:`.gap`).  :mod:`.pipeline` runs the chosen route and
:mod:`.split` writes a round's jobs' records.  It imports the shared core
(:mod:`costa.discover.core`), never the full-state route.
"""
