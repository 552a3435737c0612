"""Configuration: what a policy runs with, and what only its training uses.

`ControllerConfig` is what a shipped policy runs with: the physics it steps, its gait, the
policy network's shape and the regulator gains. `Config` adds what only training uses:
episodes, rewards, termination, randomization, the ES and the training loop. Every setting is
named by its section and field (`regulators.k_phr`, `es.sigma`) whichever half holds it.

`configs/base.yaml` holds what the robots share (the paper's tables where they apply) and
`configs/<robot>.yaml` only where that robot differs. Each section checks its own fields when it
is built, so a bad value fails where it is defined. Saved configs carry a `version`: `migrate`
turns an older one into the current form, so no field needs a default to keep old files loading.
"""

from __future__ import annotations

import dataclasses
import importlib.resources
import math
import typing
from pathlib import Path
from typing import Any

import yaml

VERSION = 7  # of the saved form (`to_dict`); `migrate` reads every earlier one
# The robot registry: name -> the module whose `DEFINITION` describes it (`robots.get`).
ROBOTS = {"cassie": "mjx_cascade.robots.cassie", "digit": "mjx_cascade.robots.digit"}
IMPLS = ("auto", "jax", "warp", "mujoco")
PAPER_DT = 0.0005  # s: the paper's 2 kHz loop; training steps at `physics.dt`, evaluation here by default
FIRST_SWING = ("random", "command", "turn")
OPTIMIZERS = ("adam", "sgd")


class ConfigError(ValueError):
    """A setting is missing, unknown or out of range. The message is one line."""


def need(ok: bool, message: str) -> None:
    """Raise ConfigError(message) unless `ok`."""
    if not ok:
        raise ConfigError(message)


def _interval(pair: tuple[float, float], name: str, floor: float | None = None, strict: bool = False) -> None:
    lo, hi = pair
    bound = "" if floor is None else f"{floor:g} {'<' if strict else '<='} "
    need(lo <= hi and (floor is None or (lo > floor if strict else lo >= floor)),
         f"{name} must be [low, high] with {bound}low <= high")


# ---------------------------------------------------------------------------------- the controller


@dataclasses.dataclass(frozen=True)
class PhysicsConfig:
    dt: float  # physics time step, s (the paper: 0.0005, the robot's 2 kHz loop)
    impl: str  # auto: warp on an NVIDIA GPU with mujoco-warp, else jax; mujoco: MuJoCo's C engine (CPUs)
    solver_iterations: int
    ls_iterations: int
    contacts_per_env: int  # warp: contact buffer per environment (only the feet collide)
    constraints_per_env: int  # warp: njmax

    def __post_init__(self) -> None:
        need(self.dt > 0, "physics.dt must be positive")
        need(self.dt <= 0.005, "physics.dt must be at most 0.005 s (the model's springs need small steps)")
        need(self.impl in IMPLS, f"physics.impl must be one of {', '.join(IMPLS)}")
        need(min(self.solver_iterations, self.ls_iterations) >= 1, "physics solver iterations must be >= 1")
        need(min(self.contacts_per_env, self.constraints_per_env) >= 1, "physics warp buffers must be >= 1")


@dataclasses.dataclass(frozen=True)
class GaitConfig:
    bezier_order: int  # M, eq. 11
    step_time: float  # T_step, s
    min_phase: float  # a swing-foot touchdown ends the step only after this phase
    max_phase: float  # time-out: the step ends here whatever the contact force
    grf_threshold: float  # N, swing-foot normal force that counts as touchdown
    action_scale: float  # scales every learned joint's range about its middle
    first_swing: str  # which foot lifts first from standing: random (a coin), command (vy's side) or turn
                     # (away from the turn; controller.first_stance)

    def __post_init__(self) -> None:
        need(self.bezier_order >= 2, "gait.bezier_order must be >= 2")
        need(self.step_time > 0, "gait.step_time must be positive")
        need(0 < self.min_phase < self.max_phase, "gait needs 0 < min_phase < max_phase")
        need(self.max_phase >= 1.0, "gait.max_phase must be >= 1 (a step may not time out early)")
        need(self.grf_threshold > 0, "gait.grf_threshold must be positive")
        need(self.action_scale > 0, "gait.action_scale must be positive")
        need(self.first_swing in FIRST_SWING, f"gait.first_swing must be one of {', '.join(FIRST_SWING)}")


