"""The cascade-controlled robot as a pure environment over `mjx.Data` (Fig. 2 and 3).

Every physics step: measure the state, end the walking step on touchdown or time-out (and
then query the policy once for the next step's Bezier coefficients), evaluate the learned
trajectories, add the regulators' compensations (eq. 20, 22-26), track with joint PD (eq.
21) plus the torso torques (Sec. IV-B), advance MJX, and score the state (eq. 13-19, 27).

`reset` and `step` are pure functions of arrays; batch them with `jax.vmap`. The model is
an argument so that each environment can have its own (domain randomization).
"""

from __future__ import annotations

from typing import NamedTuple, Sequence

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from flax import struct
from jax import Array

from mjx_cascade import bezier, features, gait, pd, regulators, rewards, robots, standing
from mjx_cascade import policy as policy_lib
from mjx_cascade.config import Config
from mjx_cascade.physics import make_data, mjx, put_model, resolve_impl
from mjx_cascade.robots import scene
from mjx_cascade.robots.base import Robot
from mjx_cascade.rotations import quat_to_rpy

GROUND_FILTER = 0.2  # s, time constant of the terrain slope estimate
MIN_LIP_HEIGHT = 0.3  # m: keeps the LIP prediction finite while the robot falls


class ControllerState(struct.PyTreeNode):
    stance: Array  # gait.LEFT or gait.RIGHT: the foot in stance
    step_start: Array  # time the current walking step began, s
    alpha: Array  # [N, M + 1] Bezier coefficients of the learned joints, role coordinates
    v_sum: Array  # [2] sum of heading-frame pelvis velocities over the current step
    v_count: Array  # physics steps in the current step
    v_avg: Array  # [2] average velocity over the last completed step (the features; v^ls of eq. 25)
    v_prev: Array  # [2] the same over the step before it
    beta: Array  # [2] PI drift terms (beta_x, beta_y)
    ground: Array  # [2] terrain (pitch, roll) estimated from the stance foot
    lifted: Array  # the swing foot has been unloaded during this step
    hold: Array  # [2] stance hip (roll, pitch) angles at the step start, held while the foot loads
    steps: Array  # walking steps completed
    cmd: Array  # [3] the command followed: the given one through regulators.rate_limit


class EnvState(struct.PyTreeNode):
    data: mjx.Data
    ctrl: ControllerState
    t: Array  # physics steps scored (taken before the episode was done)
    done: Array  # stopped scoring (terminated, diverged or out of time)
    terminated: Array  # ended early by eq. 27
    diverged: Array  # ended by non-finite or impossible physics
    ret: Array  # accumulated weighted reward, reward x seconds
    terms: Array  # [9] accumulated unweighted reward terms, x seconds


class Obs(NamedTuple):
    q: Array  # [2, J] leg motor joint angles, absolute (row 0 left)
    qd: Array  # [2, J]
    pos: Array  # [3] pelvis position
    rpy: Array  # [3] pelvis roll, pitch, yaw
    omega: Array  # [3] pelvis angular velocity, pelvis frame
    v_heading: Array  # [2] pelvis horizontal velocity, heading frame
    feet: Array  # [2, 3] foot positions
    foot_angles: Array  # [2, 2] foot (pitch, roll) relative to flat, heading frame
    foot_force: Array  # [2] normal ground reaction forces
    foot_v: Array  # [2, 3] foot linear velocities
    foot_w: Array  # [2, 3] foot angular velocities
    com: Array  # [3] centre of mass
    ground: Array  # terrain height under the pelvis


def foot_angles(rot: Array, flat: Array, yaw: Array) -> Array:
    """(pitch, roll) of a foot relative to its flat standing orientation, in the heading frame."""
    e = rot @ flat.T  # rotation taking the flat foot to the current one
    hx = jnp.stack([jnp.cos(yaw), jnp.sin(yaw), 0.0])
    hy = jnp.stack([-jnp.sin(yaw), jnp.cos(yaw), 0.0])
    return jnp.stack([jnp.arcsin(jnp.clip(-e[2] @ hx, -1, 1)), jnp.arcsin(jnp.clip(e[2] @ hy, -1, 1))])


