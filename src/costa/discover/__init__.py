"""Discovery of missing physics: where a model and measured data disagree, what is missing, and a fix."""

from .cases.shipped import CASES, HiddenEffectCase, add_noise
from .core.settings import DiscoverySettings
from .full_state.search import Round, discover

__all__ = ["CASES", "DiscoverySettings", "HiddenEffectCase", "Round", "add_noise", "discover"]
