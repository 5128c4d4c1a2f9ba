"""``hybrid-recovery report``."""

from __future__ import annotations

import argparse
from pathlib import Path

from hybrid_recovery.cli.errors import UsageError
from hybrid_recovery.cli.registry import command


def _report(args: argparse.Namespace) -> int:
    from hybrid_recovery.evaluation.ablation import ablation_table
    from hybrid_recovery.evaluation.report import write_report
    from hybrid_recovery.evaluation.runner import HEADER_KEY, header_provenance, load_results
    from hybrid_recovery.training.record import plot_curves

    if not args.results and not args.runs:
        raise UsageError("report: nothing to report; give results.jsonl files of eval or "
                         "compare, or training runs with --runs")
    results, provenance = {}, {}
    for path in args.results:
        rows = load_results(path)
        header = next((r for r in rows if r.get("key") == HEADER_KEY), None)
        if header is None:  # an empty report would look like a run without trials
            raise ValueError(f"{path} is not a results file of this harness (no header "
                             "line); give the results.jsonl that eval or compare wrote")
        label = f"{header.get('controller', Path(path).parent.name)} ({Path(path).parent.name})"
        results[label] = [r for r in rows if r.get("key") != HEADER_KEY]
        if (policy := header_provenance(header)) is not None:
            provenance[label] = policy
    runs = dict(item.split("=", 1) if "=" in item else (Path(item).name, item)
                for item in args.runs)
    table = ablation_table(runs, same_budget=not args.whole_runs) if runs else None
    print(write_report(results, args.out, args.title, ablation=table,
                       provenance=provenance))
    if runs:
        print(plot_curves(runs, Path(args.out) / "training_curves.png"))
    return 0


def _configure(p: argparse.ArgumentParser) -> None:
    p.add_argument("results", nargs="*", help="results.jsonl files from eval/compare")
    p.add_argument("--runs", nargs="*", default=[], metavar="[LABEL=]RUN_DIR",
                   help="training runs for the ablation table and training_curves.png")
    p.add_argument("--whole-runs", action="store_true",
                   help="ablation table over each run's whole log (default: every run cut "
                        "at the env steps of the shortest, the same budget)")
    p.add_argument("--out", default="results/report")
    p.add_argument("--title", default="hybrid_recovery evaluation")


_report.configure = _configure  # type: ignore[attr-defined]
command("report", "Write a Markdown report with figures from results and training runs.")(
    _report)
