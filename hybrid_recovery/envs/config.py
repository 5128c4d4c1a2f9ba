"""Typed configuration of the recovery environment (paper §III-C–§III-G), with units."""

from __future__ import annotations

import dataclasses
import typing
from dataclasses import dataclass, field
from typing import Any

from hybrid_recovery.envs.config_values import check_section, checked_value
from hybrid_recovery.robot.action import TARGET_RANGE_FACTOR
from hybrid_recovery.robot.actuator import SATURATION_RATIO, Actuator, check_actuator
from hybrid_recovery.robot.constants import UPRIGHT_COM_HEIGHT


@dataclass
class RewardConfig:
    """Weights w, shaping coefficients α, bandwidths σ of the paper (§III-E; rates per second).

    Every term value is multiplied by its weight and by the control period Δt, so a
    weight is a reward per second of the condition holding. A weight of 0 disables a
    term. Choices (the paper gives none):

    * Group I is the main drive: w_height 5 with σ_h 0.5 m leaves a usable gradient from
      the floor (h_c ≈ 0.2 m gives 0.08) to upright; r_rise pays α_r = 4 per m/s of
      rising; r_fall costs α_f = 4 per (m/s)²; both are off inside the dead band δ_h =
      0.08 m around h*, where r_stab pays α_s = 2 and costs α_v = 2 per m/s.
    * Group II: σ_c = 0.10 m and σ_ξ = 0.15 m are about half a foot length, so the reward
      falls off over the distance a foot or an ankle strategy can correct.
      α_ℓ = 2e-7 / N², α_L = 2e-5 / (N·m)²: free fall (|F_net| = m g ≈ 660 N) costs
      ≈ 0.09 per second, but a hard landing (Δp ≈ 130 kg·m/s within one 20 ms step,
      |F_net| ≈ 6.6 kN) ≈ 9 per second: compliant falls pay.
    * Group III: small regularisers that do not mask Groups I–II.
    """

    height_target: float | None = None
    """h*: target upright CoM height [m]; None = the CoM height of the default pose."""
    w_height: float = 5.0
    sigma_height: float = 0.5
    """σ_h [m]."""
    w_rise: float = 1.0
    alpha_rise: float = 4.0
    """α_r [1/(m/s)]."""
    w_fall: float = 1.0
    alpha_fall: float = 4.0
    """α_f [1/(m/s)²]."""
    w_stab: float = 1.0
    alpha_stab: float = 2.0
    alpha_stab_vel: float = 10.0
    """α_v [1/(m/s)]. At 2 a policy stood at h_c ≈ 0.92 m bobbing at |ḣ_c| ≈ 0.07 m/s and
    met the success criterion (|ḣ_c| < 0.1 m/s held for 1 s) in only 9 % of standing
    episodes; 10 makes that bobbing cost a third of the band bonus α_s."""
    height_band: float = 0.08
    """δ_h: dead band around h* [m]: r_rise and r_fall act outside it, r_stab inside."""
    w_com: float = 1.0
    sigma_com: float = 0.10
    """σ_c [m]."""
    w_cp: float = 2.0
    sigma_cp: float = 0.15
    """σ_ξ [m]."""
    w_mom: float = 1.0
    alpha_lin: float = 2e-7
    """α_ℓ [1/N²]."""
    alpha_ang: float = 2e-5
    """α_L [1/(N·m)²]."""
    w_torque: float = 2.0e-6
    """Weight of −Σ τ² [1/(N·m)²]."""
    w_joint_limit: float = 2.0
    """Weight of −Σ (violation beyond the soft limits) [1/rad]."""
    w_joint_speed: float = 0.0
    """Weight of −Σ_j max(|q̇_j| / ω_max,j − 1, 0), the joints' speed beyond the
    manufacturer's velocity limits ω_max (beyond the paper, off by default; the paper's
    "hardware protection" in group III). Why: the shipped policy, trained without it,
    drives joints past ω_max in 14–30 % of a rise's physics steps with ideal motors and
    ~14 % under the DC curve (gravity and impacts drive them there, not only the motors)."""
    w_action_rate: float = 0.01
    """Weight of −Σ (a_t − a_{t−1})². At 0.05 the initial exploration noise alone
    (σ = 1 on 27 joints) cost 2.7 per second, more than the alive bonus."""
    w_orient: float = 1.0
    """Weight of −‖g_xy‖², the torso's projected gravity off vertical."""
    w_contact: float = 0.25
    """Weight of the hand/elbow support reward, paid only while h_c < contact_gate_height."""
    contact_gate_height: float = 0.6
    """CoM height below which hand and elbow support is rewarded [m]."""
    w_feet: float = 0.0
    """Weight of r_feet, the share of the body weight borne by flat feet (beyond the paper,
    off by default). Standing, squatting: ≈ 1; the half-kneel: its front foot's share;
    kneeling, sitting, lying: ≈ 0. Why: from the two-knee kneel nothing but the rise itself
    rewards bringing a foot under the body; r_CP reads only the feet's polygon, ≈ 0 until
    the capture point is inside it."""
    feet_flat: float = 0.5
    """u_min: a foot counts fully when its sole normal is vertical, not at all once
    u_z ≤ u_min (60° tilt), linearly in between."""
    w_alive: float = 1.0
    w_termination: float = -100.0
    """Early-termination penalty (timeouts excluded), × Δt like every term."""
    use_capture_point: bool = True
    """Ablation switch: False zeroes r_CP (and r_CoM) — the capture-point rewards."""

    def __post_init__(self) -> None:
        check_section(self, "rewards.")


