"""``hybrid-recovery eval`` and ``hybrid-recovery compare``."""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

from hybrid_recovery.cli.errors import UsageError, sigterm_as_interrupt
from hybrid_recovery.cli.registry import command
from hybrid_recovery.cli.validate import (
    CONTROLLER_HELP,
    Distinct,
    bounded,
    check_model,
    integer,
    positive,
    terrain,
)
from hybrid_recovery.evaluation.scenario import (
    MAX_DELAY,
    MAX_PAYLOAD,
    MAX_PUSH_FORCE,
    MOTOR_STRENGTH_RANGE,
    PUSH_HEIGHT_RANGE,
    SWEEP_DIRECTIONS,
)


def _scenarios(args: argparse.Namespace):
    """The protocol's scenarios, restricted as asked; refuses a restriction that does not
    apply and a ``--duration`` too short to show a recovery (:attr:`Scenario.min_duration`).
    """
    from hybrid_recovery.envs.terminations import SUCCESS_TIME
    from hybrid_recovery.evaluation.scenario import PROTOCOLS, check_pose

    kwargs = {"seed": args.seed}
    if args.duration is not None:
        kwargs["duration"] = args.duration
    if args.poses:
        if args.protocol == "pushes":
            raise UsageError("eval: --poses restricts the poses and sweep protocols; "
                             "pushes start from standing")
        for pose in args.poses:
            check_pose(pose)
        kwargs["poses"] = tuple(args.poses)
    for name in ("forces", "directions", "heights"):
        value = getattr(args, name, None)
        if value is None:
            continue
        if args.protocol in ("poses", "terrain") or (args.protocol == "pushes"
                                                     and name == "heights"):
            raise UsageError(f"eval: --{name} does not apply to the {args.protocol} protocol")
        kwargs[name] = tuple(value)
    terrains = getattr(args, "terrain", None)
    if terrains and args.protocol == "terrain":
        kwargs["terrains"] = tuple(terrains)
    scenarios = PROTOCOLS[args.protocol](args.trials, **kwargs)
    if terrains and args.protocol != "terrain":
        scenarios = [replace(s, terrain=t) for t in terrains for s in scenarios]
    scenarios = [replace(s, motor_strength=getattr(args, "motor_strength", 1.0),
                         payload=getattr(args, "payload", 0.0),
                         delay=getattr(args, "delay", 0.0)) for s in scenarios]
    longest = max(scenarios, key=lambda s: s.min_duration)
    if args.duration is not None and args.duration < longest.min_duration:
        why = (f"the push ends at {longest.min_duration - SUCCESS_TIME:g} s, then "
               if longest.force > 0 else "")
        raise UsageError(f"argument --duration: must be >= {longest.min_duration:g} s for the "
                         f"{args.protocol} protocol ({why}{SUCCESS_TIME:g} s of standing "
                         f"counts a recovery), got '{args.duration:g}'")
    return scenarios


def _run(args: argparse.Namespace, controller: str, out: Path) -> list[dict]:
    from hybrid_recovery.evaluation import run_protocol

    header = {"protocol": args.protocol, "trials": args.trials, "seed": args.seed,
              "poses": list(args.poses) if args.poses else None, "duration": args.duration}
    for name in ("forces", "directions", "heights"):  # recorded only when restricted
        if getattr(args, name, None) is not None:
            header[name] = list(getattr(args, name))
    if args.stop_on_success:
        header["stop_on_success"] = True
    if args.terrain:
        header["terrain"] = list(args.terrain)
    for name, nominal in (("motor_strength", 1.0), ("payload", 0.0), ("delay", 0.0)):
        if getattr(args, name) != nominal:  # recorded only off-nominal
            header[name] = getattr(args, name)
    return run_protocol(_scenarios(args), controller, out / "results.jsonl",
                        model_path=args.model, contact=args.contact, workers=args.workers,
                        header=header, rotor_inertia=args.rotor_inertia,
                        stop_on_success=args.stop_on_success, actuator=args.actuator)


def _sections(results: dict[str, list[dict]], out: Path) -> str:
    """The report's motor and terrain sections (Markdown)."""
    from hybrid_recovery.evaluation.motor_use import motor_table
    from hybrid_recovery.evaluation.terrain_results import terrain_section

    motors = motor_table(results)
    return "\n".join([*(["## Motors", "", motors, ""] if motors else []),
                      terrain_section(results, out)])


def _check(args: argparse.Namespace, controllers: list[str]) -> None:
    """Everything the run will need, before any of it runs or any file is written:
    the scenarios, the model, the contact preset and every controller."""
    from hybrid_recovery.controllers import make
    from hybrid_recovery.evaluation.contact import check_contact_preset

    _scenarios(args)
    check_contact_preset(args.contact)
    check_model(args.model)
    for spec in controllers:
        make(spec)


def _eval(args: argparse.Namespace) -> int:
    from hybrid_recovery.evaluation.report import summary_table, write_report
    from hybrid_recovery.evaluation.runner import LOCK_HINT
    from hybrid_recovery.files import exclusive_lock

    _check(args, [args.controller])
    out = Path(args.out)
    with exclusive_lock(out, LOCK_HINT):  # the results and the report: one writer
        with sigterm_as_interrupt():
            rows = _run(args, args.controller, out)
        print(summary_table(rows))
        report = write_report({args.controller: rows}, out,
                              f"{args.protocol}: {args.controller}",
                              notes=_sections({args.controller: rows}, out))
    print(f"results: {out / 'results.jsonl'}  report: {report}")
    return 0


