"""Configuration: every setting of a run, loaded from YAML, overridden, validated.

The robot configs in `configs/<robot>.yaml` hold the paper's tables (Table 3: ES, Table 4:
rewards, Table 7: regulator gains) and every other setting. A user config names a `robot`
and overrides any subset of that robot's config; unknown keys are errors.
"""

from __future__ import annotations

import dataclasses
import importlib.resources
import math
import typing
from pathlib import Path
from typing import Any

import yaml


class ConfigError(ValueError):
    """A setting is missing, unknown or out of range. The message is one line."""


@dataclasses.dataclass(frozen=True)
class PhysicsConfig:
    dt: float  # physics time step, s (the paper: 0.0005, the robot's 2 kHz loop)
    impl: str  # auto: warp on an NVIDIA GPU with mujoco-warp, else jax
    solver_iterations: int
    ls_iterations: int
    contacts_per_env: int  # warp: contact buffer per environment (feet only collide)
    constraints_per_env: int  # warp: njmax


@dataclasses.dataclass(frozen=True)
class EpisodeConfig:
    seconds: float
    vx: tuple[float, float]  # commanded velocities, heading frame, m/s
    vy: tuple[float, float]
    yaw: tuple[float, float]  # desired heading relative to the start, rad
    pool_size: int  # balanced initial states from the standing controller
    settle_seconds: float
    steps_per_check: int  # physics steps between checks that every env is done
    # a second command, drawn like the first, takes over at U(command_change) s (not in the
    # paper, whose episodes hold one command); [0, 0] (the default) keeps one command
    command_change: tuple[float, float] = (0.0, 0.0)


@dataclasses.dataclass(frozen=True)
class GaitConfig:
    bezier_order: int  # M, eq. 11
    step_time: float  # T_step, s
    min_phase: float  # a swing-foot touchdown ends the step only after this phase
    max_phase: float  # time-out: the step ends here whatever the contact force
    grf_threshold: float  # N, swing-foot normal force that counts as touchdown
    action_scale: float  # scales every learned joint's range about its nominal
    # which foot lifts first from standing (not in the paper): "random" (a fair coin per episode),
    # or "command": the foot on the side of the commanded sideways velocity (env.first_stance)
    first_swing: str = "random"


@dataclasses.dataclass(frozen=True)
class PolicyConfig:
    hidden_layers: int
    hidden_units: int
    # the features of a right-stance step are mirrored (lateral components negated) into the
    # left-stance picture that the role coordinates use (gait.velocity_to_role); false, the
    # default, is what configs saved before this setting existed did
    mirror_lateral: bool = False


@dataclasses.dataclass(frozen=True)
class RegulatorConfig:
    """Sec. IV gains; Table 7 for the torso and swing-leg terms."""

    k_phr: float  # swing hip roll, P on (v_y - v_y^d)
    k_dhr: float  # swing hip roll, on (v_y - v_y^ls)
    k_php: float  # swing hip pitch, P on (v_x - v_x^d)
    k_dhp: float  # swing hip pitch, on (v_x - v_x^ls)
    k_neutral_x: float  # fraction of Raibert's neutral point v T / 2 added forward (regulators.neutral_point)
    k_neutral_y: float  # and sideways
    k_ptp: float  # stance toe pitch (Digit only)
    k_ptr: float  # stance toe roll (Digit only)
    k_heading: float  # swing hip yaw per rad of heading error, eq. 24 row 3
    k_p_roll: float  # torso roll PD torque, Sec. IV-B
    k_d_roll: float
    k_p_pitch: float  # torso pitch PD torque
    k_d_pitch: float
    blend_phase: float  # swing compensations ramp in over tau in [0, blend_phase]
    k_i_drift: float  # PI drift term beta_x: rad per (m/s) per step
    drift_limit: float  # |beta| bound, rad
    slope_estimation: bool  # swing foot parallel to the stance foot (Sec. IV-A)
    # stance knee extension per m of pelvis height below rewards.height (regulators.height_fix;
    # not in the paper): 0, the default, leaves the pelvis height to the learned stance knee
    k_height: float = 0.0
    # beta_y's own integral gain (regulators.drift_update); 0.05, the default, is the single gain
    # that configs saved before this setting existed used for both axes
    k_i_drift_y: float = 0.05
    # how fast the command the controller follows may move towards the one given
    # (regulators.rate_limit; not in the paper): [m/s^2 for vx and vy, rad/s for the heading];
    # 0, the default, follows every command at once
    command_rate: tuple[float, float] = (0.0, 0.0)
    # k_height's pelvis height over the ground under the pelvis, extrapolated from the stance foot
    # along the slope estimate (regulators.ground_rise), instead of over the stance foot: false,
    # the default, is how configs saved before this setting existed measured it
    height_over_slope: bool = False


