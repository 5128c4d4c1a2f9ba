"""Running a protocol: parallel over processes, resumable, results as JSON lines."""

from __future__ import annotations

import contextlib
import json
import multiprocessing as mp
import signal
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import IO

from hybrid_recovery.controllers import make, policy_path
from hybrid_recovery.evaluation.contact import check_contact_preset
from hybrid_recovery.evaluation.scenario import Scenario
from hybrid_recovery.evaluation.trial import run_trial
from hybrid_recovery.files import exclusive_lock, sha256_file
from hybrid_recovery.policy.description import load_policy_description
from hybrid_recovery.policy.onnx_policy import DESCRIPTION
from hybrid_recovery.robot.actuator import check_actuator

_WORKER: dict = {}
HEADER_KEY = "__header__"
"""``key`` of a results file's first line, the run's description (not a trial)."""
HASHES = "sha256"
"""Header field: role → SHA-256 of each file the results depend on (:func:`content_hashes`)."""
_HASHED = {"model": "the model file", "policy": "the policy file",
           "policy_data": "the policy's weights file"}
"""Roles of :data:`HASHES`, as the messages name them."""
LOCK_HINT = "wait for it to end or choose another --out"
"""The end of the message that refuses a second writer of an evaluation's output."""


class EvaluationInterrupted(KeyboardInterrupt):
    """Ctrl-C during a protocol; the finished trials are in the results file."""


def _init_worker(controller: str, model_path: str | None, contact: str,
                 ignore_sigint: bool = False, rotor_inertia: bool = False,
                 stop_on_success: bool = False, actuator: str = "ideal") -> None:
    if ignore_sigint:  # a pool worker: the parent alone handles Ctrl-C (one line, not one each)
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        # and the pool's terminate() ends it wherever it blocks: a SIGTERM handler inherited
        # from the parent runs Python code, which a worker blocked in a C-level lock never
        # reaches (an evaluation hung so after its last trial, the parent joining the worker)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
    _WORKER.update(controller=make(controller), model=model_path, contact=contact,
                   rotor_inertia=rotor_inertia, stop=stop_on_success, actuator=actuator)


def _work(scenario: Scenario) -> dict:
    return run_trial(_WORKER["controller"], scenario, _WORKER["model"], _WORKER["contact"],
                     rotor_inertia=_WORKER["rotor_inertia"], stop_on_success=_WORKER["stop"],
                     actuator=_WORKER["actuator"])


def completed_keys(results: Path) -> set[str]:
    """Keys of the trials already in ``results``: not the header; a torn line is ignored.

    Raises:
        ValueError: a line that is not a JSON object (see :func:`load_results`).
    """
    if not Path(results).is_file():
        return set()
    return {r["key"] for r in load_results(results) if r["key"] != HEADER_KEY}


def content_hashes(controller: str, model_path: str | Path | None) -> dict[str, str]:
    """SHA-256 of the files a run's results depend on, by role: ``model`` (the
    ``--model`` file itself, not the meshes it includes), ``policy`` (``policy.onnx`` of
    the controller's policy) and ``policy_data`` (its ``policy.onnx.data`` weights, where
    torch split them off); the roles without a file are absent."""
    hashes = {}
    if model_path is not None:
        hashes["model"] = sha256_file(model_path)
    policy = policy_path(controller)
    if policy is not None:
        hashes["policy"] = sha256_file(policy)
        weights = policy.with_name(policy.name + ".data")
        if weights.is_file():
            hashes["policy_data"] = sha256_file(weights)
    return hashes


