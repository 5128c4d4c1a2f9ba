"""``bench deploy``: ONNX inference latency and 50 Hz loop jitter over loopback DDS.

The simulated robot runs in a second process (MuJoCo 1 kHz, ``LowState_`` at 500 Hz); this
process runs the full controller (state machine + policy + DDS) for ``seconds``. The
figures: inference time per policy step, wake-up lateness against the absolute 50 Hz
schedule, period jitter |Δt_wake − 20 ms|, the compute time per tick (state decode,
policy, state machine, command encode and write) and when the command left relative to
its deadline, with the
machine's load (load average and CPU busy share over the run, from ``/proc``).
"""

from __future__ import annotations

import json
import os
import random
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict
from pathlib import Path

from hybrid_recovery.deploy.bridge import run_controller
from hybrid_recovery.deploy.state_machine import SafetyConfig
from hybrid_recovery.robot.limits import SafetyLimits

_ROBOT_CODE = (
    "import json, dataclasses, sys\n"
    "from hybrid_recovery.deploy.bridge import serve_sim_robot\n"
    "from hybrid_recovery.deploy.sim_robot import SimRobotConfig\n"
    "d, s, rt = int(sys.argv[1]), float(sys.argv[2]), sys.argv[3] == '1'\n"
    "r = serve_sim_robot(SimRobotConfig(gantry_s=3.0), d, 'lo', s, 1.0, rt)\n"
    "print(json.dumps(dataclasses.asdict(r)))\n"
)


def _cpu_times() -> tuple[float, float]:
    """(busy, total) jiffies of all CPUs from /proc/stat (steal counted busy)."""
    fields = [float(v) for v in Path("/proc/stat").read_text().split("\n")[0].split()[1:]]
    idle = fields[3] + fields[4]
    total = sum(fields[:8])
    return total - idle, total


def bench_deploy(seconds: float = 60.0, policy_dir: str | Path | None = None,
                 realtime: bool = True, domain_id: int | None = None) -> dict:
    """Runs the loopback benchmark; returns the figures (see the module docstring)."""
    domain = domain_id if domain_id is not None else random.SystemRandom().randint(1, 200)
    with tempfile.TemporaryDirectory() as tmp:
        if policy_dir is None:
            from hybrid_recovery.training.stand_in import write_stand_in_policy

            policy_dir = write_stand_in_policy(Path(tmp) / "policy", "random")
        robot = subprocess.Popen(
            [sys.executable, "-c", _ROBOT_CODE, str(domain), str(seconds + 20.0),
             "1" if realtime else "0"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
            text=True)
        load_before, cpu0, t0 = os.getloadavg(), _cpu_times(), time.monotonic()
        try:
            safety = SafetyConfig(SafetyLimits.from_robot())
            report = run_controller(f"onnx:{policy_dir}", domain, "lo", seconds, safety,
                                    wait_timeout_s=30.0, realtime=realtime)
        finally:
            cpu1, wall = _cpu_times(), time.monotonic() - t0
            try:
                out, err = robot.communicate(timeout=30.0)
            except subprocess.TimeoutExpired:
                robot.kill()
                out, err = robot.communicate()
    robot_report = json.loads(out.strip().splitlines()[-1]) if out.strip() else {"error": err}
    busy = (cpu1[0] - cpu0[0]) / max(cpu1[1] - cpu0[1], 1.0)
    return {
        "seconds": seconds, "policy": str(policy_dir), "domain": domain,
        "controller": {k: v for k, v in asdict(report).items() if k != "ticks"},
        "robot": robot_report,
        "state_rate_hz": report.states_received / max(report.seconds, 1e-9),
        "load": {"loadavg_before": load_before, "loadavg_after": os.getloadavg(),
                 "cpu_busy_share": busy, "cpus": os.cpu_count(), "wall_s": wall},
    }


def format_bench(result: dict) -> str:
    """A short table of the figures."""
    c, s = result["controller"], result["controller"]["stats"]
    r = result["robot"]
    lines = [
        f"bench deploy: {result['seconds']:.0f} s over loopback DDS, controller "
        f"{c['scheduling']}, robot {r.get('scheduling', '?')}; load avg "
        f"{result['load']['loadavg_before'][0]:.2f} → {result['load']['loadavg_after'][0]:.2f},"
        f" CPU busy {100 * result['load']['cpu_busy_share']:.0f} % of "
        f"{result['load']['cpus']} cores",
        f"{'quantity':28s} {'median':>9s} {'p99':>9s} {'max':>9s}  [ms]",
    ]
    for key, label in (("inference", "ONNX inference"), ("lateness", "wake lateness"),
                       ("period_jitter", "period jitter |dt - 20 ms|"),
                       ("compute", "compute per tick"),
                       ("send_lateness", "command sent after deadline")):
        if f"{key}_median_ms" in s:
            lines.append(f"{label:28s} {s[key + '_median_ms']:9.3f} {s[key + '_p99_ms']:9.3f} "
                         f"{s[key + '_max_ms']:9.3f}")
    lines.append(f"ticks {s['ticks']:.0f}, states received {c['states_received']} "
                 f"({result['state_rate_hz']:.0f} Hz), commands sent {c['commands_sent']}, "
                 f"robot accepted {r.get('commands_accepted')} rejected "
                 f"{r.get('commands_rejected')}, fault {c['fault']}")
    return "\n".join(lines)