@dataclasses.dataclass(frozen=True)
class RewardWeights:
    """w of eq. 13, Table 4, in the paper's order."""

    vx: float
    vy: float
    height: float
    torque: float
    com: float
    orientation: float
    angular_velocity: float
    feet_distance: float
    stance_foot: float


@dataclasses.dataclass(frozen=True)
class RewardConfig:
    """Table 4 constants."""

    rho_v: float
    epsilon: float
    e_vx: float
    e_vy: float
    velocity_cap: float  # bound of the in-band velocity reward (see rewards.py)
    height: float  # q_z^d
    e_height: float
    rho_d: float
    com_radius: float  # d in Table 4: radius of the admissible CoM region P
    feet_min: float
    feet_max: float
    termination_penalty: float  # per second of the episode lost to early termination
    weights: RewardWeights
    velocity_steps: int = 1  # walking steps whose average velocity r_vx, r_vy judge: 1 (the last) or 2 (a stride)


@dataclasses.dataclass(frozen=True)
class TerminationConfig:
    """Eq. 27."""

    max_tilt: float  # |roll|, |pitch|, rad
    max_yaw_error: float  # |yaw - yaw^d|, rad
    max_rate: float  # |angular velocity| per axis, rad/s
    height: tuple[float, float]  # pelvis height above the ground, m
    feet: tuple[float, float]  # lateral distance between the feet, m
    max_speed: float  # any |qvel| beyond this is diverged physics


@dataclasses.dataclass(frozen=True)
class RandomizationConfig:
    """Table 5, sampled once per episode, and an optional push (not in the paper)."""

    enabled: bool
    mass: tuple[float, float]
    com: tuple[float, float]
    # one horizontal push on the pelvis per episode: magnitude U(push_force) N in a uniformly random
    # direction, for push_seconds, starting at U(push_after) s; [0, 0] (the default) pushes nothing
    push_force: tuple[float, float] = (0.0, 0.0)
    push_seconds: float = 0.2
    push_after: tuple[float, float] = (1.0, 3.0)
    # a curriculum: the first push_warmup_generations generations train without pushes
    push_warmup_generations: int = 0


@dataclasses.dataclass(frozen=True)
class ESConfig:
    """Table 3."""

    population: int  # members, antithetic pairs: must be even
    sigma: float
    sigma_decay: float
    sigma_min: float
    learning_rate: float
    lr_decay: float
    lr_min: float
    optimizer: str  # adam | sgd
    weight_decay: float  # L2 on the parameters, added to the ES gradient


@dataclasses.dataclass(frozen=True)
class TrainConfig:
    generations: int
    checkpoint_every: int
    generations_per_call: int  # generations per jitted call (one lax.scan)


@dataclasses.dataclass(frozen=True)
class Config:
    robot: str
    seed: int
    physics: PhysicsConfig
    episode: EpisodeConfig
    gait: GaitConfig
    policy: PolicyConfig
    regulators: RegulatorConfig
    rewards: RewardConfig
    termination: TerminationConfig
    randomization: RandomizationConfig
    es: ESConfig
    train: TrainConfig

    def override(self, **overrides: Any) -> "Config":
        """A validated copy with dotted-key overrides: `cfg.override(**{"es.sigma": 0.05})`."""
        return apply_overrides(self, overrides)


ROBOTS = ("cassie", "digit")
FIRST_SWING = ("random", "command")  # gait.first_swing


def to_dict(cfg: Any) -> dict:
    """Plain nested dict (tuples as lists) for YAML, JSON and checkpoints."""

    def plain(x):
        if dataclasses.is_dataclass(x):
            return {f.name: plain(getattr(x, f.name)) for f in dataclasses.fields(x)}
        if isinstance(x, tuple):
            return [plain(v) for v in x]
        return x

    return plain(cfg)


def from_dict(data: dict) -> Config:
    """A complete config from nested dicts (every key present, none unknown), validated."""
    cfg = _build(Config, data, "")
    validate(cfg)
    return cfg


def robot_config(robot: str) -> Config:
    """The shipped config of a robot (`configs/<robot>.yaml`)."""
    if robot not in ROBOTS:
        raise ConfigError(f"unknown robot {robot!r}; choose from {', '.join(ROBOTS)}")
    text = importlib.resources.files("mjx_cascade.configs").joinpath(f"{robot}.yaml").read_text()
    return from_dict(yaml.safe_load(text))


