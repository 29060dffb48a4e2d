"""Named, independent random streams derived from the config's one seed.

Every random draw in the project comes from ``stream(seed, replicate, name, *index)``:
a :class:`numpy.random.SeedSequence` keyed by the replicate, a stable hash of a
stream name (e.g. ``"data/test"``) and optional indices (a trajectory, an
instance).  Streams are independent of each other and of how many draws other
streams make, so trajectory 7 of the test set is the same whether 10 or 100 are
simulated.
"""

from __future__ import annotations

import zlib
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import torch


def stream(seed: int, replicate: int, name: str, *index: int) -> np.random.SeedSequence:
    """The seed sequence of one named stream."""
    key = (int(replicate), zlib.crc32(name.encode()), *map(int, index))
    return np.random.SeedSequence(entropy=int(seed), spawn_key=key)


def numpy_generator(seed: int, replicate: int, name: str, *index: int) -> np.random.Generator:
    """A numpy Generator on the named stream."""
    return np.random.Generator(np.random.PCG64(stream(seed, replicate, name, *index)))


def torch_generator(seed: int, replicate: int, name: str, *index: int) -> torch.Generator:
    """A CPU torch Generator on the named stream."""
    import torch  # here, not at the top: jobs that draw no network weights start without torch (2-3 s)

    state = stream(seed, replicate, name, *index).generate_state(2, dtype=np.uint32)
    return torch.Generator().manual_seed(int(state[0]) << 32 | int(state[1]))
