"""The cascade-controlled robot as a pure environment over `mjx.Data`.

`reset` stands the robot in a balanced pose; `step` runs one control tick (`controller`), advances
MJX by one physics step and reports the step's reward terms (eq. 13-19), early termination
(eq. 27) and diverged physics. Keeping an episode's books (what is still live, returns, the
termination penalty) is the rollout's (`rollout.Books`). Both are pure functions of arrays: batch
them with `jax.vmap`. The model is an argument so that each environment can have its own
(terrain, domain randomization); `data` templates come from `data_template`, sized for a batch.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from flax import struct
from jax import Array

from mjx_cascade import features, pd, regulators, rewards, robots, standing
from mjx_cascade.config import Config
from mjx_cascade.controller import Controller, ControllerState, Policy
from mjx_cascade.observe import Obs, ground_height, observe
from mjx_cascade.physics import make_data, mjx, put_model, resolve_impl, stepper
from mjx_cascade.robots import scene
from mjx_cascade.robots.base import Robot


class EnvState(struct.PyTreeNode):
    data: mjx.Data
    ctrl: ControllerState


class StepReport(NamedTuple):
    """What one physics step reports."""

    terms: Array  # [9] the unweighted rewards of eq. 13 (`rewards.TERMS`), of the state before the step
    terminated: Array  # eq. 27 ended the episode (diverged physics too)
    diverged: Array  # the physics blew up: this step's terms are not to be counted
    switched: Array  # a walking step ended: the stance switched


class Env:
    """A robot's cascade controller, querying `policy`, under a training config, over its compiled
    MJX model; `pool` holds the balanced standing states (`standing.balanced_pool`)."""

    def __init__(self, robot: Robot, cfg: Config, pool: tuple[np.ndarray, np.ndarray], policy: Policy):
        self.robot, self.cfg = robot, cfg
        self.controller = Controller(robot, cfg, float(robot.model.opt.timestep), policy, foot_rest(robot, pool[0]))
        self.height_field = scene.height_field(robot.model)  # None on a plane
        self.impl = resolve_impl(cfg.physics.impl)
        self.model = put_model(robot.model, self.impl)
        self.physics_step = stepper(robot.model, self.impl)
        self.pool_qpos = jnp.asarray(pool[0], dtype=jnp.float32)
        self.pool_qvel = jnp.asarray(pool[1], dtype=jnp.float32)
        self.dt = float(robot.model.opt.timestep)
        self.weights = rewards.weights(cfg.rewards)

    def data_template(self, batch: int) -> mjx.Data:
        """An unbatched `mjx.Data` for a batch of `batch` environments (warp sizes its buffers for them)."""
        return make_data(self.robot.model, self.impl, self.cfg.physics, batch)

    def observe(self, data: mjx.Data, model: mjx.Model | None = None) -> Obs:
        """The controller's measurements; `model` (default `self.model`) holds the terrain."""
        return observe(self.robot, self.height_field, data, self.model if model is None else model)

    def ground(self, data: mjx.Data, model: mjx.Model | None = None) -> Array:
        """The terrain height under the pelvis."""
        return ground_height(self.height_field, self.model if model is None else model, data.qpos[:3])

    def reset(self, params: Array, key: Array, cmd: Array, model: mjx.Model | None = None,
              data: mjx.Data | None = None) -> EnvState:
        """Start standing, from a random member of the balanced pool, under command `cmd` [vx, vy, yaw];
        `data` is the template (default: one environment's)."""
        model = self.model if model is None else model
        data = self.data_template(1) if data is None else data
        i, k_side = start_draw(key, self.pool_qpos.shape[0])
        data = mjx.forward(model, data.replace(qpos=self.pool_qpos[i], qvel=self.pool_qvel[i]))
        ctrl = self.controller.reset(params, k_side, self.observe(data, model), data.time, cmd)
        return EnvState(data=data, ctrl=ctrl)

    def step(self, params: Array, state: EnvState, cmd: Array, force: Array | None = None,
             model: mjx.Model | None = None, live: Array | None = None) -> tuple[EnvState, StepReport]:
        """One physics step under the cascade controller; `force` [3] pushes the pelvis (world frame).
        `live` false: nothing reads the next state (the episode is done), which the physics may
        then skip (`physics.stepper`)."""
        r, cfg = self.robot, self.cfg
        model = self.model if model is None else model
        obs = self.observe(state.data, model)
        u, switched, ctrl = self.controller.tick(params, state.ctrl, obs, state.data.time, cmd)
        data = state.data.replace(ctrl=state.data.ctrl.at[r.actuator].set(pd.motor_command(u, r.gear, r.ctrl_low, r.ctrl_high)))
        if force is not None:
            data = data.replace(xfrc_applied=data.xfrc_applied.at[r.pelvis_body, :3].set(force))
        data = self.physics_step(model, data, live)
        # scored against the command followed, which is all the controller is asked to do
        x = self.reward_inputs(obs, ctrl, u)
        terms = rewards.terms(x, cfg.rewards, cfg.regulators.height)
        # a non-finite score means this step started from diverged physics: never count it
        diverged = rewards.diverged(data.qpos, data.qvel, cfg.termination) | ~jnp.all(jnp.isfinite(terms))
        terminated = rewards.terminated(x, cfg.termination) | diverged
        return EnvState(data=data, ctrl=ctrl), StepReport(terms, terminated, diverged, switched)

    def reward_inputs(self, obs: Obs, c: ControllerState, u: Array) -> rewards.RewardInputs:
        r, cmd = self.robot, c.cmd
        feet_h = features.to_heading_frame(obs.feet[0, :2] - obs.feet[1, :2], obs.rpy[2])
        # a stride's average cancels the sideways sway, which alternates sign from step to step
        v = c.v_avg if self.cfg.rewards.velocity_steps == 1 else 0.5 * (c.v_avg + c.v_prev)
        return rewards.RewardInputs(
            v_error=v - cmd[:2],
            height=obs.pos[2] - obs.ground,
            u_normalized=(u / r.torque_limit).ravel(),
            com_distance=jnp.linalg.norm(obs.com[:2] - obs.feet[:, :2].mean(axis=0)),
            rpy_error=jnp.stack([obs.rpy[0], obs.rpy[1], regulators.wrap_angle(obs.rpy[2] - cmd[2])]),
            omega=obs.omega,
            feet_distance=jnp.abs(feet_h[1]),
            stance_v=obs.foot_v[c.stance],
            stance_w=obs.foot_w[c.stance],
        )


def start_draw(key: Array, pool_size: int) -> tuple[Array, Array]:
    """`(pool index, first-swing key)` of an episode started with `key`: every simulator of the
    controller (MJX here, MuJoCo C in `runtime`) starts from the same draw."""
    k_pool, k_side = jax.random.split(key)
    return jax.random.randint(k_pool, (), 0, pool_size), k_side


def foot_rest(robot: Robot, qpos: np.ndarray) -> float:
    """Height of the foot bodies' origins above level ground in the balanced standing states."""
    d = mujoco.MjData(robot.model)
    heights = []
    for q in qpos:
        d.qpos[:] = q
        mujoco.mj_kinematics(robot.model, d)
        heights.append(d.xpos[robot.foot_body, 2])
    return float(np.mean(heights))


def make_env(cfg: Config, policy: Policy, model_path: str | None = None,
             terrain: dict | list[dict] | None = None) -> Env:
    """The robot for `cfg` (on a terrain, or one height field for several: `scene.compile_model`),
    its balanced initial states, its controller querying `policy`, and the environment."""
    robot = robots.build(robots.get(cfg.robot), cfg.physics, model_path, terrain)
    return Env(robot, cfg, standing.balanced_pool(robot, cfg, seed=cfg.seed), policy)