@dataclass
class NoiseConfig:
    """Additive uniform actor-observation noise half-widths (paper §III-G)."""

    ang_vel: float = 0.5
    """[rad/s]."""
    gravity: float = 0.15
    joint_pos: float = 0.1
    """[rad]."""
    joint_vel: float = 0.5
    """[rad/s]."""

    def __post_init__(self) -> None:
        check_section(self, "noise.")


@dataclass
class DomainRandConfig:
    """Per-episode domain randomisation ranges (paper §III-G); ``scale`` ∈ [0, 1] widens them
    from nominal (0) to the full range (1) — the curriculum drives it."""

    kp_scale: tuple[float, float] = (0.75, 1.25)
    kd_scale: tuple[float, float] = (0.75, 1.25)
    joint_friction: tuple[float, float] = (0.5, 4.0)
    """Joint Coulomb friction (MuJoCo frictionloss) [N·m]."""
    armature_scale: tuple[float, float] = (0.5, 1.6)
    static_friction: tuple[float, float] = (0.3, 1.6)
    dynamic_friction: tuple[float, float] = (0.3, 1.2)
    """MuJoCo has one Coulomb coefficient: μ = min(μ_s, μ_d) is used."""
    restitution: tuple[float, float] = (0.0, 0.2)
    """e, mapped to the contact damping ratio ζ = −ln e / √(π² + ln² e) (1 at e = 0)."""
    mass_scale: tuple[float, float] = (0.9, 1.1)
    inertia_scale: tuple[float, float] = (0.9, 1.1)
    init_base_pos: float = 0.05
    """Initial base position noise ±[m] (horizontal; vertical is re-seated on the ground)."""
    init_base_rot: float = 0.2
    """Initial base rotation noise ±[rad] about each axis."""
    init_joint_pos: float = 0.1
    """Initial joint offsets ±[rad]."""

    def __post_init__(self) -> None:
        check_section(self, "domain_rand.")


@dataclass
class PushConfig:
    """Torso pushes (paper §III-G): horizontal force at the torso CoM."""

    force: tuple[float, float] = (50.0, 300.0)
    """|F| [N]."""
    duration: tuple[float, float] = (0.1, 0.2)
    """[s]."""
    interval: tuple[float, float] = (3.0, 8.0)
    """Time between pushes [s]."""
    fall_force: tuple[float, float] = (350.0, 600.0)
    """Large fall-inducing push, once the robot has been upright for upright_time [N]."""
    fall_probability: float = 0.5
    """Chance that a push, while upright for ≥ upright_time, is a fall-inducing one."""
    upright_time: float = 2.0
    """[s]."""

    def __post_init__(self) -> None:
        check_section(self, "pushes.")


