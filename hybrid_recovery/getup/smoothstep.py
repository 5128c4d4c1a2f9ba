"""The smoothstep s(τ) = 3τ² − 2τ³ the ground moves take their references along.

s goes from 0 to 1 over τ ∈ [0, 1] with zero slope at both ends and stays constant
outside; over a duration T, τ = (t − t₀)/T, ṡ = s'(τ)/T and s̈ = s''(τ)/T².
"""

from __future__ import annotations


def smoothstep(tau: float) -> tuple[float, float, float]:
    """s, ds/dτ, d²s/dτ² of s = 3τ² − 2τ³ on τ ∈ [0, 1], constant outside [-]."""
    if tau <= 0.0 or tau >= 1.0:
        return (0.0 if tau <= 0.0 else 1.0), 0.0, 0.0
    return tau * tau * (3.0 - 2.0 * tau), 6.0 * tau * (1.0 - tau), 6.0 - 12.0 * tau


def smoothstep_profile(elapsed: float, duration: float) -> tuple[float, float, float]:
    """s, ṡ [1/s] and s̈ [1/s²] of a smoothstep over ``duration`` T [s], ``elapsed``
    t − t₀ [s] after its start."""
    s, ds, dds = smoothstep(elapsed / duration)
    return s, ds / duration, dds / duration**2