def load(path: str | Path) -> Config:
    """A user config file: its `robot` picks the shipped config, its other keys override it."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"config file not found: {path}")
    try:
        data = yaml.safe_load(path.read_text()) or {}
    except yaml.YAMLError as e:
        raise ConfigError(f"config file {path} is not valid YAML: {str(e).splitlines()[0]}") from None
    if not isinstance(data, dict):
        raise ConfigError(f"config file {path} must hold a mapping of sections")
    base = robot_config(str(data.get("robot", "cassie")))
    cfg = _merge(base, data, "")
    validate(cfg)
    return cfg


def parse_assignments(items: list[str]) -> dict[str, str]:
    """`["a.b=1", ...]` (the command lines' `--set`) -> `{"a.b": "1"}`, values parsed later."""
    out = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep:
            raise ConfigError(f"--set needs KEY=VALUE, got {item!r}")
        out[key.strip()] = value
    return out


def apply_overrides(cfg: Config, overrides: dict[str, Any]) -> Config:
    """Apply `{"section.key": value}` overrides (string values are parsed as YAML)."""
    nested: dict = {}
    for key, value in overrides.items():
        if isinstance(value, str):
            try:
                value = yaml.safe_load(value)
            except yaml.YAMLError:
                raise ConfigError(f"cannot parse the value of {key}: {value!r}") from None
        node = nested
        parts = key.split(".")
        for part in parts[:-1]:
            node = node.setdefault(part, {})
            if not isinstance(node, dict):
                raise ConfigError(f"config key {key!r} does not name a setting")
        node[parts[-1]] = value
    out = _merge(cfg, nested, "")
    validate(out)
    return out


def _check_keys(cls: type, data: Any, prefix: str, complete: bool) -> dict:
    where = prefix.rstrip(".") or "config"
    if not isinstance(data, dict):
        raise ConfigError(f"{where} must be a mapping")
    names = [f.name for f in dataclasses.fields(cls)]
    for key in data:
        if key not in names:
            close = [n for n in names if n[:3] == str(key)[:3]]
            hint = f" (did you mean {prefix}{close[0]}?)" if close else ""
            raise ConfigError(f"unknown config key '{prefix}{key}'{hint}")
    if complete:  # a setting with a default may be absent (configs saved before it existed)
        required = [f.name for f in dataclasses.fields(cls)
                    if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING]
        missing = [n for n in required if n not in data]
        if missing:
            raise ConfigError(f"config key '{prefix}{missing[0]}' is missing")
    return typing.get_type_hints(cls)


def _build(cls: type, data: Any, prefix: str) -> Any:
    hints = _check_keys(cls, data, prefix, complete=True)
    values = {}
    for key, value in data.items():
        if dataclasses.is_dataclass(hints[key]):
            values[key] = _build(hints[key], value, f"{prefix}{key}.")
        else:
            values[key] = _coerce(value, hints[key], f"{prefix}{key}")
    return cls(**values)


def _merge(obj: Any, data: Any, prefix: str) -> Any:
    hints = _check_keys(type(obj), data, prefix, complete=False)
    changes = {}
    for key, value in data.items():
        if dataclasses.is_dataclass(hints[key]):
            changes[key] = _merge(getattr(obj, key), value, f"{prefix}{key}.")
        else:
            changes[key] = _coerce(value, hints[key], f"{prefix}{key}")
    return dataclasses.replace(obj, **changes)


def _coerce(value: Any, hint: Any, name: str) -> Any:
    origin = typing.get_origin(hint)
    if origin is tuple:
        kinds = typing.get_args(hint)
        if not isinstance(value, (list, tuple)) or len(value) != len(kinds):
            raise ConfigError(f"{name} must be a list of {len(kinds)} numbers")
        return tuple(_coerce(v, k, name) for v, k in zip(value, kinds))
    if hint is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"{name} must be true or false")
        return value
    if hint is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"{name} must be an integer")
        return value
    if hint is float:
        if isinstance(value, str):
            try:
                value = float(value)
            except ValueError:
                raise ConfigError(f"{name} must be a number") from None
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ConfigError(f"{name} must be a finite number")
        return float(value)
    if hint is str:
        if not isinstance(value, str):
            raise ConfigError(f"{name} must be a string")
        return value
    raise ConfigError(f"{name}: unsupported setting type {hint}")


