"""The filter route: each hypothesis a random-walk delta(t) in the augmented Kalman filter and smoother.

Scored by the likelihood its delta gains (:mod:`.likelihood`), its smoothed delta regressed on the
physical terms, and the corrected models ranked by BIC, round by round (:mod:`.search`).  The
route wherever the shooting route is not set (the ``partial`` and ``pot_line`` sensor sets; your
own sparse records without ``shooting_cells``).
"""
