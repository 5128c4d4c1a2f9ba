"""Evaluation: the paper's protocols, success criterion, strategy labels and reports."""

from hybrid_recovery.evaluation.runner import load_results, run_protocol
from hybrid_recovery.evaluation.scenario import PROTOCOLS, Scenario
from hybrid_recovery.evaluation.trial import run_trial

__all__ = ["PROTOCOLS", "Scenario", "load_results", "run_protocol", "run_trial"]
