"""Discovery of missing physics: where a model and measured data disagree, what is missing, and a fix.

Three routes (full state; on sparse records the filter or multiple shooting) over a shared core:

- :mod:`.core`: hypotheses and their term library, the sparse regression and its
  bootstrap, the kept terms' intervals, the naming order, noise estimation, the settings;
- :mod:`.full_state`: every state measured at every step (weak-form equation tests,
  rounds, the gap on held-out states);
- :mod:`.sparse`: some channels, sparse and noisy (an augmented Kalman filter and smoother,
  hypotheses scored by likelihood or fitted by multiple shooting, the gap on the measured channels);
- :mod:`.cases`: the shipped and unshipped cases, their simulated tables and their truths.

The top-level modules are the glue: :mod:`.route` picks the route from what a record samples,
:mod:`.pipeline` reads the config and runs it, :mod:`.findings` and :mod:`.summary` write what
was found, :mod:`.reference` trains CoSTA on the same data as a reference.
"""

from .cases.shipped import CASES, HiddenEffectCase, add_noise
from .core.outcome import Decision, Outcome, Round
from .core.settings import DiscoverySettings
from .full_state.search import discover

__all__ = ["CASES", "Decision", "DiscoverySettings", "HiddenEffectCase", "Outcome", "Round", "add_noise", "discover"]
