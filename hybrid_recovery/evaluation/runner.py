"""Running a protocol: parallel over processes, resumable, results as JSON lines."""

from __future__ import annotations

import json
import multiprocessing as mp
import signal
import sys
import time
from collections.abc import Iterator
from pathlib import Path

from hybrid_recovery.evaluation.contact import check_contact_preset
from hybrid_recovery.evaluation.controllers import make_controller
from hybrid_recovery.evaluation.scenario import Scenario
from hybrid_recovery.evaluation.trial import run_trial
from hybrid_recovery.policy.description import load_policy_description
from hybrid_recovery.policy.onnx_policy import DESCRIPTION

_WORKER: dict = {}
HEADER_KEY = "__header__"
"""``key`` of a results file's first line, the run's description (not a trial)."""


class EvaluationInterrupted(KeyboardInterrupt):
    """Ctrl-C during a protocol; the finished trials are in the results file."""


def _init_worker(controller: str, model_path: str | None, contact: str,
                 ignore_sigint: bool = False, rotor_inertia: bool = False,
                 stop_on_success: bool = False) -> None:
    if ignore_sigint:  # the parent alone handles Ctrl-C (one line, not one per worker)
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    _WORKER.update(controller=make_controller(controller), model=model_path, contact=contact,
                   rotor_inertia=rotor_inertia, stop=stop_on_success)


def _work(scenario: Scenario) -> dict:
    return run_trial(_WORKER["controller"], scenario, _WORKER["model"], _WORKER["contact"],
                     rotor_inertia=_WORKER["rotor_inertia"], stop_on_success=_WORKER["stop"])


def completed_keys(results: Path) -> set[str]:
    """Keys of the trials already in ``results``: not the header; a torn last line is
    ignored."""
    if not results.is_file():
        return set()
    keys = set()
    for line in results.read_text().splitlines():
        try:
            keys.add(json.loads(line)["key"])
        except (json.JSONDecodeError, KeyError, TypeError):
            continue
    keys.discard(HEADER_KEY)
    return keys


def check_same_run(results: Path, meta: dict) -> None:
    """Refuses to resume ``results`` for a run other than the one its header describes.

    Args:
        results: an existing results file.
        meta: the header the run would write to a new file.

    Raises:
        ValueError: naming the first field that differs (or the missing header).
    """
    with results.open() as f:
        first = f.readline()
    try:
        old = json.loads(first)
    except json.JSONDecodeError:
        old = {}
    if not isinstance(old, dict) or old.get("key") != "__header__":
        raise ValueError(f"{results} is not a results file of this harness (no header); "
                         "choose another --out or remove it")
    for field in sorted(set(old) | set(meta)):
        if old.get(field) != meta.get(field):
            raise ValueError(
                f"{results} holds another run ({field}: {old.get(field)!r} there, "
                f"{meta.get(field)!r} now); choose another --out or remove it to start anew")


def load_results(results: str | Path) -> list[dict]:
    """All complete result rows of a JSON-lines results file.

    Raises:
        FileNotFoundError: ``results file not found: <path>``.
    """
    if not Path(results).is_file():
        raise FileNotFoundError(f"results file not found: {results}")
    rows = []
    for line in Path(results).read_text().splitlines():
        try:
            rows.append(json.loads(line))
        except json.JSONDecodeError:
            continue
    return rows


def policy_provenance(controller) -> dict | None:
    """The training provenance (variant, commit, iteration, env steps) of a controller
    that runs an exported policy; None for any other controller."""
    description = getattr(getattr(controller, "policy", None), "description", None)
    return description.get("provenance") if isinstance(description, dict) else None


def header_provenance(header: dict) -> dict | None:
    """The policy provenance of a results file's header: recorded there by
    :func:`run_protocol`, else read from the ``policy.json`` of an ``onnx:PATH``
    controller that still exists (results written before it was recorded)."""
    if "policy" in header:
        return header["policy"]
    kind, _, arg = str(header.get("controller", "")).partition(":")
    if kind != "onnx" or not arg:
        return None
    path = Path(arg)
    description = (path if path.is_dir() else path.parent) / DESCRIPTION
    if not description.is_file():
        return None
    return load_policy_description(description).get("provenance")


