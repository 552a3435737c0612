"""The whole controller on hand-built states, checked against the model's own kinematics: would
the swing foot really land where Raibert says, do the torso torques right the pelvis, does the
height fix lengthen the right leg? Each test runs the compiled `Controller.tick` of Cassie."""

import dataclasses
import functools

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest

from mjx_cascade import config, features, gait, policy, regulators
from mjx_cascade.env import Env
from mjx_cascade.physics import mjx

# compiles MJX's forward pass and the controller's tick on the CPU (about 25 s for the module)
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def standing(cassie_env, cassie_pool, cassie_network):
    env = cassie_env
    data = env.data_template(1).replace(qpos=jnp.asarray(cassie_pool[0][0]), qvel=jnp.zeros(env.robot.model.nv))
    data = jax.jit(lambda d: mjx.forward(env.model, d))(data)
    obs = jax.jit(env.observe)(data)
    # the controller's reset alone: env.reset would compile a second forward pass
    ctrl = jax.jit(env.controller.reset)(cassie_network.init_params, jax.random.PRNGKey(0), obs, data.time, jnp.zeros(3))
    # right foot in stance, a quarter into the step: too early for a touchdown to end it
    ctrl = ctrl.replace(stance=jnp.int32(gait.RIGHT), step_start=jnp.float32(-0.1))
    return env, data, obs, ctrl


@functools.cache
def _control(env):
    """The controller's tick, compiled once for every test here (run op by op it takes seconds a call)."""
    return jax.jit(env.controller.tick)


@functools.cache
def _untrained():
    """The untrained policy's parameters (the range middles, about)."""
    return policy.for_controller(config.robot_config("cassie"), 6, jax.random.PRNGKey(0)).init_params


def _obs_change(env, obs, ctrl, **change):
    """Joint torques [2, J] that measuring `change` instead of `obs` adds."""
    base, _, _ = _control(env)(_untrained(), ctrl, obs, jnp.float32(0.0), jnp.zeros(3))
    moved, _, _ = _control(env)(_untrained(), ctrl, obs._replace(**change), jnp.float32(0.0), jnp.zeros(3))
    return np.asarray(moved - base)


def _swing_foot_shift(env, data, joint, dq):
    m, r = env.robot.model, env.robot
    d = mujoco.MjData(m)
    d.qpos[:] = np.asarray(data.qpos)
    mujoco.mj_kinematics(m, d)
    before = d.xpos[r.foot_body[gait.LEFT]].copy(), d.xmat[r.foot_body[gait.LEFT]].reshape(3, 3).copy()
    d.qpos[r.qpos_adr[gait.LEFT, joint]] += dq
    mujoco.mj_kinematics(m, d)
    after = d.xpos[r.foot_body[gait.LEFT]].copy(), d.xmat[r.foot_body[gait.LEFT]].reshape(3, 3).copy()
    return after[0] - before[0], after[1] @ before[1].T


def test_faster_than_commanded_places_the_swing_foot_further_forward(standing):
    env, data, obs, ctrl = standing
    du = _obs_change(env, obs, ctrl, v_heading=obs.v_heading + jnp.array([0.4, 0.0]))
    j = env.robot.hip_pitch
    dq = du[gait.LEFT, j] / env.robot.kp[j]  # the right foot is in stance: the left leg swings
    assert abs(dq) > 1e-3
    shift, _ = _swing_foot_shift(env, data, j, dq)
    assert shift[0] > 0


def test_drifting_left_places_the_swing_foot_further_left(standing):
    env, data, obs, ctrl = standing
    du = _obs_change(env, obs, ctrl, v_heading=obs.v_heading + jnp.array([0.0, 0.3]))
    j = env.robot.hip_roll
    shift, _ = _swing_foot_shift(env, data, j, du[gait.LEFT, j] / env.robot.kp[j])
    assert shift[1] > 0


def test_swing_hip_cancels_the_pelvis_roll(standing):
    """Pelvis rolled left side up (it carries the hanging swing foot leftwards): the swing hip
    moves the foot back to the right by about the same amount."""
    env, data, obs, ctrl = standing
    j = env.robot.hip_roll
    du = _obs_change(env, obs, ctrl, rpy=obs.rpy + jnp.array([0.05, 0.0, 0.0]))
    shift, _ = _swing_foot_shift(env, data, j, du[gait.LEFT, j] / env.robot.kp[j])
    carried = 0.05 * float(data.qpos[2] - data.xpos[env.robot.foot_body[gait.LEFT], 2])
    assert -1.5 * carried < shift[1] < -0.5 * carried


