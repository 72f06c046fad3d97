"""Flat observation vectors from dm_env observation dicts, and back.

A task's observation is an ordered dict of arrays (its observation_spec's order).
Learners want one flat float64 vector; ``layout`` records where each entry lies
in it, so that ``flatten`` and ``unflatten`` are exact inverses (no cast beyond
float64, no reordering).
"""

from __future__ import annotations

import collections

import numpy as np


def layout(observation_spec) -> collections.OrderedDict:
    """key -> (slice in the flat vector, the entry's shape), in the spec's order."""
    places = collections.OrderedDict()
    start = 0
    for key, spec in observation_spec.items():
        size = int(np.prod(spec.shape))
        places[key] = (slice(start, start + size), tuple(spec.shape))
        start += size
    return places


def size(places) -> int:
    """The flat vector's length."""
    return max((part.stop for part, _ in places.values()), default=0)


def flatten(observation, places) -> np.ndarray:
    """The entries of a dm_env observation concatenated in layout order, as float64."""
    return np.concatenate([np.asarray(observation[key], dtype=np.float64).ravel() for key in places])


def unflatten(flat: np.ndarray, places) -> dict:
    """Per-key views of a flat observation, or of a stack of them (the last axis is the flat one)."""
    lead = flat.shape[:-1]
    return {key: flat[..., part].reshape(lead + shape) for key, (part, shape) in places.items()}
