"""Loops compiled to machine code (numba), for work numpy can only do in many passes."""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any


def compiled(loop: Callable[..., Any]) -> Callable[..., Any]:
    """Decorator: ``loop`` compiled by numba on its first call (``nogil``: callers may run
    it on several threads at once), the machine code cached on disk where numba finds a
    writable place for it, else compiled in every process (~1 s).

    Args:
        loop: a function of numpy arrays and scalars that numba's nopython mode compiles.
    """

    @functools.cache
    def build() -> Callable[..., Any]:
        import numba

        try:
            return numba.njit(nogil=True, cache=True)(loop)
        except RuntimeError:  # "cannot cache function ...: no locator available"
            return numba.njit(nogil=True)(loop)

    @functools.wraps(loop)
    def call(*args: Any) -> Any:
        return build()(*args)

    return call