def test_heading_error_turns_the_landing_foot_against_it(standing):
    """Yaw beyond the command: the swing foot lands turned clockwise relative to the pelvis, so
    straightening the hip during the next stance turns the pelvis back."""
    env, data, obs, ctrl = standing
    cmd_turned = jnp.array([0.0, 0.0, -0.3])  # pelvis yaw (0) is 0.3 rad beyond the command
    base, _, _ = _control(env)(_untrained(), ctrl, obs, jnp.float32(0.0), jnp.zeros(3))
    moved, _, _ = _control(env)(_untrained(), ctrl, obs, jnp.float32(0.0), cmd_turned)
    j = env.robot.hip_yaw
    dq = float(moved[gait.LEFT, j] - base[gait.LEFT, j]) / env.robot.kp[j]
    _, rot = _swing_foot_shift(env, data, j, dq)
    assert rot[1, 0] < 0  # the foot turned clockwise about z


def test_torso_torques_right_the_pelvis(standing):
    env, data, obs, ctrl = standing
    m, r = env.robot.model, env.robot
    d = mujoco.MjData(m)
    d.qpos[:] = np.asarray(data.qpos)
    mujoco.mj_kinematics(m, d)
    stance = gait.RIGHT
    for axis, joint, tilt in ((0, r.hip_roll, [0.1, 0.0, 0.0]), (1, r.hip_pitch, [0.0, 0.1, 0.0])):
        tilted = obs._replace(rpy=obs.rpy + jnp.array(tilt), omega=jnp.zeros(3))
        u, _, _ = _control(env)(_untrained(), ctrl, tilted, jnp.float32(0.0), jnp.zeros(3))
        jnt = int(np.nonzero(m.jnt_qposadr == r.qpos_adr[stance, joint])[0][0])
        on_pelvis = -float(u[stance, joint]) * d.xaxis[jnt]  # a joint torque's reaction on its parent
        assert on_pelvis[axis] < 0, (axis, on_pelvis)


def test_torso_torques_take_over_the_stance_hips_as_the_foot_loads(standing):
    """At touchdown the new stance hip holds its angles (a torso torque there would swing the
    still unloaded leg); after the blend phase the torso regulator alone sets its torques."""
    env, data, obs, ctrl = standing
    r, reg = env.robot, env.cfg.regulators
    hips = np.array([r.hip_roll, r.hip_pitch])
    tilted = obs._replace(rpy=obs.rpy + jnp.array([0.1, 0.1, 0.0]), omega=jnp.zeros(3), qd=jnp.zeros_like(obs.qd))
    held = ctrl.replace(hold=obs.q[gait.RIGHT, hips] + 0.05)

    def stance_hips(step_start):
        u, ended, _ = _control(env)(_untrained(), held.replace(step_start=jnp.float32(step_start)), tilted,
                                  jnp.float32(0.0), jnp.zeros(3))
        assert not bool(ended)
        return np.asarray(u[gait.RIGHT, hips])

    np.testing.assert_allclose(stance_hips(0.0), r.kp[hips] * 0.05, rtol=1e-4)
    late = -reg.blend_phase * env.cfg.gait.step_time - 0.01
    torso = np.asarray(regulators.torso_torque(tilted.rpy, tilted.omega, reg))
    np.testing.assert_allclose(np.abs(stance_hips(late)), np.abs(torso), rtol=1e-4)


@pytest.fixture(scope="module")
def height_env(cassie, cassie_pool, standing, cassie_network):
    """The controller with `k_height` 2, measuring the height over the sloped ground."""
    return Env(cassie, standing[0].cfg.override(**{"regulators.k_height": 2.0}),
               cassie_pool, cassie_network.apply)


def test_height_fix_lengthens_the_stance_leg_when_the_pelvis_sags(cassie, cassie_pool, standing, height_env,
                                                                 cassie_network):
    """With `k_height`, a pelvis 5 cm below the desired height over the stance foot's ground turns
    the stance knee by k_height * 0.05 rad the way that lengthens the leg; 0 changes nothing."""
    shipped, data, obs, ctrl = standing
    plain = Env(cassie, shipped.cfg.override(**{"regulators.k_height": 0.0}), cassie_pool, cassie_network.apply)
    env, r, z = height_env, cassie, height_env.cfg.regulators.height

    def stance_knee(e, height):
        ground = obs.feet[ctrl.stance, 2] - e.controller.foot_rest  # under the stance foot
        u, _, _ = _control(e)(_untrained(), ctrl, obs._replace(pos=obs.pos.at[2].set(ground + height)),
                              jnp.float32(0.0), jnp.zeros(3))
        return float(u[gait.RIGHT, r.knee])

    assert stance_knee(plain, z - 0.05) == pytest.approx(stance_knee(plain, z))
    dq = (stance_knee(env, z - 0.05) - stance_knee(env, z)) / r.kp[r.knee]
    assert abs(dq) == pytest.approx(2.0 * 0.05, rel=1e-3)
    m = r.model
    d = mujoco.MjData(m)
    d.qpos[:] = np.asarray(data.qpos)
    hip = int(np.nonzero(m.jnt_qposadr == r.qpos_adr[gait.RIGHT, r.hip_pitch])[0][0])

    def leg_length():
        mujoco.mj_kinematics(m, d)
        return np.linalg.norm(d.xpos[r.foot_body[gait.RIGHT]] - d.xanchor[hip])

    before = leg_length()
    d.qpos[r.qpos_adr[gait.RIGHT, r.knee]] += dq
    assert leg_length() > before + 0.003  # 6 mm for the 0.1 rad here