@dataclasses.dataclass(frozen=True)
class PolicyConfig:
    hidden_layers: int
    hidden_units: int

    def __post_init__(self) -> None:
        need(self.hidden_layers >= 0 and self.hidden_units >= 1, "policy size must be positive")


@dataclasses.dataclass(frozen=True)
class RegulatorConfig:
    """Sec. IV gains (Table 7 for the torso and swing-leg terms) and the regulations added to them."""

    k_phr: float  # swing hip roll, P on (v_y - v_y^d)
    k_dhr: float  # swing hip roll, on (v_y - v_y^ls)
    k_php: float  # swing hip pitch, P on (v_x - v_x^d)
    backstep_limit: float  # rad: bound on that P term where it steps the foot back (v_x < v_x^d); 0: none
    k_dhp: float  # swing hip pitch, on (v_x - v_x^ls)
    k_neutral_x: float  # fraction of Raibert's neutral point v T / 2 added forward (regulators.neutral_point)
    k_neutral_y: float  # and sideways
    neutral_vx_max: float  # m/s: forward velocity beyond which the neutral point holds (regulators.neutral_point); 0: none
    k_ptp: float  # stance toe pitch (eq. 24 row 6)
    k_ptr: float  # stance toe roll (eq. 24 row 7)
    k_heading: float  # swing hip yaw per rad of heading error, eq. 24 row 3
    k_p_roll: float  # torso roll PD torque, Sec. IV-B
    k_d_roll: float
    k_p_pitch: float  # torso pitch PD torque
    k_d_pitch: float
    blend_phase: float  # swing compensations ramp in over tau in [0, blend_phase]
    k_i_drift: float  # PI drift term beta_x: rad per (m/s) per step
    k_i_drift_y: float  # beta_y
    drift_limit: float  # |beta| bound, rad
    height: float  # desired pelvis height q_z^d, m: the height regulation's target and Table 4's
    k_height: float  # stance knee extension per m of pelvis below `height` over the ground under it
                     # (regulators.height_fix, regulators.ground_rise); 0: none
    # how fast the followed command moves towards the given one (regulators.rate_limit):
    # [m/s^2 for vx and vy, rad/s for the heading]; 0 follows at once
    command_rate: tuple[float, float]
    # from standing, the followed command starts at rest (zero velocity, the present heading) and
    # ramps to the first one at `command_rate` (Controller.reset); false: it starts at the first one
    start_from_rest: bool

    def __post_init__(self) -> None:
        need(0 < self.blend_phase <= 1, "regulators.blend_phase must be in (0, 1]")
        need(self.drift_limit >= 0, "regulators.drift_limit must be >= 0")
        need(self.height > 0, "regulators.height must be positive")
        need(self.k_height >= 0, "regulators.k_height must be >= 0")
        need(self.backstep_limit >= 0, "regulators.backstep_limit must be >= 0")
        need(self.neutral_vx_max >= 0, "regulators.neutral_vx_max must be >= 0 (0 = no bound)")
        need(min(self.command_rate) >= 0, "regulators.command_rate must be >= 0 (0 = no limit)")


@dataclasses.dataclass(frozen=True)
class ControllerConfig:
    """What a policy runs with: a shipped policy carries it beside its parameters."""

    robot: str
    physics: PhysicsConfig
    gait: GaitConfig
    policy: PolicyConfig
    regulators: RegulatorConfig

    def __post_init__(self) -> None:
        need(self.robot in ROBOTS, f"unknown robot {self.robot!r}; choose from {', '.join(ROBOTS)}")

    def override(self, **overrides: Any) -> Any:
        """A checked copy with dotted-key overrides: `cfg.override(**{"regulators.k_phr": 0.4})`."""
        return apply_overrides(self, overrides)


# ---------------------------------------------------------------------------------- training only