@dataclass
class CurriculumConfig:
    """Three stages (paper §III-F), advanced by the success rate of finished episodes.

    Stage 1 (exploration): torque limits × torque_scale_explore, no pushes, no domain
    randomisation, start poses ``stage1_poses``. Stage 2: ``difficulty`` rises from 0 to 1
    in steps of ``step`` each time the success rate ≥ ``advance_success``; it scales push
    probability, DR ranges and the share of hard poses. Stage 3: torque scale anneals
    from torque_scale_explore to 1 and the position-limit factor to 0.9 in the same
    steps. ``enabled=False`` starts at the end of stage 3 (the ablation).
    """

    enabled: bool = True
    torque_scale_explore: float = 10.0
    position_limit_final: float = TARGET_RANGE_FACTOR
    advance_success: float = 0.6
    """Success rate of the last ``window`` episodes needed to advance one step."""
    advance_on: str = "stood_up"
    """What counts as a success for advancing (and for decaying the assistance):
    ``"stood_up"`` = CoM above 0.85 m with the torso within 72° of vertical for 1 s;
    ``"success"`` = the paper's criterion, which adds |ḣ_c| < 0.1 m/s throughout. Training
    rollouts carry the policy's exploration noise, which alone breaks the stillness
    clause: with a mean policy that stood up from 44 % of squats by the full criterion
    (and ~100 % by "stood_up"), not one training episode met it in 4.5 M steps, so the
    curriculum could never advance. Both rates are logged."""
    advance_poses: tuple[str, ...] | None = None
    """Start poses whose episodes count for advancing (and for the assistance); None: all.
    Beyond the paper, for small budgets: with ``stage1_poses`` here, hard poses train
    alongside from stage 2 on without gating the torque annealing. Measured: after 300
    iterations (7 M steps) at stage 2 level 1.0, episodes stood up from standing 87 %,
    squatting 70 %, kneeling ~25 % and sitting, supine, prone 0 %, so the all-pose rate
    could not reach ``advance_success`` and stage 3 (1× torque) never began."""
    window: int = 512
    step: float = 0.1
    stage1_poses: tuple[str, ...] = ("standing", "squatting", "kneeling")

    def __post_init__(self) -> None:
        check_section(self, "curriculum.")


@dataclass
class AssistConfig:
    """Lifting assistance annealed away (beyond the paper; off by default).

    An upward force of ``fraction`` × m g on the torso while its tilt is below
    ``max_tilt`` lets early policies reach, and learn to hold, the upright states that
    random exploration rarely finds. Each time the success rate of the last curriculum
    window of episodes reaches ``CurriculumConfig.advance_success`` the fraction is
    multiplied by ``decay``; below ``floor`` it is switched off. The paper's curriculum
    (§III-F) only starts counting once the assistance is off.
    """

    fraction: float = 0.0
    """Initial force as a fraction of the robot's weight; 0 = off (the paper)."""
    decay: float = 0.7
    floor: float = 0.05
    max_tilt: float = 1.05
    """Torso tilt from vertical up to which the force acts [rad] (60°); π: any attitude,
    a pull that also lifts a robot off its back (the pulling-force curriculum of
    humanoid stand-up work)."""
    max_height: float = float("inf")
    """CoM height h_c above which the force stops [m]: a pull up to standing height that
    leaves the robot to stand on its own rather than carrying it off the ground
    (0.8 m g lifts a lying H1-2 to h_c ≈ 1.2 m; 1.0 m g off the ground)."""
    poses: list[str] | None = None
    """Start poses whose episodes get the force and whose outcomes (stood up or not)
    anneal it, while the other episodes go on counting for the curriculum; None: every
    episode is assisted and the curriculum waits for the assistance to end."""

    def __post_init__(self) -> None:
        check_section(self, "assist.")


