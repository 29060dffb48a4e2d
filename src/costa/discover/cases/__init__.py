"""The cases and their scoring: measured-like data in which a physical effect is hidden.

The shipped cases (:mod:`.shipped`) and the unshipped effects (:mod:`.unshipped`) say what
is hidden and which model discovery starts from; :mod:`.tables` simulates a case's
training and held-out tables through a sensor set; :mod:`.truth` says, machine-readably,
what a correct answer is, for scoring (never for choosing).  It reads the config and the
physics and writes tables; it imports neither discovery route.
"""
