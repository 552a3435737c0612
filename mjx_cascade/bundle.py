"""A trained policy as a self-contained bundle: what runs the controller outside the trainer.

    DIR/contract.json  everything the controller needs, as plain JSON (`docs/bundle.md`)
    DIR/weights.npz    the network's layers as plain arrays, `layer{i}.kernel` [in, out] and
                       `layer{i}.bias` [out] (ReLU between them, a sigmoid after the last), and
                       `params`, the flat vector ES trained, bit for bit

The contract states the robot's and model's identity, the joint and actuator names, the learned
joints with their coefficient ranges, the Bezier order, step time and switching thresholds, the
regulator and PD gains, every sign the regulators use (derived from the model: `robots.base`),
the feature definition, the command rate limit, the time steps it trained and runs at (`eval`'s
and `sim2sim`'s default, the paper's 2 kHz loop), and the complete config the
controller runs with (`config`), from which this package rebuilds it. `load` refuses a bundle
whose derived facts differ from the model it is given: the signs and gains are the contract.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import mujoco
import numpy as np

from mjx_cascade import checkpoint, policies, robots
from mjx_cascade.config import PAPER_DT, ConfigError, from_dict, need, to_dict
from mjx_cascade.robots.base import Robot

FORMAT, VERSION = "mjx_cascade.bundle", 1
CONTRACT, WEIGHTS = "contract.json", "weights.npz"
FEATURES = ("vx_desired", "vy_desired", "vx_step_average", "vy_step_average",
            "vx_step_average - vx_desired", "vy_step_average - vy_desired")
TOLERANCE = 1e-6  # relative and absolute, for facts re-derived from the model (float64 arithmetic)


def is_bundle(path: str | Path) -> bool:
    return (Path(path) / CONTRACT).is_file() and (Path(path) / WEIGHTS).is_file()


def layers(params: np.ndarray, hidden_layers: int, hidden_units: int, actions: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """`[(kernel [in, out], bias [out]), ...]` of the flat parameter vector, in flax's order
    (`jax.flatten_util.ravel_pytree` of `{"params": {"Dense_i": {"bias", "kernel"}}}`)."""
    sizes = [len(FEATURES)] + [hidden_units] * hidden_layers + [actions]
    blocks, at = {}, 0
    for i in sorted(range(len(sizes) - 1), key=lambda i: f"Dense_{i}"):  # the flat vector's key order
        n_in, n_out = sizes[i], sizes[i + 1]
        bias, at = params[at:at + n_out], at + n_out
        kernel, at = params[at:at + n_in * n_out].reshape(n_in, n_out), at + n_in * n_out
        blocks[i] = (kernel, bias)
    need(at == params.shape[0], f"the policy has {params.shape[0]} parameters, its network {at}")
    return [blocks[i] for i in range(len(sizes) - 1)]


def actions(net: list[tuple[np.ndarray, np.ndarray]], s: np.ndarray) -> np.ndarray:
    """The network in NumPy: actions in (0, 1) for features `s` [..., 6]."""
    x = np.asarray(s, np.float64)
    for kernel, bias in net[:-1]:
        x = np.maximum(x @ kernel + bias, 0.0)
    kernel, bias = net[-1]
    return 1.0 / (1.0 + np.exp(-(x @ kernel + bias)))


def robot_facts(robot: Robot) -> dict:
    """Everything the controller reads of the robot, derived from its model (`robots.base.Robot`)."""
    plain = lambda v: v.tolist() if isinstance(v, np.ndarray) else v  # noqa: E731
    facts = {f.name: plain(getattr(robot, f.name)) for f in dataclasses.fields(robot)
             if f.name not in ("definition", "model")}
    d = robot.definition
    return {"joints": list(d.joints), "motors": [list(m) for m in d.motors], "toe_joints": list(d.toe_joints),
            "learned": [f"{role}_{joint}" for role, joint in d.learned], "pelvis": d.pelvis, "feet": list(d.feet),
            "derived": facts}


def model_identity(model: mujoco.MjModel) -> dict:
    return {"nq": model.nq, "nv": model.nv, "nu": model.nu, "nbody": model.nbody, "timestep": model.opt.timestep,
            "total_mass": float(np.sum(model.body_mass)),
            "actuators": [model.actuator(i).name for i in range(model.nu)]}


def write(found: policies.Policy, robot: Robot, foot_rest: float, dest: str | Path) -> Path:
    """Write `found` (a policy with the config it runs with) for `robot` as a bundle in `dest`."""
    cfg, dest = found.config, Path(dest)
    n_actions = found.record["action_dim"]
    net = layers(found.params, cfg.policy.hidden_layers, cfg.policy.hidden_units, n_actions)
    dest.mkdir(parents=True, exist_ok=True)
    arrays = {f"layer{i}.{part}": a for i, layer in enumerate(net) for part, a in zip(("kernel", "bias"), layer)}
    np.savez(dest / WEIGHTS, params=found.params.astype(np.float32), **arrays)
    contract = {
        "format": FORMAT, "version": VERSION, "robot": cfg.robot, "model": model_identity(robot.model),
        "policy": {"features": list(FEATURES), "mirror_lateral": True,
                   "layers": [[int(k.shape[0]), int(k.shape[1])] for k, _ in net], "hidden": "relu",
                   "output": "sigmoid", "params": int(found.params.shape[0]),
                   "params_sha256": checkpoint.params_sha256(found.params)},
        "gait": _section(cfg.gait) | {"learned_low": robot.learned_low.tolist(), "learned_high": robot.learned_high.tolist()},
        "regulators": _section(cfg.regulators),
        "pd": {"kp": robot.kp.tolist(), "kd": robot.kd.tolist(), "gear": robot.gear.tolist(),
               "ctrl_low": robot.ctrl_low.tolist(), "ctrl_high": robot.ctrl_high.tolist()},
        "timestep": {"trained": cfg.physics.dt, "runs": PAPER_DT}, "foot_rest": foot_rest, "robot_facts": robot_facts(robot),
        "training": {"generation": found.generation, "revisions": found.revisions,
                     "record": {k: v for k, v in found.record.items() if k != "config"}},
        "config": to_dict(cfg),
    }
    (dest / CONTRACT).write_text(json.dumps(contract, indent=1) + "\n")
    return dest


def _section(section) -> dict:
    return {k: v for k, v in to_dict(section).items() if k != "version"}


def load(path: str | Path) -> policies.Policy:
    """The policy in a bundle, with the config it runs with (`contract["config"]`)."""
    path = Path(path)
    try:
        contract = json.loads((path / CONTRACT).read_text())
        with np.load(path / WEIGHTS) as f:
            params = np.asarray(f["params"], np.float32)
    except (OSError, ValueError, KeyError) as e:
        raise ConfigError(f"{path} holds no readable bundle ({type(e).__name__})") from None
    need(contract.get("format") == FORMAT, f"{path} is not an mjx_cascade bundle")
    need(contract.get("version") == VERSION, f"{path}: bundle version {contract.get('version')}, this "
         f"package reads {VERSION}")
    need(checkpoint.params_sha256(params) == contract["policy"]["params_sha256"],
         f"{path}: weights.npz does not hold the parameters the contract names")
    record = {**contract["training"]["record"], "config": contract["config"]}
    return policies.Policy(params, record, contract["training"]["revisions"], from_dict(contract["config"]))


def check(path: str | Path, robot: Robot) -> None:
    """Refuse to run the bundle in `path` on `robot` when the facts derived from its model differ
    from the contract's: the regulators' signs and the PD gains would not be the ones it was
    trained with."""
    contract = json.loads((Path(path) / CONTRACT).read_text())
    expected, actual = contract["robot_facts"], robot_facts(robot)
    for key in expected:
        if key == "derived":
            continue
        need(expected[key] == actual[key], f"{path}: the model's {key} differ from the bundle's")
    for key, value in expected["derived"].items():
        a, b = np.asarray(value, np.float64), np.asarray(actual["derived"][key], np.float64)
        need(a.shape == b.shape and np.allclose(a, b, rtol=TOLERANCE, atol=TOLERANCE),
             f"{path}: the model's {key} differ from the bundle's (another model file?)")


def export(source: str, dest: str | Path, model_path: str | None = None) -> Path:
    """Write the policy `source` (a robot's name for its shipped policy, a policy directory or a
    run's checkpoint) as a bundle in `dest`."""
    from mjx_cascade import env, standing

    found = policies.load(source)
    # the model and standing states it runs with (`timestep.runs`), as `sim2sim` and `play` build them
    runs = found.config.override(**{"physics.dt": PAPER_DT})
    robot = robots.build(robots.get(runs.robot), runs.physics, model_path)
    pool = standing.balanced_pool(robot, runs, seed=runs.seed)
    return write(found, robot, env.foot_rest(robot, pool[0]), dest)