@dataclass
class BridgeConfig:
    """Start-pose bridges (beyond the paper; off by default), see
    :mod:`hybrid_recovery.envs.pose_bridge`.

    For each (source, target) of ``pairs``, episodes drawn for the target start instead
    from a blend of the two poses — joint angles and base pitch interpolated, settled
    like every pose — at that bridge's level k / ``levels``, from 0 (the source pose) up;
    each time the stand-up rate of the last ``window`` such episodes reaches ``advance``
    the level rises by one, and at ``levels`` the episodes start from the target itself.
    Why: at 1× torque a policy that stands up from ``half_kneeling`` in about a third of
    its episodes may never rise from ``kneeling`` (the knee's range keeps the feet from
    getting under the body); the blends are the states in between, where the front foot
    comes forward. Likewise between squatting (risen from) and sitting (not), where the
    feet come under the body. Measured effect: ``docs/experiments.md``.
    """

    levels: int = 0
    """Steps from source to target; 0 = off (the paper)."""
    pairs: tuple[tuple[str, str], ...] = (("half_kneeling", "kneeling"),)
    """(source, target) start poses, one bridge each; the targets differ."""
    advance: float = 0.3
    """Stand-up rate of a target's episodes over ``window`` that earns its bridge a level."""
    retreat: float = 0.0
    """Stand-up rate over ``window`` below which the bridge steps back a level (0: never),
    so that its starts stay where rises are still found. Why: without it, bridges have
    stalled for 200 iterations at a level where 0–6 % stood up."""
    window: int = 256

    def __post_init__(self) -> None:
        check_section(self, "bridge.")
        _check_rates(self)


@dataclass
class RiseConfig:
    """Starts along recorded rises (beyond the paper; off by default), see
    :mod:`hybrid_recovery.envs.rise_starts`.

    Episodes of a pose that has recordings (``files``, written by ``hybrid-recovery getup
    record``: states along successful hybrid rises, model-based ground moves then the
    policy) start from recorded states (qpos, qvel) of the move, as a reverse curriculum:
    the move from the ground pose to the hand-over is cut into ``levels`` K stretches of
    equal time; level 0 starts from the stretch that ends at the hand-over, level K − 1
    from the one that begins at the ground pose, level K from the pose's own settled
    starts. A full window of ``window`` episodes from the current level with a stand-up
    rate ≥ ``advance`` moves it one level toward the ground pose, below ``retreat`` one
    back. The start-pose bridges of such a pose are not used. Why: a blend of two unrelated
    poses is a state no rising robot passes through; a recorded rise is one it does.
    """

    files: tuple[str, ...] = ()
    """Recordings (``.npz``), each of one start pose; empty = off (the paper)."""
    levels: int = 8
    """K: stretches of each recorded move."""
    advance: float = 0.4
    """Stand-up rate over ``window`` that moves the starts one stretch toward the ground.
    The training episodes run the stochastic policy, which stands up about half as often
    as its mean action does from the same starts: at 0.8 a fork of the live lineage stayed
    at level 0 for 65 iterations while its mean actor rose from there in 88–94 %; at 0.4
    it reached level 6 of 8 within 200 (docs/experiments.md §11)."""
    retreat: float = 0.15
    """Stand-up rate over ``window`` below which the starts move one stretch back."""
    window: int = 128
    """Finished episodes from the current level per decision."""

    def __post_init__(self) -> None:
        check_section(self, "rises.")
        _check_rates(self)


