"""The arrays the batched terms take: numpy arrays on the CPU path, torch tensors on any
device. Terms written against the array API standard (``array_api_compat``) run on
either, so each is written once."""

from __future__ import annotations

from typing import TYPE_CHECKING, TypeVar

import numpy as np
from array_api_compat import is_array_api_obj

if TYPE_CHECKING:
    import torch

Array = TypeVar("Array", "np.ndarray", "torch.Tensor")
"""A numpy array or a torch tensor, leading dimension N (envs); a term given numpy
arrays returns numpy arrays, given tensors returns tensors (on their device)."""


def as_arrays(*values: object) -> tuple:
    """Each value as it is when an array (numpy or torch), else as a float64 numpy array
    (lists, tuples and numbers, as the public functions always took)."""
    return tuple(v if is_array_api_obj(v) else np.asarray(v, dtype=float) for v in values)
