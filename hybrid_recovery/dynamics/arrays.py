"""The arrays the batched terms take: numpy arrays on the CPU path, torch tensors on any
device. Terms written against the array API standard (``array_api_compat``) run on
either, so each is written once."""

from __future__ import annotations

from typing import TYPE_CHECKING, TypeVar

if TYPE_CHECKING:
    import numpy as np
    import torch

Array = TypeVar("Array", "np.ndarray", "torch.Tensor")
"""A numpy array or a torch tensor, leading dimension N (envs); a term given numpy
arrays returns numpy arrays, given tensors returns tensors (on their device)."""
