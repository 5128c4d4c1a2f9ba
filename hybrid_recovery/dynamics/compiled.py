"""Loops compiled to machine code (numba), for work numpy can only do in many passes."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any


def compiled(loop: Callable[..., Any], *probe: Any) -> Callable[..., Any]:
    """``loop`` compiled by numba (``nogil``: callers may run it on several threads at
    once), on first use, with the machine code cached on disk where numba finds a
    writable place for it, else compiled in every process (~1 s).

    Args:
        loop: a function of numpy arrays and scalars that numba's nopython mode compiles.
        probe: arguments to compile it with now (the types of later calls), so that a
            failing disk cache is met here.
    """
    import numba

    try:
        fn = numba.njit(nogil=True, cache=True)(loop)
        if probe:
            fn(*probe)
    except RuntimeError:  # "cannot cache function ...: no locator available"
        fn = numba.njit(nogil=True)(loop)
    return fn