@dataclasses.dataclass(frozen=True)
class EpisodeConfig:
    seconds: float
    vx: tuple[float, float]  # commanded velocities, heading frame, m/s, drawn uniformly
    vy: tuple[float, float]
    yaw: tuple[float, float]  # desired heading relative to the start, rad
    pool_size: int  # balanced initial states from the standing controller
    settle_seconds: float
    steps_per_check: int  # physics steps between checks that every episode has ended
    # a second command, drawn like the first, takes over at U(command_change) s; [0, 0]: one command
    command_change: tuple[float, float]

    def __post_init__(self) -> None:
        need(self.seconds > 0, "episode.seconds must be positive")
        for name in ("vx", "vy", "yaw"):
            _interval(getattr(self, name), f"episode.{name}")
        need(self.pool_size >= 1, "episode.pool_size must be >= 1")
        need(self.settle_seconds > 0, "episode.settle_seconds must be positive")
        need(self.steps_per_check >= 1, "episode.steps_per_check must be >= 1")
        _interval(self.command_change, "episode.command_change", floor=0.0)


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
    """Table 4 constants; q_z^d is `regulators.height`."""

    rho_v: float
    epsilon: float
    e_vx: float
    e_vy: float
    velocity_cap: float  # bound of the in-band velocity reward (rewards.velocity)
    velocity_steps: int  # walking steps whose average r_vx, r_vy judge: 1 (the last) or 2 (a stride)
    e_height: float
    rho_d: float
    com_radius: float  # d in Table 4: radius of the admissible CoM region P
    feet_min: float
    feet_max: float
    termination_penalty: float  # per second of the episode lost to early termination
    weights: RewardWeights

    def __post_init__(self) -> None:
        need(self.rho_v > 0 and self.epsilon > 0 and self.rho_d > 0, "rewards.rho_v, epsilon, rho_d must be positive")
        need(self.e_vx > 0 and self.e_vy > 0 and self.e_height > 0, "rewards error bands must be positive")
        need(self.velocity_cap >= 1, "rewards.velocity_cap must be >= 1")
        need(self.velocity_steps in (1, 2), "rewards.velocity_steps must be 1 or 2")
        need(self.com_radius > 0, "rewards.com_radius must be positive")
        need(0 <= self.feet_min < self.feet_max, "rewards needs 0 <= feet_min < feet_max")
        need(self.termination_penalty >= 0, "rewards.termination_penalty must be >= 0")


@dataclasses.dataclass(frozen=True)
class TerminationConfig:
    """Eq. 27."""

    max_tilt: float  # |roll|, |pitch|, rad
    max_yaw_error: float  # |yaw - yaw^d|, rad
    max_rate: float  # |angular velocity| per axis, rad/s
    height: tuple[float, float]  # pelvis height above the ground, m
    feet: tuple[float, float]  # lateral distance between the feet, m
    max_speed: float  # any |qvel| beyond this is diverged physics

    def __post_init__(self) -> None:
        need(self.height[0] < self.height[1], "termination.height must be [low, high]")
        need(self.feet[0] < self.feet[1], "termination.feet must be [low, high]")
        need(min(self.max_tilt, self.max_yaw_error, self.max_rate) > 0, "termination bounds must be positive")
        need(self.max_speed > 0, "termination.max_speed must be positive")


@dataclasses.dataclass(frozen=True)
class RandomizationConfig:
    """Table 5, drawn once per episode, and one push per episode (not in the paper)."""

    enabled: bool
    mass: tuple[float, float]
    com: tuple[float, float]
    # a horizontal push on the pelvis: U(push_force) N in a uniformly random direction for
    # push_seconds, from U(push_after) s; [0, 0] pushes nothing
    push_force: tuple[float, float]
    push_seconds: float
    push_after: tuple[float, float]
    push_warmup_generations: int  # a curriculum: the first generations train without pushes

    def __post_init__(self) -> None:
        _interval(self.mass, "randomization.mass", floor=0.0, strict=True)
        _interval(self.com, "randomization.com", floor=0.0, strict=True)
        _interval(self.push_force, "randomization.push_force", floor=0.0)
        need(self.push_seconds > 0, "randomization.push_seconds must be positive")
        _interval(self.push_after, "randomization.push_after", floor=0.0)
        need(self.push_warmup_generations >= 0, "randomization.push_warmup_generations must be >= 0")


