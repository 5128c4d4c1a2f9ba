"""Typed settings of the QP balance controller and the hybrid supervisor (units in each field).

``default_config()`` returns the tuned values; override fields with
``dataclasses.replace`` (or attribute assignment on a fresh config). Every number is
checked finite and in its range (:data:`RANGES`) when a config is constructed.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from hybrid_recovery.checks import FINITE, NON_NEGATIVE, POSITIVE, UNIT, Range, check_fields
from hybrid_recovery.control.diagnostics import Capturability
from hybrid_recovery.robot.constants import UPRIGHT_COM_HEIGHT

COUNT: Range = (1, True, float("inf"))
"""An integer ≥ 1."""


@dataclass
class QpConfig:
    """Whole-body QP: task weights, task gains, contact model and solver settings.

    The cost is Σ_i w_i ‖J_i q̈ − b_i‖² + w_q̈ ‖q̈‖² + w_ρ ‖ρ‖², ρ the friction-pyramid
    coefficients of the sole-corner forces.
    """

    w_linear_momentum: float = 1.0
    """Weight of the linear momentum rate task ṗ_l = m c̈_des [1/N²]."""
    w_angular_momentum: float = 0.5
    """Weight of the angular momentum rate task L̇ = L̇_des [1/(N·m)²]."""
    w_swing_foot: float = 2e4
    """Weight of the swing-foot spatial acceleration task [s⁴/m²]."""
    w_pelvis_orientation: float = 20.0
    """Weight of the pelvis angular acceleration task [s⁴]."""
    w_posture_legs: float = 0.5
    """Weight of the joint-space posture task, leg joints [s⁴]."""
    w_posture_upper: float = 5.0
    """Weight of the joint-space posture task, waist and arm joints [s⁴]."""
    w_qacc: float = 1e-4
    """Regularisation of q̈ [s⁴]."""
    w_force: float = 1e-6
    """Regularisation of the pyramid coefficients ρ [1/N²]."""
    pelvis_kp: float = 60.0
    """Pelvis orientation stiffness [1/s²]."""
    pelvis_kd: float = 12.0
    """Pelvis orientation damping [1/s]."""
    posture_kp: float = 60.0
    """Posture stiffness toward q* [1/s²]."""
    posture_kd: float = 12.0
    """Posture damping [1/s]."""
    swing_kp: float = 400.0
    """Swing-foot position and orientation stiffness [1/s²]."""
    swing_kd: float = 40.0
    """Swing-foot damping [1/s]."""
    contact_kd: float = 10.0
    """Stance-foot velocity damping in the contact constraint a_foot = −k v_foot [1/s]."""
    limit_horizon: float = 0.1
    """Horizon T of the joint-limit acceleration box [s]."""
    limit_margin: float = 0.02
    """Joint limits shrunk by this margin in the QP [rad]."""
    friction: float = 0.6
    """Friction coefficient μ of the linearised (inner) pyramid, 4 edges per corner."""
    max_corner_force: float = 1500.0
    """Upper bound of each pyramid coefficient ρ [N]."""
    torque_limit_scale: float = 1.0
    """Torque limits in the QP as a fraction of ``constants.EFFORT_LIMITS``."""
    eps_abs: float = 1e-5
    """proxsuite absolute tolerance."""
    max_iter: int = 50
    """proxsuite outer (and inner) iteration cap; reaching it counts as a failure."""

    def __post_init__(self) -> None:
        check_config(self)


@dataclass
class DcmConfig:
    """Capture-point (DCM) control and the ankle/hip split of the desired CMP."""

    k_xi: float = 1.5
    """DCM gain k in r_cmp = ξ + k (ξ − ξ_ref); ξ converges at rate k ω [-]."""
    cop_margin: float = 0.015
    """CoP kept this far inside the support polygon [m] (ankle strategy)."""
    max_angular_momentum_rate: float = 60.0
    """Bound ‖L̇_xy‖ of the hip strategy [N·m]."""
    max_angular_momentum: float = 8.0
    """Bound ‖L_xy‖ of the hip strategy [kg·m²/s]."""
    angular_momentum_damping: float = 4.0
    """L̇_des = −k_L L when the CMP needs no offset [1/s]."""
    height_kp: float = 100.0
    """CoM height stiffness [1/s²]."""
    height_kd: float = 20.0
    """CoM height damping [1/s]."""
    ankle_threshold: float = 0.01
    """|r_cmp − ξ_ref| above which a tick counts as ankle strategy [m]."""
    hip_threshold: float = 0.002
    """CMP offset outside the CoP region above which a tick counts as hip strategy [m]."""

    def __post_init__(self) -> None:
        check_config(self)


@dataclass
class SteppingConfig:
    """Capture steps: when to step, where, and the swing trajectory."""

    enabled: bool = True
    """Allow steps; with False only ankle and hip strategies are used."""
    swing_time: float = 0.35
    """Swing duration Δt_s, also the shortest step time of the capture region [s]."""
    step_length: float = 0.55
    """Largest distance l_max of the new sole centre from the stance sole centre [m]."""
    foot_size: float = 0.04
    """r_max: ξ within this distance of the new sole centre counts as captured [m]."""
    min_width: float = 0.2
    """Least lateral distance between the sole centres (no leg crossing) [m]."""
    lateral_offset: float = 0.03
    """New sole centre placed this far beyond ξ at touchdown, away from the stance [m]."""
    target_margin: float = 0.02
    """The target is kept this far inside the capture region when it can be [m]."""
    swing_height: float = 0.07
    """Apex height of the swing trajectory [m]."""
    touchdown_depth: float = 0.01
    """The swing target lies this far below the ground so that contact is made [m]."""
    hip_margin_scale: float = 0.8
    """Step when ξ is farther out of C than this fraction of the hip's reach [-]."""
    lookahead: float = 0.05
    """Horizon of the "is ξ coming back" check before a step [s]."""
    replan_until: float = 0.6
    """The step target is re-planned until this fraction of the swing [-]."""
    replan_period: float = 0.01
    """Re-planning period during the swing [s]."""
    region_vertices: int = 16
    """Vertices of the discs of the 1-step capture region polygon [-]."""
    touchdown_force: float = 40.0
    """Normal force on the swing sole that ends the swing (after half of it) [N]."""
    touchdown_timeout: float = 1.5
    """Swing phase s = (t − t₀)/T after which touchdown is declared without contact [-]."""
    min_double_support: float = 0.08
    """Double support time after touchdown before another step [s]."""
    max_steps: int = 4
    """Most steps per recovery; N of the N-step capturability check."""

    def __post_init__(self) -> None:
        check_config(self)