@dataclass
class TerrainConfig:
    """Terrain under each episode (beyond the paper; off by default), see
    :mod:`hybrid_recovery.envs.terrain_tiles`.

    Each episode draws its ground by ``weights``: flat, a slope (any heading), rough ground
    or a step edge through the start, its size ``level`` × the largest × U(0.5, 1) (rough:
    the nearest of ``rough_levels`` fields of max_rough · k / K). The level starts at
    ``start_level`` and rises by ``step`` each time the outcome rate
    (``curriculum.advance_on``) of the last ``window`` episodes reaches ``advance``, falls
    below ``retreat``. The critic sees the ground's heights on a ``height_grid`` ×
    ``height_grid`` grid ``height_spacing`` apart around the base (heading frame) below the
    base; the actor sees none.
    """

    enabled: bool = False
    weights: dict[str, float] = field(default_factory=lambda: {
        "flat": 1.0, "slope": 1.0, "rough": 1.0, "step": 1.0})
    """Sampling weights of the terrain kinds."""
    max_slope: float = 15.0
    """[deg]."""
    max_rough: float = 0.05
    """Largest height of rough ground [m]."""
    rough_levels: int = 5
    max_step: float = 0.10
    """[m]."""
    advance: float = 0.6
    retreat: float = 0.3
    window: int = 256
    step: float = 0.1
    start_level: float = 0.0
    """The level of a new run (a resumed one keeps its own) [-]."""
    height_grid: int = 7
    height_spacing: float = 0.3
    """[m]."""

    def __post_init__(self) -> None:
        check_section(self, "terrain.")
        unknown = set(self.weights) - {"flat", "slope", "rough", "step"}
        if unknown:
            raise ValueError(f"terrain.weights has unknown kinds {sorted(unknown)}; known: "
                             "['flat', 'slope', 'rough', 'step']")
        _check_rates(self)


@dataclass
class EnvConfig:
    """The recovery environment (paper §III-C–§III-G)."""

    num_envs: int = 1024
    num_threads: int = 0
    """Physics threads of the ``batch`` backend (0 = all cores)."""
    backend: str = "batch"
    """Physics backend: ``batch`` (CPU MuJoCo, float64) or ``warp`` (MuJoCo Warp, float32;
    :mod:`hybrid_recovery.sim.backend`)."""
    device: str = "cpu"
    """Device of the ``warp`` backend: ``cpu`` or ``cuda``."""
    seed: int = 0
    model_path: str | None = None
    """MJCF of the robot; None = the project's own H1-2."""
    physics_dt: float = 0.005
    """[s]."""
    decimation: int = 4
    """Physics substeps per control step (50 Hz control at 0.005 s)."""
    episode_length_s: float = 20.0
    action_scale: float = 0.3
    delay_range: tuple[float, float] = (0.010, 0.040)
    """Per-episode actuation delay [s], a multiple of physics_dt, held within the episode."""
    pose_weights: dict[str, float] = field(default_factory=lambda: {
        "standing": 1.0, "squatting": 1.0, "kneeling": 1.0, "sitting": 1.0,
        "supine": 1.0, "prone": 0.5, "half_kneeling": 0.0})
    """Sampling weights of the initial poses. ``half_kneeling`` (beyond the paper, 0 by
    default) is a stepping stone to rising from kneeling at 1× torque, where the knee's
    range (≤ 2.19 rad) keeps the feet from getting under the body."""
    privileged_critic: bool = True
    """Ablation switch: False gives the critic the actor's observation only."""
    torso_force_limit: float = 10000.0
    """Torso–ground contact force above which the episode ends [N] (the paper's "unsafe
    torso–ground contact under high contact force"). Measured on this model (32 envs):
    resting on the torso 0.2–0.35 kN; passive falls from standing peak at 0.75 kN
    (median); random actions from kneeling at 10× torque slam at 7.6 kN (median, 90th
    percentile 11.8 kN). At 2 kN and at 5 kN every training episode ended by torso
    contact within 1–2 s (rate 1.0, no stand-up learnt); 10 kN ends the violent slams
    only."""
    stuck_time: float = 2.0
    """Stuck-low: no CoM rise of stuck_rise above the lowest point of the last stuck_time
    seconds, while not upright, ends the episode [s]. (Measured against the rule read
    literally, a timer reset by any 2 cm rise: 48 % of episodes then timed out lying at
    h_c ≈ 0.34 m by wiggling.)"""
    stuck_rise: float = 0.02
    """[m]."""
    upright_height: float = UPRIGHT_COM_HEIGHT
    """CoM height of the success criterion [m]."""
    actuator: Actuator = "ideal"
    """Motor model (:mod:`hybrid_recovery.robot.actuator`): ``ideal``, ±τ_lim at any speed,
    or ``dc``, the torque–speed curve (applied every physics substep; ``batch`` backend
    only)."""
    actuator_saturation: float = SATURATION_RATIO
    """τ_sat / τ_lim of the ``dc`` model (why 1:
    :data:`~hybrid_recovery.robot.actuator.SATURATION_RATIO`)."""
    rewards: RewardConfig = field(default_factory=RewardConfig)
    noise: NoiseConfig = field(default_factory=NoiseConfig)
    domain_rand: DomainRandConfig = field(default_factory=DomainRandConfig)
    pushes: PushConfig = field(default_factory=PushConfig)
    curriculum: CurriculumConfig = field(default_factory=CurriculumConfig)
    assist: AssistConfig = field(default_factory=AssistConfig)
    bridge: BridgeConfig = field(default_factory=BridgeConfig)
    rises: RiseConfig = field(default_factory=RiseConfig)
    terrain: TerrainConfig = field(default_factory=TerrainConfig)

    def __post_init__(self) -> None:
        check_section(self, "")
        check_actuator(self.actuator)
        if self.actuator == "dc" and self.backend != "batch":
            raise ValueError(f"actuator 'dc' needs the batch backend, got '{self.backend}'")
        if self.terrain.enabled and self.backend != "batch":
            raise ValueError(f"terrain needs the batch backend, got '{self.backend}'")