def check_same_run(results: Path, meta: dict) -> None:
    """Refuses to resume ``results`` for a run other than the one its header describes:
    another setting, or the same file names with other contents.

    Args:
        results: an existing results file.
        meta: the header the run would write to a new file.

    Raises:
        ValueError: naming the first field that differs (or the missing header), or each
            file whose content hash differs.
    """
    with results.open() as f:
        first = f.readline()
    try:
        old = json.loads(first)
    except json.JSONDecodeError:
        old = {}
    if not isinstance(old, dict) or old.get("key") != HEADER_KEY:
        raise ValueError(f"{results} is not a results file of this harness (no header); "
                         "choose another --out or remove it")
    for field in sorted((set(old) | set(meta)) - {HASHES}):
        if old.get(field) != meta.get(field):
            raise ValueError(
                f"{results} holds another run ({field}: {old.get(field)!r} there, "
                f"{meta.get(field)!r} now); choose another --out or remove it to start anew")
    now = meta.get(HASHES, {})
    if HASHES not in old and now:
        raise ValueError(f"{results} records no content hashes of its model and policy "
                         "files, so they cannot be checked; choose another --out or remove "
                         "it to start anew")
    then = old.get(HASHES) or {}
    changed = [f"{_HASHED.get(role, role)} {_hashed_path(role, meta)} "
               f"(sha256 {_short(then.get(role))} there, {_short(now.get(role))} now)"
               for role in sorted(set(then) | set(now)) if then.get(role) != now.get(role)]
    if changed:
        raise ValueError(f"{results} holds results of other file contents: "
                         f"{'; '.join(changed)} changed; choose another --out or remove it "
                         "to start anew")


def _hashed_path(role: str, meta: dict) -> str:
    if role == "model":
        return str(meta.get("model"))
    policy = policy_path(str(meta.get("controller")))
    if policy is None:
        return "?"
    return str(policy if role == "policy" else policy.with_name(policy.name + ".data"))


def _short(digest: str | None) -> str:
    return "none" if digest is None else digest[:12]


def load_results(results: str | Path) -> list[dict]:
    """The rows of a JSON-lines results file: the header first, then each trial once.

    A line that is not JSON (a line torn by a killed run) is skipped; of rows with the
    same ``key`` (two writers appending at once before results were locked) the first
    is kept.

    Raises:
        FileNotFoundError: ``results file not found: <path>``.
        ValueError: a line that is JSON but not an object with a string ``key``:
            ``<path> line <n> is not a result row (a JSON object with a key): <line>``.
    """
    if not Path(results).is_file():
        raise FileNotFoundError(f"results file not found: {results}")
    rows: dict[str, dict] = {}
    for number, line in enumerate(Path(results).read_text().splitlines(), 1):
        try:
            row = json.loads(line)
        except json.JSONDecodeError:
            continue
        if not isinstance(row, dict) or not isinstance(row.get("key"), str):
            shown = line if len(line) <= 60 else line[:57] + "..."
            raise ValueError(f"{results} line {number} is not a result row (a JSON object "
                             f"with a key): {shown}")
        rows.setdefault(row["key"], row)
    header = rows.pop(HEADER_KEY, None)
    return [*([header] if header is not None else []), *rows.values()]


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
                 rotor_inertia: bool = False, stop_on_success: bool = False,
                 actuator: str = "ideal") -> list[dict]:
    """Runs every scenario not yet in ``results`` and appends one JSON line per trial.

    With ``stop_on_success`` each trial ends once it has succeeded (see
    :func:`run_trial`); ``actuator`` is the motor model (``ideal`` or ``dc``).

    A killed run resumes where it stopped: finished trials are skipped by key. The first
    line of a new file is a header with the controller (and its policy's provenance), the
    model, the contact setting, the rotor inertia, the SHA-256 of the model and policy
    files (:func:`content_hashes`) and ``header`` (the protocol's configuration and
    seed); an existing file is resumed only if its header is the same, since trial keys
    name the scenario, not who ran it. A new file is created with its first trial's row:
    a run that ends before any trial finished leaves no file.

    The run holds the lock of ``results`` (:func:`~hybrid_recovery.files.exclusive_lock`):
    a second writer of the same file is refused at once, naming the holder's pid.

    Ctrl-C stops the run: every finished trial is already in the file (written and
    flushed as it arrives), the workers are ended, and
    :class:`EvaluationInterrupted` says how many trials the file holds.

    Returns:
        All result rows of the file (old and new, each key once).

    Raises:
        ValueError: ``results`` exists but holds another run (another setting, or model
            or policy files whose contents changed), no header, or a line that is not a
            result row; or a bad controller, contact preset or model; nothing is written
            then.
        FileLockedError: another process is writing ``results``.
        EvaluationInterrupted: on Ctrl-C.
    """
    results = Path(results)
    check_contact_preset(contact)
    check_actuator(actuator)
    built = make(controller)  # fail fast on a bad spec, before any file
    meta = {"key": HEADER_KEY, "controller": controller, "model": model_path,
            "contact": contact, **(header or {})}
    if rotor_inertia:  # absent otherwise: older results files stay resumable
        meta["rotor_inertia"] = True
    if actuator != "ideal":  # likewise
        meta["actuator"] = actuator
    if (policy := policy_provenance(built)) is not None:
        meta["policy"] = policy
    if hashes := content_hashes(controller, model_path):
        meta[HASHES] = hashes
    with exclusive_lock(results, LOCK_HINT):
        return _run_locked(scenarios, controller, results, meta, model_path, contact,
                           workers, progress, rotor_inertia, stop_on_success, actuator)


