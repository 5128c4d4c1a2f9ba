"""Recipes that span training and evaluation: a staged run that records its own rises
(:mod:`~hybrid_recovery.recipe.staged_run`)."""

from hybrid_recovery.recipe.staged_run import train_staged

__all__ = ["train_staged"]
