"""The filter route: each hypothesis a random-walk delta(t) in the augmented Kalman filter and smoother.

Scored by the likelihood its delta gains (:mod:`.likelihood`), its smoothed delta regressed on the
physical terms, and the corrected models ranked by BIC, round by round (:mod:`.search`).  The
route of sparse records with the composition at every step or hand samples rarer than a shift (the
``partial`` and ``pot_line`` sensor sets: :mod:`costa.discover.route`).
"""