def _run_locked(scenarios: list[Scenario], controller: str, results: Path, meta: dict,
                model_path: str | None, contact: str, workers: int, progress: bool,
                rotor_inertia: bool, stop_on_success: bool,
                actuator: str = "ideal") -> list[dict]:
    """:func:`run_protocol` once it holds the lock of ``results``."""
    if results.is_file():
        check_same_run(results, meta)
    done = completed_keys(results)
    todo = [s for s in scenarios if s.key not in done]
    start, count, shown = time.time(), 0, 0.0
    if workers <= 1:
        _init_worker(controller, model_path, contact, rotor_inertia=rotor_inertia,
                     stop_on_success=stop_on_success, actuator=actuator)
        rows: Iterator[dict] = map(_work, todo)
        pool = None
    else:
        pool = mp.get_context("fork").Pool(workers, _init_worker,
                                           (controller, model_path, contact, True,
                                            rotor_inertia, stop_on_success, actuator))
        rows = pool.imap_unordered(_work, todo)
    with contextlib.ExitStack() as stack:
        out: IO[str] | None = None
        try:
            for row in rows:
                if out is None:
                    out = stack.enter_context(_open_results(results, meta))
                out.write(json.dumps(row, default=str) + "\n")
                out.flush()
                count += 1
                if progress and (time.time() - shown > 1.0 or count == len(todo)):
                    _progress(count, len(todo), start, len(done))
                    shown = time.time()
        except KeyboardInterrupt:
            if progress and count:
                print(file=sys.stderr)
            if out is not None:
                out.flush()  # the interrupt may fall between a row's write and its count
            raise EvaluationInterrupted(
                f"interrupted: {len(completed_keys(results))} of {len(done) + len(todo)} "
                f"trials are in {results}; the same command resumes") from None
        finally:
            if pool is not None:
                pool.terminate()
    if progress and todo:
        print(file=sys.stderr)
    if not results.is_file():
        return []
    return [r for r in load_results(results) if r["key"] != HEADER_KEY]


@contextlib.contextmanager
def _open_results(results: Path, meta: dict) -> Iterator[IO[str]]:
    """``results`` opened to append, created with its header line when new; a line torn
    by a killed run is ended first."""
    new = not results.is_file()
    if new:
        results.parent.mkdir(parents=True, exist_ok=True)
    with results.open("a") as out:
        if new:
            out.write(json.dumps(meta) + "\n")
        elif results.read_bytes()[-1:] not in (b"", b"\n"):
            out.write("\n")
        yield out


def _progress(count: int, total: int, start: float, skipped: int) -> None:
    rate = count / max(time.time() - start, 1e-9)
    eta = (total - count) / max(rate, 1e-9)
    bar = "#" * int(30 * count / max(total, 1))
    print(f"\r[{bar:<30}] {count}/{total} trials ({skipped} resumed) {rate:.1f}/s "
          f"ETA {eta:5.0f}s", end="", file=sys.stderr, flush=True)