def _check_rates(config: BridgeConfig | RiseConfig | TerrainConfig) -> None:
    """The stand-up rates that move a level: retreat below advance."""
    if not config.retreat < config.advance:
        raise ValueError(f"{type(config).__name__}.retreat must be < advance, got retreat "
                         f"{config.retreat!r} and advance {config.advance!r}")


def default_config() -> EnvConfig:
    """The paper's environment (§III-C–§III-G) with this project's documented choices."""
    return EnvConfig()


def apply_overrides(cfg: Any, overrides: dict[str, Any]) -> Any:
    """Applies dotted overrides, e.g. ``{"rewards.w_cp": 0.0, "num_envs": 64}``.

    Each value is checked against its field's declared type and range
    (:func:`~hybrid_recovery.envs.config_values.checked_value`): ``"abc"`` for a number
    or ``0`` for ``physics_dt`` is refused here, not met later as a TypeError.

    Raises:
        KeyError: naming the unknown key and the valid ones at that level.
        ValueError: ``config key '<key>' must be ..., got <value>``.
    """
    for dotted, value in overrides.items():
        target = cfg
        *path, last = dotted.split(".")
        if len(path) == 1 and isinstance(getattr(cfg, path[0], None), dict):
            _set_entry(cfg, path[0], last, value, dotted)
            continue
        for part in path:
            target = _field(target, part, dotted)
        _field(target, last, dotted)
        hint = typing.get_type_hints(type(target))[last]
        setattr(target, last, checked_value(dotted, value, hint))
    return cfg


def _set_entry(cfg: EnvConfig, name: str, entry: str, value: Any, dotted: str) -> None:
    """Sets entry ``entry`` of the dict-valued field ``name`` (``pose_weights.sitting``),
    checked as the field's values are; the entry must be one the field holds."""
    table = dict(getattr(cfg, name))
    if entry not in table:
        raise KeyError(f"unknown config key '{dotted}': '{entry}' is not one of {sorted(table)}")
    hint = typing.get_type_hints(EnvConfig)[name]
    try:
        table[entry] = checked_value(name, {entry: value}, hint)[entry]
    except ValueError as err:
        raise ValueError(str(err).replace(f"config key '{name}'", f"config key '{dotted}'", 1)
                         .replace(repr({entry: value}), repr(value))) from None
    setattr(cfg, name, table)


def _field(obj: Any, name: str, dotted: str) -> Any:
    names = [f.name for f in dataclasses.fields(obj)] if dataclasses.is_dataclass(obj) else []
    if name not in names:
        raise KeyError(f"unknown config key '{dotted}': '{name}' is not one of {names}")
    return getattr(obj, name)