@dataclasses.dataclass(frozen=True)
class ESConfig:
    """Table 3: sigma and the learning rate decay geometrically to their floors (es.schedule)."""

    population: int  # members, antithetic pairs: must be even
    sigma: float
    sigma_decay: float
    sigma_min: float
    learning_rate: float
    lr_decay: float
    lr_min: float
    optimizer: str  # adam | sgd
    weight_decay: float  # L2 on the parameters, added to the ES gradient

    def __post_init__(self) -> None:
        need(self.population > 0 and self.population % 2 == 0,
             f"es.population must be a positive even number (antithetic pairs), got {self.population}")
        need(self.sigma > 0, "es.sigma must be positive")
        need(self.learning_rate > 0, "es.learning_rate must be positive")
        need(0 < self.sigma_decay <= 1 and 0 < self.lr_decay <= 1, "es decays must be in (0, 1]")
        need(self.sigma_min > 0 and self.lr_min > 0, "es.sigma_min and es.lr_min must be positive")
        need(self.optimizer in OPTIMIZERS, f"es.optimizer must be one of {', '.join(OPTIMIZERS)}")
        need(self.weight_decay >= 0, "es.weight_decay must be >= 0")


@dataclasses.dataclass(frozen=True)
class TrainConfig:
    generations: int
    checkpoint_every: int
    generations_per_call: int  # generations per jitted call (one lax.scan)
    eval_every: int  # generations between checks of the ES mean on the validation profiles; 0: none

    def __post_init__(self) -> None:
        need(self.generations >= 0, "train.generations must be >= 0")
        need(self.checkpoint_every >= 1, "train.checkpoint_every must be >= 1")
        need(self.generations_per_call >= 1, "train.generations_per_call must be >= 1")
        need(self.eval_every >= 0, "train.eval_every must be >= 0 (0: no checks)")


@dataclasses.dataclass(frozen=True)
class Config(ControllerConfig):
    """A training run: the controller it trains, and what only training uses."""

    seed: int
    episode: EpisodeConfig
    rewards: RewardConfig
    termination: TerminationConfig
    randomization: RandomizationConfig
    es: ESConfig
    train: TrainConfig

    @property
    def controller(self) -> ControllerConfig:
        return ControllerConfig(**{f.name: getattr(self, f.name) for f in dataclasses.fields(ControllerConfig)})


CONTROLLER_SECTIONS = tuple(f.name for f in dataclasses.fields(ControllerConfig) if f.name != "robot")
# what a trained policy's parameters fix: the network's shape
SHAPE_SETTINGS = ("gait.bezier_order", "policy.hidden_layers", "policy.hidden_units")


def check_controller_settings(settings: dict) -> None:
    """Refuse changes to a trained policy outside its controller, or to its network's shape."""
    for key in settings:
        need(key.split(".")[0] in CONTROLLER_SECTIONS and key not in SHAPE_SETTINGS,
             f"a trained policy's settings can change only in {', '.join(s + '.*' for s in CONTROLLER_SECTIONS)} "
             f"(not {', '.join(SHAPE_SETTINGS)}), got {key!r}")


def get(cfg: Any, key: str) -> Any:
    """The value of dotted `key` in `cfg` (tuples as lists, as saved)."""
    for part in key.split("."):
        cfg = getattr(cfg, part)
    return list(cfg) if isinstance(cfg, tuple) else cfg


# ---------------------------------------------------------------------------------- reading and writing


def to_dict(cfg: Any) -> dict:
    """Plain nested dict (tuples as lists) with the format `version`, for YAML, JSON and checkpoints."""

    def plain(x: Any) -> Any:
        if dataclasses.is_dataclass(x):
            return {f.name: plain(getattr(x, f.name)) for f in dataclasses.fields(x)}
        return [plain(v) for v in x] if isinstance(x, tuple) else x

    return {"version": VERSION, **plain(cfg)}


def from_dict(data: dict, cls: type = Config) -> Any:
    """A complete config (every key present, none unknown) from a saved one of any version."""
    return _build(cls, migrate(data), "")


def robot_config(robot: str) -> Config:
    """The shipped config of a robot: `configs/base.yaml` overridden by `configs/<robot>.yaml`."""
    need(robot in ROBOTS, f"unknown robot {robot!r}; choose from {', '.join(ROBOTS)}")
    files = importlib.resources.files("mjx_cascade.configs")
    data = _deep_merge(yaml.safe_load(files.joinpath("base.yaml").read_text()),
                       yaml.safe_load(files.joinpath(f"{robot}.yaml").read_text()))
    return _build(Config, {"robot": robot, **data}, "")