def validate(cfg: Config) -> None:
    """Raise ConfigError naming the first setting out of range."""

    def need(ok: bool, msg: str) -> None:
        if not ok:
            raise ConfigError(msg)

    need(cfg.robot in ROBOTS, f"unknown robot {cfg.robot!r}; choose from {', '.join(ROBOTS)}")
    p, e, g, es, t = cfg.physics, cfg.episode, cfg.gait, cfg.es, cfg.train
    need(p.dt > 0, "physics.dt must be positive")
    need(p.dt <= 0.005, "physics.dt must be at most 0.005 s (the model's springs need small steps)")
    need(p.impl in ("auto", "jax", "warp"), "physics.impl must be auto, jax or warp")
    need(p.solver_iterations >= 1 and p.ls_iterations >= 1, "physics solver iterations must be >= 1")
    need(p.contacts_per_env >= 1 and p.constraints_per_env >= 1, "physics warp buffers must be >= 1")
    need(e.seconds > 0, "episode.seconds must be positive")
    for name in ("vx", "vy", "yaw"):
        lo, hi = getattr(e, name)
        need(lo <= hi, f"episode.{name} must be [low, high] with low <= high")
    need(e.pool_size >= 1, "episode.pool_size must be >= 1")
    need(e.settle_seconds > 0, "episode.settle_seconds must be positive")
    need(e.steps_per_check >= 1, "episode.steps_per_check must be >= 1")
    need(0 <= e.command_change[0] <= e.command_change[1],
         "episode.command_change must be [low, high] with 0 <= low <= high")
    need(g.bezier_order >= 2, "gait.bezier_order must be >= 2")
    need(g.step_time > 0, "gait.step_time must be positive")
    need(0 < g.min_phase < g.max_phase, "gait needs 0 < min_phase < max_phase")
    need(g.max_phase >= 1.0, "gait.max_phase must be >= 1 (a step may not time out early)")
    need(g.grf_threshold > 0, "gait.grf_threshold must be positive")
    need(g.action_scale > 0, "gait.action_scale must be positive")
    need(g.first_swing in FIRST_SWING, f"gait.first_swing must be one of {', '.join(FIRST_SWING)}")
    need(cfg.policy.hidden_layers >= 0 and cfg.policy.hidden_units >= 1, "policy size must be positive")
    r = cfg.regulators
    need(0 < r.blend_phase <= 1, "regulators.blend_phase must be in (0, 1]")
    need(r.drift_limit >= 0, "regulators.drift_limit must be >= 0")
    need(r.k_height >= 0, "regulators.k_height must be >= 0")
    need(min(r.command_rate) >= 0, "regulators.command_rate must be >= 0 (0 = no limit)")
    rw = cfg.rewards
    need(rw.rho_v > 0 and rw.epsilon > 0 and rw.rho_d > 0, "rewards.rho_v, epsilon, rho_d must be positive")
    need(rw.e_vx > 0 and rw.e_vy > 0 and rw.e_height > 0, "rewards error bands must be positive")
    need(rw.velocity_cap >= 1, "rewards.velocity_cap must be >= 1")
    need(rw.velocity_steps in (1, 2), "rewards.velocity_steps must be 1 or 2")
    need(rw.height > 0 and rw.com_radius > 0, "rewards.height and com_radius must be positive")
    need(0 <= rw.feet_min < rw.feet_max, "rewards needs 0 <= feet_min < feet_max")
    need(rw.termination_penalty >= 0, "rewards.termination_penalty must be >= 0")
    tm = cfg.termination
    need(tm.height[0] < tm.height[1], "termination.height must be [low, high]")
    need(tm.feet[0] < tm.feet[1], "termination.feet must be [low, high]")
    need(tm.max_tilt > 0 and tm.max_yaw_error > 0 and tm.max_rate > 0, "termination bounds must be positive")
    need(tm.max_speed > 0, "termination.max_speed must be positive")
    dr = cfg.randomization
    need(0 < dr.mass[0] <= dr.mass[1], "randomization.mass must be [low, high] with 0 < low <= high")
    need(0 < dr.com[0] <= dr.com[1], "randomization.com must be [low, high] with 0 < low <= high")
    need(0 <= dr.push_force[0] <= dr.push_force[1], "randomization.push_force must be [low, high] with 0 <= low <= high")
    need(dr.push_seconds > 0, "randomization.push_seconds must be positive")
    need(0 <= dr.push_after[0] <= dr.push_after[1], "randomization.push_after must be [low, high] with 0 <= low <= high")
    need(dr.push_warmup_generations >= 0, "randomization.push_warmup_generations must be >= 0")
    need(es.population > 0 and es.population % 2 == 0,
         f"es.population must be a positive even number (antithetic pairs), got {es.population}")
    need(es.sigma > 0, "es.sigma must be positive")
    need(es.learning_rate > 0, "es.learning_rate must be positive")
    need(0 < es.sigma_decay <= 1 and 0 < es.lr_decay <= 1, "es decays must be in (0, 1]")
    need(es.sigma_min > 0 and es.lr_min > 0, "es.sigma_min and es.lr_min must be positive")
    need(es.optimizer in ("adam", "sgd"), "es.optimizer must be adam or sgd")
    need(es.weight_decay >= 0, "es.weight_decay must be >= 0")
    need(t.generations >= 0, "train.generations must be >= 0")
    need(t.checkpoint_every >= 1, "train.checkpoint_every must be >= 1")
    need(t.generations_per_call >= 1, "train.generations_per_call must be >= 1")