def run_protocol(scenarios: list[Scenario], controller: str, results: str | Path,
                 model_path: str | None = None, contact: str = "default", workers: int = 2,
                 header: dict | None = None, progress: bool = True,
                 rotor_inertia: bool = False, stop_on_success: bool = False) -> list[dict]:
    """Runs every scenario not yet in ``results`` and appends one JSON line per trial.

    With ``stop_on_success`` each trial ends once it has succeeded (see
    :func:`run_trial`).

    A killed run resumes where it stopped: finished trials are skipped by key. The first
    line of a new file is a header with the controller (and its policy's provenance), the
    model, the contact setting, the rotor inertia and ``header`` (the protocol's
    configuration and seed); an existing file is resumed only if its header is the same,
    since trial keys name the scenario, not who ran it.

    Ctrl-C stops the run: every finished trial is already in the file (written and
    flushed as it arrives), the workers are ended, and
    :class:`EvaluationInterrupted` says how many trials the file holds.

    Returns:
        All result rows of the file (old and new).

    Raises:
        ValueError: ``results`` exists but holds another run (or no header), or a bad
            controller, contact preset or model; nothing is written then.
        EvaluationInterrupted: on Ctrl-C.
    """
    results = Path(results)
    check_contact_preset(contact)
    built = make_controller(controller)  # fail fast on a bad spec, before any file
    results.parent.mkdir(parents=True, exist_ok=True)
    meta = {"key": HEADER_KEY, "controller": controller, "model": model_path,
            "contact": contact, **(header or {})}
    if rotor_inertia:  # absent otherwise: older results files stay resumable
        meta["rotor_inertia"] = True
    if (policy := policy_provenance(built)) is not None:
        meta["policy"] = policy
    if results.is_file():
        check_same_run(results, meta)
    else:
        results.write_text(json.dumps(meta) + "\n")
    done = completed_keys(results)
    todo = [s for s in scenarios if s.key not in done]
    start, count, shown = time.time(), 0, 0.0
    with results.open("a") as out:
        if results.read_bytes()[-1:] not in (b"", b"\n"):
            out.write("\n")  # end a line torn by a killed run
        if workers <= 1:
            _init_worker(controller, model_path, contact, rotor_inertia=rotor_inertia,
                         stop_on_success=stop_on_success)
            rows: Iterator[dict] = map(_work, todo)
            pool = None
        else:
            pool = mp.get_context("fork").Pool(workers, _init_worker,
                                               (controller, model_path, contact, True,
                                                rotor_inertia, stop_on_success))
            rows = pool.imap_unordered(_work, todo)
        try:
            for row in rows:
                out.write(json.dumps(row, default=str) + "\n")
                out.flush()
                count += 1
                if progress and (time.time() - shown > 1.0 or count == len(todo)):
                    _progress(count, len(todo), start, len(done))
                    shown = time.time()
        except KeyboardInterrupt:
            if progress and count:
                print(file=sys.stderr)
            out.flush()  # the interrupt may fall between a row's write and its count
            raise EvaluationInterrupted(
                f"interrupted: {len(completed_keys(results))} of {len(done) + len(todo)} "
                f"trials are in {results}; the same command resumes") from None
        finally:
            if pool is not None:
                pool.terminate()
    if progress and todo:
        print(file=sys.stderr)
    return [r for r in load_results(results) if r.get("key") != HEADER_KEY]


def _progress(count: int, total: int, start: float, skipped: int) -> None:
    rate = count / max(time.time() - start, 1e-9)
    eta = (total - count) / max(rate, 1e-9)
    bar = "#" * int(30 * count / max(total, 1))
    print(f"\r[{bar:<30}] {count}/{total} trials ({skipped} resumed) {rate:.1f}/s "
          f"ETA {eta:5.0f}s", end="", file=sys.stderr, flush=True)