def test_height_fix_measures_the_pelvis_over_the_sloped_ground_beneath_it(cassie, standing, height_env):
    """On an estimated slope, the stance knee moves by k_height times the rise of the ground
    between the stance foot and the pelvis, the way a sag of that much moves it. (The estimate
    moves 0.5% of the way to the standing foot's angles in the one step taken: rel 2e-2.)"""
    _, data, obs, ctrl = standing
    env, r = height_env, cassie
    obs = obs._replace(pos=obs.pos.at[0].add(-0.25))  # the pelvis well behind its stance foot

    def stance_knee(slope, sag=0.0):
        u, _, _ = _control(env)(_untrained(), ctrl.replace(ground=jnp.asarray(slope, jnp.float32)),
                                obs._replace(pos=obs.pos.at[2].add(-sag)), jnp.float32(0.0), jnp.zeros(3))
        return float(u[gait.RIGHT, r.knee]) / r.kp[r.knee]

    offset = features.to_heading_frame(obs.pos[:2] - obs.feet[gait.RIGHT, :2], obs.rpy[2])
    assert float(offset[0]) < -0.15
    rise = float(regulators.ground_rise(jnp.array([0.1, 0.0]), offset))
    assert rise > 0.01  # downhill, the ground behind the stance foot is higher
    moved = stance_knee([0.1, 0.0]) - stance_knee([0.0, 0.0])
    assert abs(moved) == pytest.approx(2.0 * rise, rel=2e-2)
    sag = stance_knee([0.0, 0.0], sag=rise) - stance_knee([0.0, 0.0])
    assert moved == pytest.approx(sag, rel=2e-2)  # the same as a pelvis that much lower


def test_a_command_held_since_reset_is_followed_bit_for_bit_at_any_rate(standing):
    """The controller starts out following the command it is reset with, so an episode of one command
    (`episode.command_change` 0) runs the same whatever `regulators.command_rate` is; a command
    that changes is limited."""
    env, _, obs, _ = standing
    cmd = jnp.asarray(np.random.default_rng(0).uniform([-0.3, -0.3, -0.5], [0.8, 0.3, 0.5], (64, 3)), jnp.float32)

    def followed(rate, given):
        ctl = dataclasses.replace(env.controller, cfg=env.cfg.override(**{"regulators.command_rate": rate}))

        def ticks(start, later):
            c = ctl.reset(_untrained(), jax.random.PRNGKey(0), obs, jnp.float32(0.0), start)
            for _ in range(3):
                c = ctl.follow(c, later)
            return c.cmd

        return np.asarray(jax.jit(jax.vmap(ticks))(cmd, given))

    held = followed([1.0, 1.0], cmd)
    np.testing.assert_array_equal(held, followed([0.0, 0.0], cmd))
    np.testing.assert_array_equal(held, cmd)
    limit = 3 * env.dt * np.array([1.0, 1.0, 1.0])  # three ticks at 1 m/s^2 and 1 rad/s
    np.testing.assert_allclose(np.abs(followed([1.0, 1.0], -cmd) - cmd), np.minimum(limit, np.abs(2 * cmd)), atol=1e-6)


def test_from_rest_the_followed_command_ramps_from_standing_at_the_rate(standing):
    """With `regulators.start_from_rest` the controller starts out following zero velocity at the
    heading it stands at, plans its first step for that, and ramps to the given command at
    `command_rate`; the first foot still lifts for the given command."""
    env, _, obs, _ = standing
    cmd = jnp.array([-0.2, 0.3, 0.4], jnp.float32)
    ctl = dataclasses.replace(env.controller, cfg=env.cfg.override(**{"regulators.start_from_rest": True,
                                                                        "regulators.command_rate": [1.0, 0.5]}))

    params = _untrained()  # outside the trace: the cached value must not be a tracer

    def ticks(n):
        c = ctl.reset(params, jax.random.PRNGKey(0), obs, jnp.float32(0.0), cmd)
        start = c
        for _ in range(n):
            c = ctl.follow(c, cmd)
        return start, c

    start, later = jax.jit(ticks, static_argnums=0)(10)
    np.testing.assert_allclose(np.asarray(start.cmd), [0.0, 0.0, float(obs.rpy[2])], atol=1e-7)
    step = 10 * env.dt * np.array([1.0, 1.0, 0.5])
    np.testing.assert_allclose(np.asarray(later.cmd), np.asarray(start.cmd) + np.sign(cmd) * step, atol=1e-6)
    at_rest = ctl.plan(params, obs.q, start.stance, start.cmd, jnp.zeros(2))
    np.testing.assert_array_equal(np.asarray(start.alpha), np.asarray(at_rest))
    assert int(start.stance) == int(ctl.first_stance(jax.random.PRNGKey(0), cmd, obs.rpy[2]))  # the given command's foot