@dataclass
class RiseConfig:
    """The rise from a crouch with both soles on the ground (:mod:`.rise`).

    The CoM height reference h_ref(t) and the posture reference q_ref(t) follow one
    minimum-jerk profile s(t) from the crouch (h₀, q₀) to the standing pose (h*, q*) over
    T (:meth:`profile_duration`); the capture-point law, the stepping and the QP are the
    standing ones.
    """

    speed: float = 0.12
    """Mean CoM rise speed v̄ of the profile s(t) = 10τ³ − 15τ⁴ + 6τ⁵, τ = t/T: T =
    (h* − h₀)/v̄ [m/s] (peak speed 1.875 v̄). A deep squat (h₀ 0.56 m) rises over 3 s,
    a squat at 0.71 m over 1.75 s."""
    duration: float = 3.0
    """Longest T [s]."""
    min_duration: float = 1.0
    """Shortest T [s]."""
    min_com_height: float = 0.3
    """While rising the QP applies down to this CoM height [m] (standing: 0.6)."""
    max_tilt: float = 1.3
    """While rising the QP applies up to this pelvis tilt from vertical [rad] (a squat
    leans the pelvis 35–60°; standing: 1.0)."""
    max_sole_height: float = 0.15
    """A rise starts only with both sole centres this close to the ground [m] (a start
    dropped onto the ground may have one foot up to ~13 cm above it)."""
    end_com_height: float = 0.85
    """The rise ends (the standing weights and bounds return) once the profile is
    complete, the CoM is this high [m] and ``end_tilt`` holds."""
    end_tilt: float = 0.35
    """... and the pelvis is tilted less than this from vertical [rad]."""
    w_pelvis_orientation: float = 100.0
    """Weight of the pelvis orientation task while rising [s⁴] (standing: 20). A squat
    starts with the pelvis pitched 30–40° forward; held less firmly, it pitches further
    as the knees extend, and the hips' yaw and roll limits (±0.43 rad) lock the legs in
    a bent-over stance."""
    limit_margin: float = 0.0
    """The QP's joint-limit margin δ while rising [rad] (standing: ``QpConfig.limit_margin``,
    0.02). Legs that straighten under a pitched pelvis bring the hips' yaw and roll to
    their ranges; the standing margin then leaves the QP almost no acceleration there."""
    stall_time: float = 0.25
    """A rise whose profile is over with the CoM still below ``end_com_height`` for this
    long is locked (the hips' yaw and roll at their ranges, the pelvis pitched): the
    stance is reset, one foot re-placed beside the other [s] (``docs/experiments.md``
    §15)."""
    max_resets: int = 2
    """Stance resets per rise."""
    shift_time: float = 1.0
    """A reset carries ξ_ref onto the stance sole for at most this long before the other
    foot lifts [s]. A locked CoM seldom comes within ``shift_tolerance`` of the sole, so
    this is mostly the shift's length (``docs/experiments.md`` §15)."""
    shift_tolerance: float = 0.04
    """... or until the CoM is this close to the stance sole's centre [m]."""

    def __post_init__(self) -> None:
        check_config(self)
        if self.min_duration > self.duration:
            raise ValueError(f"RiseConfig.min_duration must be <= duration "
                             f"({self.duration}), got {self.min_duration}")

    def profile_duration(self, start_height: float, end_height: float) -> float:
        """T = (h* − h₀)/v̄ within [``min_duration``, ``duration``] [s]."""
        return min(self.duration,
                   max(self.min_duration, (end_height - start_height) / self.speed))