def load(path: str | Path) -> Config:
    """A user config file: its `robot` picks the shipped config, its other keys override it."""
    path = Path(path)
    need(path.is_file(), f"config file not found: {path}")
    try:
        data = yaml.safe_load(path.read_text()) or {}
    except yaml.YAMLError as e:
        raise ConfigError(f"config file {path} is not valid YAML: {str(e).splitlines()[0]}") from None
    need(isinstance(data, dict), f"config file {path} must hold a mapping of sections")
    return _merge(robot_config(str(data.get("robot", "cassie"))), data, "")


def parse_assignments(items: list[str]) -> dict[str, str]:
    """`["a.b=1", ...]` (the command lines' `--set`) -> `{"a.b": "1"}`, values parsed later."""
    out = {}
    for item in items:
        key, sep, value = item.partition("=")
        need(bool(sep), f"--set needs KEY=VALUE, got {item!r}")
        out[key.strip()] = value
    return out


def apply_overrides(cfg: Any, overrides: dict[str, Any]) -> Any:
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
            need(isinstance(node, dict), f"config key {key!r} does not name a setting")
        node[parts[-1]] = value
    return _merge(cfg, nested, "")


def differences(a: Any, b: Any) -> list[str]:
    """Dotted keys whose values differ between two configs of one class, in field order."""
    flat_a, flat_b = _flatten(to_dict(a)), _flatten(to_dict(b))
    return [k for k in flat_a if flat_a[k] != flat_b.get(k)]


def _flatten(data: dict, prefix: str = "") -> dict:
    out = {}
    for key, value in data.items():
        if isinstance(value, dict):
            out.update(_flatten(value, f"{prefix}{key}."))
        else:
            out[f"{prefix}{key}"] = value
    return out


def _deep_merge(base: dict, top: dict) -> dict:
    out = dict(base)
    for key, value in (top or {}).items():
        out[key] = _deep_merge(out[key], value) if isinstance(value, dict) and isinstance(out.get(key), dict) else value
    return out


# ---------------------------------------------------------------------------------- saved versions


# Settings added in version 1's lifetime, with the value a saved config without them meant.
_V1_DEFAULTS = {
    "episode": {"command_change": [0.0, 0.0]},
    "gait": {"first_swing": "random"},
    "regulators": {"k_height": 0.0, "k_i_drift_y": 0.05, "command_rate": [0.0, 0.0]},
    "rewards": {"velocity_steps": 1},
    "randomization": {"push_force": [0.0, 0.0], "push_seconds": 0.2, "push_after": [1.0, 3.0],
                      "push_warmup_generations": 0},
}


# Settings added after version 2, with the value a saved config without them meant.
_V2_DEFAULTS = {"train": {"eval_every": 0}}

# Settings added after version 4, with the value a saved config without them meant.
_V4_DEFAULTS = {"regulators": {"start_from_rest": False}}

# Settings added after version 5, with the value a saved config without them meant.
_V5_DEFAULTS = {"regulators": {"backstep_limit": 0.0}}

# Settings added after version 6, with the value a saved config without them meant.
_V6_DEFAULTS = {"regulators": {"neutral_vx_max": 0.0}}