def _compare(args: argparse.Namespace) -> int:
    from hybrid_recovery.evaluation.report import summary_table, write_report
    from hybrid_recovery.evaluation.runner import LOCK_HINT
    from hybrid_recovery.files import exclusive_lock

    _check(args, args.controllers)
    out = Path(args.out)
    results = {}
    with exclusive_lock(out, LOCK_HINT):  # every controller's results and the report
        for k, spec in enumerate(args.controllers):
            with sigterm_as_interrupt():
                results[spec] = _run(args, spec, out / f"c{k}")
            print(f"== {spec}\n{summary_table(results[spec])}")
        report = write_report(results, out, f"{args.protocol}: comparison",
                              notes=_sections(results, out))
    print(f"report: {report}")
    return 0


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--protocol", choices=["poses", "sweep", "pushes", "terrain"],
                   default="poses", help="terrain: the poses on flat ground, slopes, rough "
                   "ground and steps at rising difficulty (or on --terrain), trials per cell")
    p.add_argument("--trials", type=integer(1), default=100,
                   help="poses: trials in all; sweep/pushes/terrain: trials per cell")
    p.add_argument("--poses", nargs="*", default=None, action=Distinct,
                   help="poses, sweep: only these start poses")
    p.add_argument("--duration", type=positive, default=None,
                   help="trial length [s]; at least the push's end + 1 s (1 s without one)")
    p.add_argument("--forces", type=bounded(0.0, MAX_PUSH_FORCE, "N"), nargs="+",
                   default=None, action=Distinct,
                   help=f"sweep/pushes: only these push forces [N], 0 to {MAX_PUSH_FORCE:g}")
    p.add_argument("--directions", nargs="+", default=None, choices=list(SWEEP_DIRECTIONS),
                   action=Distinct, help="sweep/pushes: only these push directions")
    p.add_argument("--heights", type=bounded(*PUSH_HEIGHT_RANGE, "m"), nargs="+",
                   default=None, action=Distinct,
                   help="sweep: only these push heights relative to the CoM [m], "
                        f"{PUSH_HEIGHT_RANGE[0]:g} to {PUSH_HEIGHT_RANGE[1]:g}")
    p.add_argument("--seed", type=integer(0), default=0)
    p.add_argument("--model", default=None, help="another robot MJCF (sim-to-sim)")
    p.add_argument("--contact", default="default", help="contact preset (sim-to-sim)")
    p.add_argument("--rotor-inertia", action="store_true",
                   help="give the joints the project's rotor inertia (armature), for a "
                        "model file without it such as the manufacturer's")
    p.add_argument("--terrain", type=terrain, nargs="+", default=None, action=Distinct,
                   help="the ground: flat, slope:DEG[:HEADING], rough:CM (largest height) or "
                        "step:CM; several: the protocol on each")
    p.add_argument("--actuator", choices=["ideal", "dc"], default="ideal",
                   help="motor model: ideal (full torque at any speed) or dc (torque falls "
                        "with speed to 0 at the manufacturer's velocity limit)")
    p.add_argument("--motor-strength", type=bounded(*MOTOR_STRENGTH_RANGE), default=1.0,
                   help="the motors' torque bound as a fraction of the rated one (weak "
                        f"motors: < 1), {MOTOR_STRENGTH_RANGE[0]:g} to "
                        f"{MOTOR_STRENGTH_RANGE[1]:g}; the controllers assume 1")
    p.add_argument("--payload", type=bounded(0.0, MAX_PAYLOAD, "kg"), default=0.0,
                   help="a mass on the torso the controllers do not know [kg], 0 to "
                        f"{MAX_PAYLOAD:g}")
    p.add_argument("--delay", type=bounded(0.0, MAX_DELAY, "s"), default=0.0,
                   help="added actuation delay of every controller's output [s], in whole "
                        f"physics steps, 0 to {MAX_DELAY:g}")
    p.add_argument("--workers", type=integer(1), default=2)
    p.add_argument("--stop-on-success", action="store_true",
                   help="end each trial once it has succeeded (same success and recovery "
                        "time, shorter trials; end-of-trial figures then describe that time)")


def _configure_eval(p: argparse.ArgumentParser) -> None:
    p.add_argument("--controller", default="learned", help=CONTROLLER_HELP)
    p.add_argument("--out", default="results/eval")
    _common(p)


def _configure_compare(p: argparse.ArgumentParser) -> None:
    p.add_argument("--controllers", nargs="+", required=True, action=Distinct,
                   help=CONTROLLER_HELP)
    p.add_argument("--out", default="results/compare")
    _common(p)


_eval.configure = _configure_eval  # type: ignore[attr-defined]
_compare.configure = _configure_compare  # type: ignore[attr-defined]
command("eval", "Evaluate a controller on the paper's protocols (poses, sweep, pushes).")(_eval)
command("compare", "Run one protocol for several controllers; one side-by-side report.")(
    _compare)