@dataclass
class BalanceConfig:
    """The QP balance controller: its parts and when it applies."""

    qp: QpConfig = field(default_factory=QpConfig)
    dcm: DcmConfig = field(default_factory=DcmConfig)
    stepping: SteppingConfig = field(default_factory=SteppingConfig)
    rise: RiseConfig = field(default_factory=RiseConfig)
    min_com_height: float = 0.6
    """Below this CoM height [m] the robot is down: not applicable."""
    max_tilt: float = 1.0
    """Above this pelvis tilt from vertical [rad] the robot is down: not applicable."""
    foot_contact_force: float = 5.0
    """Normal force above which a sole counts as in contact [N]."""
    damping_gain: float = 1.0
    """Safe command when not applicable: τ = −k KD q̇ [-] (KD from constants)."""

    def __post_init__(self) -> None:
        check_config(self)


@dataclass
class SupervisorConfig:
    """Hybrid supervisor: hysteresis between the QP controller and the learned policy."""

    hand_over_at: Capturability = Capturability.ONE_STEP
    """The QP keeps the situations it captures without a step (ankle and hip strategies);
    from this capturability on (a step is needed, or nothing captures) the policy acts."""
    to_policy_delay: float = 0.0
    """Capturability at or beyond ``hand_over_at`` this long → policy [s] (0: at once)."""
    to_qp_dwell: float = 0.5
    """Upright and 0-step capturable this long → back to the QP [s]."""
    to_qp_margin: float = 0.02
    """ξ at least this far inside the feet polygon to go back to the QP [m]."""
    to_qp_max_com_speed: float = 0.15
    """CoM speed below this to go back to the QP [m/s]."""
    to_qp_min_com_height: float = UPRIGHT_COM_HEIGHT
    """CoM height above this to go back to the QP [m]."""
    to_policy_blend: float = 0.05
    """QP → policy hand-over: joint targets ramp from the measured joints to the policy's
    over this time [s] (short: the policy acts at once on a robot that needs a step)."""
    to_qp_blend: float = 0.2
    """Policy → QP hand-over: torques ramp from the policy's PD to the QP's [s]."""
    policy_dt: float = 0.02
    """Policy period (50 Hz) [s]; the PD law runs every physics step."""
    policy_delay: float = 0.02
    """Actuation delay of the policy's targets [s] (trained with 10–40 ms; the
    evaluation's ``learned`` controller uses 20 ms)."""
    action_scale: float = 0.3
    """q_ref = q* + scale · a [rad]."""
    max_ground_tilt: float = 0.05
    """Largest angle θ between a foot contact normal and the vertical for a hand-over to
    the QP [rad] (its ground is the plane z = 0). Why 0.05: docs/experiments.md §11."""
    max_weight_error: float = 0.15
    """Largest |ρ − 1|, ρ = Σ F_z / (m g) averaged over the standing dwell, for a hand-over
    to the QP (its mass is the model's m)."""
    max_torque_error: float = 0.1
    """Largest applied-against-commanded torque error e, a fraction of τ_lim; beyond it
    the QP's torque model is wrong: the policy acts for the rest of the episode."""

    def __post_init__(self) -> None:
        check_config(self)