class Env:
    """A robot, a config and the compiled MJX model; `reset` and `step` are pure and jittable."""

    def __init__(self, robot: Robot, cfg: Config, pool: tuple[np.ndarray, np.ndarray], batch: int = 1):
        self.robot, self.cfg = robot, cfg
        self.height_field = scene.height_field(robot.model)  # None on a plane
        self.impl = resolve_impl(cfg.physics.impl)
        self.model = put_model(robot.model, self.impl)
        self.data_template = make_data(robot.model, self.impl, cfg.physics, batch)
        self.pool_qpos = jnp.asarray(pool[0], dtype=jnp.float32)
        self.pool_qvel = jnp.asarray(pool[1], dtype=jnp.float32)
        self.foot_rest = _foot_rest(robot, pool[0])
        self.dt = float(robot.model.opt.timestep)
        self.episode_steps = int(round(cfg.episode.seconds / self.dt))
        n, order = robot.num_learned, cfg.gait.bezier_order
        self.action_dim = policy_lib.action_dim(n, order)
        self.policy, self.init_params, self.unravel = policy_lib.make(
            self.action_dim, cfg.policy.hidden_layers, cfg.policy.hidden_units, jax.random.PRNGKey(cfg.seed))
        if robot.learned_low.shape[1] not in (1, order - 1):
            raise ValueError(f"{robot.name}: ranges give {robot.learned_low.shape[1]} coefficients per joint, "
                             f"a Bezier order of {order} has {order - 1} free ones")
        scale = cfg.gait.action_scale
        mid = 0.5 * (robot.learned_low + robot.learned_high)
        half = 0.5 * (robot.learned_high - robot.learned_low) * scale
        self.action_low = jnp.asarray(mid - half, jnp.float32)
        self.action_high = jnp.asarray(mid + half, jnp.float32)
        self._hips = jnp.array([robot.hip_roll, robot.hip_pitch])  # the torso regulator's stance joints
        self._side = jnp.asarray(np.stack([np.ones_like(robot.mirror), robot.mirror]), jnp.float32)
        self._weights = rewards.weights(cfg.rewards)

    # ------------------------------------------------------------------ measurement
    def observe(self, data: mjx.Data, model: mjx.Model | None = None) -> Obs:
        """The controller's measurements; `model` (default `self.model`) holds the terrain."""
        r = self.robot
        rpy = quat_to_rpy(data.qpos[3:7], jnp)
        feet_rot = data.xmat[r.foot_body]
        root_com = data.subtree_com[r.pelvis_body]
        cvel = data.cvel[r.foot_body]
        foot_v = cvel[:, 3:] + jnp.cross(cvel[:, :3], data.xpos[r.foot_body] - root_com)
        pos = data.qpos[:3]
        return Obs(
            q=data.qpos[r.qpos_adr],
            qd=data.qvel[r.dof_adr],
            pos=pos,
            rpy=rpy,
            omega=data.qvel[3:6],
            v_heading=features.to_heading_frame(data.qvel[:2], rpy[2]),
            feet=data.xpos[r.foot_body],
            foot_angles=jax.vmap(foot_angles, in_axes=(0, 0, None))(feet_rot, r.foot_flat, rpy[2]),
            foot_force=data.sensordata[r.foot_force_adr],
            foot_v=foot_v,
            foot_w=cvel[:, :3],
            com=root_com,
            ground=self.ground_height(pos, self.model if model is None else model),
        )

    def ground_height(self, pos: Array, model: mjx.Model) -> Array:
        """Terrain height under `pos`, read from the model's height field (its data may be batched)."""
        if self.height_field is None:
            return jnp.zeros(())
        return scene.height_at(self.height_field, model.hfield_data, pos[0], pos[1], xp=jnp)

    # ------------------------------------------------------------------ the motion policy
    def plan(self, params: Array, q: Array, stance: Array, cmd: Array, v_avg: Array) -> Array:
        """pi_y o G: Bezier coefficients for a step starting now (impact invariance at `q`)."""
        r = self.robot
        q_role = gait.absolute_to_role(q, stance, self.robot.mirror)
        v_des = cmd[:2]
        if self.cfg.policy.mirror_lateral:
            v_des, v_avg = gait.velocity_to_role(v_des, stance), gait.velocity_to_role(v_avg, stance)
        s = features.features(v_des, v_avg)
        action = policy_lib.apply_flat(self.policy, self.unravel, params, s)
        q_start = q_role[r.learned_role, r.learned_joint]
        return gait.coefficients(action, q_start, self.action_low, self.action_high)

    # ------------------------------------------------------------------ reset
    def first_stance(self, key: Array, cmd: Array) -> Array:
        """The foot that stands through the first step, per `gait.first_swing`.

        "command" (not in the paper): lifting a foot from standing lets the CoM, which starts
        between the feet, fall towards that foot's side, so the foot on the side of the commanded
        sideways velocity (`cmd[1]`, positive to the left) swings first; with vy = 0, a coin.
        Started the other way, the first step drifts against the command.
        """
        coin = jax.random.bernoulli(key).astype(jnp.int32)
        if self.cfg.gait.first_swing == "random":
            return coin
        toward = jnp.where(cmd[1] > 0, gait.RIGHT, gait.LEFT)  # vy > 0: the right foot stands, the left swings
        return jnp.where(cmd[1] == 0, coin, toward).astype(jnp.int32)

    def reset(self, params: Array, key: Array, cmd: Array, model: mjx.Model | None = None) -> EnvState:
        """Start standing, from a random member of the balanced pool, with command `cmd` [vx, vy, yaw]."""
        model = self.model if model is None else model
        k_pool, k_side = jax.random.split(key)
        i = jax.random.randint(k_pool, (), 0, self.pool_qpos.shape[0])
        data = self.data_template.replace(qpos=self.pool_qpos[i], qvel=self.pool_qvel[i])
        data = mjx.forward(model, data)
        obs = self.observe(data, model)
        stance = self.first_stance(k_side, cmd)
        zeros2 = jnp.zeros(2)
        ctrl = ControllerState(
            stance=stance,
            step_start=data.time,
            alpha=self.plan(params, obs.q, stance, cmd, zeros2),
            v_sum=zeros2,
            v_count=jnp.zeros(()),
            v_avg=zeros2,
            v_prev=zeros2,
            beta=zeros2,
            ground=zeros2,
            lifted=jnp.zeros((), bool),
            hold=obs.q[stance, self._hips],
            steps=jnp.zeros((), jnp.int32),
            cmd=jnp.asarray(cmd, jnp.float32),
        )
        false = jnp.zeros((), bool)
        return EnvState(data=data, ctrl=ctrl, t=jnp.zeros((), jnp.int32), done=false, terminated=false,
                        diverged=false, ret=jnp.zeros(()), terms=jnp.zeros(len(rewards.TERMS)))

    # ------------------------------------------------------------------ the cascade controller
    def control(self, params: Array, c: ControllerState, obs: Obs, time: Array, cmd: Array) -> tuple[Array, Array, ControllerState]:
        """One tick of pi_m o pi_y: `(u [2, J] joint torques, step_ended, new controller state)`.

        `cmd` is the command given; the controller follows it through `regulators.rate_limit`.
        """
        r, cfg = self.robot, self.cfg
        g, reg = cfg.gait, cfg.regulators
        cmd = regulators.rate_limit(c.cmd, cmd, self.dt, reg)
        c = c.replace(cmd=cmd)
        cmd_v, cmd_yaw = cmd[:2], cmd[2]

        hips = self._hips

        # walking-step bookkeeping and the stance switch (Sec. III-C)
        tau = (time - c.step_start) / g.step_time
        swing_leg = 1 - c.stance
        swing_force = obs.foot_force[swing_leg]
        lifted = c.lifted | (swing_force < g.grf_threshold)
        ended = gait.step_ended(tau, swing_force, lifted, g.min_phase, g.max_phase, g.grf_threshold)
        v_sum = c.v_sum + obs.v_heading
        v_count = c.v_count + 1.0
        v_step = v_sum / v_count
        stance = jnp.where(ended, swing_leg, c.stance)
        v_avg = jnp.where(ended, v_step, c.v_avg)
        c = c.replace(
            stance=stance,
            step_start=jnp.where(ended, time, c.step_start),
            alpha=jnp.where(ended, self.plan(params, obs.q, stance, cmd, v_avg), c.alpha),
            v_sum=jnp.where(ended, 0.0, v_sum),
            v_count=jnp.where(ended, 0.0, v_count),
            v_avg=v_avg,
            v_prev=jnp.where(ended, c.v_avg, c.v_prev),
            beta=jnp.where(ended, regulators.drift_update(c.beta, v_step, cmd_v, reg), c.beta),
            lifted=lifted & ~ended,
            hold=jnp.where(ended, obs.q[stance, hips], c.hold),
            steps=c.steps + ended.astype(jnp.int32),
        )
        tau = jnp.where(ended, 0.0, tau)
        swing_leg = 1 - stance

        # learned trajectories (eq. 11) and trajectory regulations (eq. 20, 22-26), role coordinates
        y, yd = bezier.evaluate(c.alpha, tau, g.step_time)
        ref = jnp.asarray(r.nominal_role, jnp.float32).at[r.learned_role, r.learned_joint].set(y)
        ref_v = jnp.zeros_like(ref).at[r.learned_role, r.learned_joint].set(yd)
        # vbar of eq. 25: the LIP's prediction for the step's end, about the stance foot
        rel = features.to_heading_frame(obs.com[:2] - obs.feet[stance, :2], obs.rpy[2])
        height = jnp.maximum(obs.com[2] - obs.feet[stance, 2], MIN_LIP_HEIGHT)
        v_bar = regulators.predicted_velocity(rel, obs.v_heading, height, jnp.maximum(1.0 - tau, 0.0) * g.step_time)
        b = regulators.blend(tau, reg)
        place = (regulators.swing_placement(v_bar, cmd_v, c.v_avg, c.beta, tau, reg)
                 + b * regulators.neutral_point(v_bar, height, g.step_time, reg)
                 + b * regulators.swing_levelling(obs.rpy))
        turn = regulators.heading(obs.rpy[2], cmd_yaw, tau, reg)
        ref = ref.at[gait.SWING, r.hip_pitch].add(jnp.asarray(r.forward_sign)[swing_leg] * place[0])
        ref = ref.at[gait.SWING, r.hip_roll].add(jnp.asarray(r.lateral_sign)[swing_leg] * place[1])
        ref = ref.at[gait.SWING, r.hip_yaw].add(-jnp.asarray(r.yaw_sign)[swing_leg] * turn)
        # the terrain slope estimate of Sec. IV-A: the stance foot is taken to lie on the ground
        ground = c.ground
        if reg.slope_estimation:
            a = self.dt / (GROUND_FILTER + self.dt)
            ground = ground + a * (obs.foot_angles[stance] - ground)
        c = c.replace(ground=ground)
        if reg.k_height > 0:  # without it the compiled controller is unchanged
            # over the stance foot's ground, from the foot's position: what a robot can measure
            # through its leg (it does not know the terrain under its pelvis)
            leg_height = obs.pos[2] - obs.feet[stance, 2] + self.foot_rest
            if reg.height_over_slope:  # over the slope estimate's ground under the pelvis
                # over the foot itself, a downhill stance foot ahead of the pelvis reads as a
                # pelvis too high, and one behind it as too low
                offset = features.to_heading_frame(obs.pos[:2] - obs.feet[stance, :2], obs.rpy[2])
                leg_height = leg_height - regulators.ground_rise(ground * r.slope_sensed, offset)
            lift = regulators.height_fix(leg_height, cfg.rewards.height, reg)
            ref = ref.at[gait.STANCE, r.knee].add(jnp.asarray(r.knee_extension)[stance] * lift)
        ref = gait.role_to_absolute(ref, stance, r.mirror)
        ref_v = gait.role_to_absolute(ref_v, stance, r.mirror)

        # foot orientation (Sec. IV-A): one Newton step of decoupled IK per foot, absolute
        want = jnp.stack([ground, ground])
        want = want.at[stance].add(regulators.stance_foot_tilt(v_bar, cmd_v, reg))
        toe_step = jnp.einsum("lkc,lc->lk", r.toe_pinv, want - obs.foot_angles) * self._side[:, r.toe]
        ref = ref.at[:, r.toe].set(obs.q[:, r.toe] + toe_step)
        ref_v = ref_v.at[:, r.toe].set(0.0)

        # joint PD (eq. 21); the torso torques take over the stance hip roll and pitch from a
        # PD hold of their touchdown angles as the new stance foot loads (phase blend)
        ref = ref.at[stance, hips].set(c.hold)
        ref_v = ref_v.at[stance, hips].set(0.0)
        u = pd.pd_torque(obs.q, obs.qd, ref, ref_v, r.kp, r.kd)
        torso = jnp.asarray(r.torso_sign)[stance] * regulators.torso_torque(obs.rpy, obs.omega, reg) * self._side[stance, hips]
        u = u.at[stance, hips].set((1.0 - b) * u[stance, hips] + b * torso)
        return u, ended, c

    # ------------------------------------------------------------------ step
    def step(self, params: Array, state: EnvState, cmd: Array, force: Array | None = None,
             model: mjx.Model | None = None) -> EnvState:
        """Advance one physics step under the cascade controller; `force` [3] pushes the pelvis."""
        r, cfg = self.robot, self.cfg
        model = self.model if model is None else model
        data = state.data
        obs = self.observe(data, model)
        u, _, ctrl = self.control(params, state.ctrl, obs, data.time, cmd)
        motor = pd.motor_command(u, r.gear, r.ctrl_low, r.ctrl_high)
        data = data.replace(ctrl=data.ctrl.at[r.actuator].set(motor))
        if force is not None:
            data = data.replace(xfrc_applied=data.xfrc_applied.at[r.pelvis_body, :3].set(force))
        data = mjx.step(model, data)

        # scored against the command followed, which is all the controller is asked to do
        x = self.reward_inputs(obs, ctrl, u)
        terms = rewards.terms(x, cfg.rewards)
        # a non-finite score means this step started from diverged physics: never count it
        diverged = rewards.diverged(data.qpos, data.qvel, cfg.termination) | ~jnp.all(jnp.isfinite(terms))
        terminated = rewards.terminated(x, cfg.termination) | diverged
        live = ~state.done
        reward = jnp.where(live & ~diverged, jnp.dot(self._weights, terms) * self.dt, 0.0)
        t = state.t + live.astype(jnp.int32)
        # charged per second of episode lost, so surviving longer always pays
        lost = (self.episode_steps - t) * self.dt
        penalty = jnp.where(live & terminated, cfg.rewards.termination_penalty * lost, 0.0)
        return EnvState(
            data=data,
            # a finished episode's robot simulates on with the batch: its falls are not walking steps
            ctrl=ctrl.replace(steps=jnp.where(live, ctrl.steps, state.ctrl.steps)),
            t=t,
            done=state.done | terminated | (t >= self.episode_steps),
            terminated=state.terminated | (live & terminated),
            diverged=state.diverged | (live & diverged),
            ret=state.ret + reward - penalty,
            terms=state.terms + jnp.where(live & ~diverged, terms * self.dt, 0.0),
        )

    def reward_inputs(self, obs: Obs, c: ControllerState, u: Array) -> rewards.RewardInputs:
        r, cmd = self.robot, c.cmd
        stance = c.stance
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
            stance_v=obs.foot_v[stance],
            stance_w=obs.foot_w[stance],
        )

    def fitness(self, state: EnvState) -> Array:
        """Episode return per second of the full episode: the normalised mean reward (Fig. 6)."""
        return state.ret / (self.episode_steps * self.dt)


def _foot_rest(robot: Robot, qpos: np.ndarray) -> float:
    """Height of the foot bodies' origins above level ground in the balanced standing states."""
    d = mujoco.MjData(robot.model)
    heights = []
    for q in qpos:
        d.qpos[:] = q
        mujoco.mj_kinematics(robot.model, d)
        heights.append(d.xpos[robot.foot_body, 2])
    return float(np.mean(heights))


def make_env(cfg: Config, batch: int = 1, model_path: str | None = None,
             terrain: dict | Sequence[dict] | None = None) -> Env:
    """Build the robot for `cfg` (and a terrain, or several: `scene.compile_model`), its balanced
    initial states, and the environment.

    `batch` sizes MJX warp's contact buffer for that many parallel environments.
    """
    robot = robots.build(robots.get(cfg.robot), cfg, model_path, terrain)
    pool = standing.balanced_pool(robot, cfg, seed=cfg.seed)
    return Env(robot, cfg, pool, batch=batch)