def migrate(data: dict) -> dict:
    """A saved config of any version, in the current form (without its `version`).

    Version 1 (no `version` key) left out the settings added after a run was saved, meaning the
    behaviour before them (`_V1_DEFAULTS`); it held the desired pelvis height in `rewards.height`
    and had `regulators.slope_estimation`, which was always on. Versions 1 and 2 have no
    validation checks during training (`_V2_DEFAULTS`), and may hold `regulators.height_over_slope`:
    the height regulation now always measures over the ground under the pelvis, so a config that
    measured over the stance foot with the regulation on is no longer supported. Versions 1 to 3
    may hold `policy.mirror_lateral` (version 1 without it meant false): right-stance steps now
    always see the state mirrored, so a config that did not mirror it is no longer supported.
    Versions 1 to 4 started the followed command at the first one (`_V4_DEFAULTS`). Versions 1
    to 5 did not bound the backward swing placement (`_V5_DEFAULTS`), and versions 1 to 6 the
    forward velocity the neutral point grows with (`_V6_DEFAULTS`).
    """
    need(isinstance(data, dict), "a saved config must be a mapping")
    data = {k: (dict(v) if isinstance(v, dict) else v) for k, v in data.items()}
    version = data.pop("version", 1)
    need(version in (1, 2, 3, 4, 5, 6, VERSION), f"config version {version!r} is newer than this mjx_cascade reads ({VERSION})")
    if version == 1:
        _fill_defaults(data, _V1_DEFAULTS)
        need(data["regulators"].pop("slope_estimation", True) is True,
             "a saved config with regulators.slope_estimation false is no longer supported")
        data["regulators"]["height"] = data["rewards"].pop("height")
    if version < 3:
        _fill_defaults(data, _V2_DEFAULTS)
        over_slope = data["regulators"].pop("height_over_slope", False)
        need(over_slope or data["regulators"].get("k_height", 0.0) == 0.0,
             "a saved config with regulators.height_over_slope false and k_height > 0 is no longer supported")
    if version < 4:
        need(data.get("policy", {}).pop("mirror_lateral", version > 1) is True,
             "a saved config with policy.mirror_lateral false (right-stance steps seeing the state unmirrored) "
             "is no longer supported")
    if version < 5:
        _fill_defaults(data, _V4_DEFAULTS)
    if version < 6:
        _fill_defaults(data, _V5_DEFAULTS)
    if version < 7:
        _fill_defaults(data, _V6_DEFAULTS)
    return data


def _fill_defaults(data: dict, defaults: dict) -> None:
    """Add each section's settings of `defaults` that the saved `data` lacks."""
    for section, values in defaults.items():
        data[section] = {**values, **data.get(section, {})}


# ---------------------------------------------------------------------------------- typed building


def _fields(cls: type, data: Any, prefix: str, complete: bool) -> dict:
    """`{field: type}` of `cls` after checking `data`'s keys (all of them present if `complete`)."""
    need(isinstance(data, dict), f"{prefix.rstrip('.') or 'config'} must be a mapping")
    names = [f.name for f in dataclasses.fields(cls)]
    for key in data:
        if key not in names:
            close = [n for n in names if n[:3] == str(key)[:3]]
            hint = f" (did you mean {prefix}{close[0]}?)" if close else ""
            raise ConfigError(f"unknown config key '{prefix}{key}'{hint}")
    missing = [n for n in names if complete and n not in data]
    need(not missing, f"config key '{prefix}{missing[0] if missing else ''}' is missing")
    return typing.get_type_hints(cls)


def _build(cls: type, data: Any, prefix: str) -> Any:
    hints = _fields(cls, data, prefix, complete=True)
    return cls(**{key: _value(hints[key], value, f"{prefix}{key}", None) for key, value in data.items()})


def _merge(obj: Any, data: Any, prefix: str) -> Any:
    hints = _fields(type(obj), data, prefix, complete=False)
    changes = {key: _value(hints[key], value, f"{prefix}{key}", getattr(obj, key)) for key, value in data.items()}
    return dataclasses.replace(obj, **changes)


def _value(hint: Any, value: Any, name: str, current: Any) -> Any:
    """`value` as a `hint`: a section built (or merged into `current`) or a coerced scalar."""
    if dataclasses.is_dataclass(hint):
        return _build(hint, value, f"{name}.") if current is None else _merge(current, value, f"{name}.")
    return _coerce(value, hint, name)


def _coerce(value: Any, hint: Any, name: str) -> Any:
    if typing.get_origin(hint) is tuple:
        kinds = typing.get_args(hint)
        need(isinstance(value, (list, tuple)) and len(value) == len(kinds), f"{name} must be a list of {len(kinds)} numbers")
        return tuple(_coerce(v, k, name) for v, k in zip(value, kinds))
    if hint is bool:
        need(isinstance(value, bool), f"{name} must be true or false")
    elif hint is int:
        need(isinstance(value, int) and not isinstance(value, bool), f"{name} must be an integer")
    elif hint is str:
        need(isinstance(value, str), f"{name} must be a string")
    elif hint is float:
        if isinstance(value, str):
            try:
                value = float(value)
            except ValueError:
                raise ConfigError(f"{name} must be a number") from None
        ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
        need(ok, f"{name} must be a finite number")
        return float(value)
    else:
        raise ConfigError(f"{name}: unsupported setting type {hint}")
    return value