RANGES: dict[str, dict[str, Range]] = {
    "QpConfig": {
        "w_linear_momentum": NON_NEGATIVE, "w_angular_momentum": NON_NEGATIVE,
        "w_swing_foot": NON_NEGATIVE, "w_pelvis_orientation": NON_NEGATIVE,
        "w_posture_legs": NON_NEGATIVE, "w_posture_upper": NON_NEGATIVE,
        "w_qacc": POSITIVE, "w_force": POSITIVE, "pelvis_kp": NON_NEGATIVE,
        "pelvis_kd": NON_NEGATIVE, "posture_kp": NON_NEGATIVE, "posture_kd": NON_NEGATIVE,
        "swing_kp": NON_NEGATIVE, "swing_kd": NON_NEGATIVE, "contact_kd": NON_NEGATIVE,
        "limit_horizon": POSITIVE, "limit_margin": NON_NEGATIVE, "friction": POSITIVE,
        "max_corner_force": POSITIVE, "torque_limit_scale": POSITIVE, "eps_abs": POSITIVE,
        "max_iter": COUNT},
    "DcmConfig": {
        "k_xi": NON_NEGATIVE, "cop_margin": NON_NEGATIVE,
        "max_angular_momentum_rate": NON_NEGATIVE, "max_angular_momentum": NON_NEGATIVE,
        "angular_momentum_damping": NON_NEGATIVE, "height_kp": NON_NEGATIVE,
        "height_kd": NON_NEGATIVE, "ankle_threshold": NON_NEGATIVE,
        "hip_threshold": NON_NEGATIVE},
    "SteppingConfig": {
        "swing_time": POSITIVE, "step_length": POSITIVE, "foot_size": NON_NEGATIVE,
        "min_width": NON_NEGATIVE, "lateral_offset": FINITE, "target_margin": NON_NEGATIVE,
        "swing_height": NON_NEGATIVE, "touchdown_depth": NON_NEGATIVE,
        "hip_margin_scale": POSITIVE, "lookahead": NON_NEGATIVE, "replan_until": UNIT,
        "replan_period": POSITIVE, "region_vertices": (3, True, float("inf")),
        "touchdown_force": NON_NEGATIVE, "touchdown_timeout": POSITIVE,
        "min_double_support": NON_NEGATIVE, "max_steps": NON_NEGATIVE},
    "RiseConfig": {
        "speed": POSITIVE, "duration": POSITIVE, "min_duration": POSITIVE,
        "min_com_height": POSITIVE, "max_tilt": POSITIVE,
        "max_sole_height": NON_NEGATIVE, "end_com_height": POSITIVE, "end_tilt": POSITIVE,
        "w_pelvis_orientation": NON_NEGATIVE, "limit_margin": NON_NEGATIVE,
        "stall_time": NON_NEGATIVE, "max_resets": NON_NEGATIVE, "shift_time": NON_NEGATIVE,
        "shift_tolerance": NON_NEGATIVE},
    "BalanceConfig": {
        "min_com_height": POSITIVE, "max_tilt": POSITIVE, "foot_contact_force": NON_NEGATIVE,
        "damping_gain": NON_NEGATIVE},
    "SupervisorConfig": {
        "to_policy_delay": NON_NEGATIVE, "to_qp_dwell": NON_NEGATIVE, "to_qp_margin": FINITE,
        "to_qp_max_com_speed": POSITIVE, "to_qp_min_com_height": POSITIVE,
        "to_policy_blend": NON_NEGATIVE, "to_qp_blend": NON_NEGATIVE, "policy_dt": POSITIVE,
        "policy_delay": NON_NEGATIVE, "action_scale": POSITIVE, "max_ground_tilt": POSITIVE,
        "max_weight_error": POSITIVE, "max_torque_error": POSITIVE},
}
"""Class name → field → range; every number must be finite."""


def check_config(config: QpConfig | DcmConfig | SteppingConfig | RiseConfig | BalanceConfig
                 | SupervisorConfig) -> None:
    """Checks every number of a control config: finite and in its range (:data:`RANGES`).

    Raises:
        ValueError: ``<Class>.<field> must be ..., got <value>``, e.g.
            ``QpConfig.friction must be > 0, got 0.0``.
    """
    check_fields(config, RANGES[type(config).__name__])


def default_config() -> BalanceConfig:
    """The tuned QP balance controller settings."""
    return BalanceConfig()
