"""The cascade controller of Fig. 2 and 3: the learned motion policy pi_y o G inside the feedback
regulators pi_m, one pure function per stage.

One control tick (`Controller.tick`), in the order of the paper's Sec. III-C and IV:
1. `follow`: the command the controller follows moves towards the given one (a rate limit);
2. `bookkeeping`: the walking step ends on touchdown or time-out; then the step's average
   velocity becomes the features, the drift terms integrate, and the policy plans the next step;
3. `learned_reference`: the learned joints' Bezier trajectories (eq. 11);
4. `swing_regulation`: swing-foot placement and heading (eq. 22-26);
5. `terrain_regulation`: the slope estimate and the stance leg's height (Sec. IV-A);
6. `foot_orientation`: the feet parallel to the estimated ground (Sec. IV-A, eq. 24 rows 6-7);
7. `torso_and_pd`: joint PD (eq. 21), with the torso torques taking over the stance hip (Sec. IV-B).

Joint arrays are `[2, J]`: role coordinates (row 0 the stance leg, row 1 the swing leg, both in the
left leg's convention; `gait`) until stage 6, absolute (row 0 the left leg) after. The robot supplies
every sign from its model (`robots.base`), so no stage knows which robot it drives.
"""

from __future__ import annotations

import dataclasses
from typing import Callable

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct
from jax import Array

from mjx_cascade import bezier, features, gait, pd, regulators
from mjx_cascade.config import ControllerConfig
from mjx_cascade.observe import Obs
from mjx_cascade.robots.base import Robot

GROUND_FILTER = 0.2  # s, time constant of the terrain slope estimate
MIN_LIP_HEIGHT = 0.3  # m: keeps the LIP prediction finite while the robot falls
FIRST_TURN = 0.1  # rad: the least turn that chooses the first swing foot under `gait.first_swing: turn`

Policy = Callable[[Array, Array], Array]  # (flat parameters, features [6]) -> actions in (0, 1)


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
    cmd: Array  # [3] the command followed: the given one through regulators.rate_limit


@dataclasses.dataclass(frozen=True, eq=False)
class Controller:
    """A robot's cascade controller under `cfg`, querying `policy`; every method is pure and jittable."""

    robot: Robot
    cfg: ControllerConfig
    dt: float  # s, one tick
    policy: Policy
    foot_rest: float  # m, height of the foot bodies' origins above level ground when standing
    action_low: Array = dataclasses.field(init=False)  # [N, K] each learned coefficient's range
    action_high: Array = dataclasses.field(init=False)
    hips: Array = dataclasses.field(init=False)  # the torso regulator's stance joints (roll, pitch)
    side: Array = dataclasses.field(init=False)  # [2, J] role value x side = absolute angle

    def __post_init__(self) -> None:
        r, order = self.robot, self.cfg.gait.bezier_order
        if r.learned_low.shape[1] not in (1, order - 1):
            raise ValueError(f"{r.name}: ranges give {r.learned_low.shape[1]} coefficients per joint, "
                             f"a Bezier order of {order} has {order - 1} free ones")
        mid = 0.5 * (r.learned_low + r.learned_high)
        half = 0.5 * (r.learned_high - r.learned_low) * self.cfg.gait.action_scale
        set_ = lambda name, value: object.__setattr__(self, name, value)  # noqa: E731
        set_("action_low", jnp.asarray(mid - half, jnp.float32))
        set_("action_high", jnp.asarray(mid + half, jnp.float32))
        set_("hips", jnp.array([r.hip_roll, r.hip_pitch]))
        set_("side", jnp.asarray(np.stack([np.ones_like(r.mirror), r.mirror]), jnp.float32))

    # ------------------------------------------------------------------ the motion policy
    def plan(self, params: Array, q: Array, stance: Array, cmd: Array, v_avg: Array) -> Array:
        """pi_y o G (eq. 8, 11): Bezier coefficients `[N, M + 1]` for a step starting now at `q`.

        A right-stance step sees the state mirrored, as its coefficients are (eq. 12;
        `gait.velocity_to_role`).
        """
        r = self.robot
        q_role = gait.absolute_to_role(q, stance, r.mirror)
        v_des, v_avg = gait.velocity_to_role(cmd[:2], stance), gait.velocity_to_role(v_avg, stance)
        action = self.policy(params, features.features(v_des, v_avg))
        return gait.coefficients(action, q_role[r.learned_role, r.learned_joint], self.action_low, self.action_high)

    def first_stance(self, key: Array, cmd: Array, heading: Array) -> Array:
        """The foot that stands through the first step, per `gait.first_swing` (not in the paper).

        "command": lifting a foot from standing lets the CoM, which starts between the feet, fall
        towards that foot's side, so the foot on the side of the commanded sideways velocity
        (`cmd[1]`, positive to the left) swings first; with vy = 0, a coin. Started the other way,
        the first step drifts against the command.
        "turn": the foot away from the turn (`cmd[2]` less the present `heading`, positive to the
        left) swings first, so a left turn stands on the left foot; below `FIRST_TURN`, as
        "command". A Digit policy trained with "command" fell in its second step when the foot on
        the turn's side swung first while walking backwards; one trained with the turn deciding
        however small it was fell where a heading command of 0 left the choice to the standing
        state's own heading rather than vy (docs/results.md).
        """
        coin = jax.random.bernoulli(key).astype(jnp.int32)
        if self.cfg.gait.first_swing == "random":
            return coin
        by_vy = jnp.where(cmd[1] == 0, coin, jnp.where(cmd[1] > 0, gait.RIGHT, gait.LEFT))  # vy > 0: the left swings
        if self.cfg.gait.first_swing == "command":
            return by_vy.astype(jnp.int32)
        turn = regulators.wrap_angle(cmd[2] - heading)
        by_turn = jnp.where(turn > 0, gait.LEFT, gait.RIGHT)
        return jnp.where(jnp.abs(turn) < FIRST_TURN, by_vy, by_turn).astype(jnp.int32)

    def reset(self, params: Array, key: Array, obs: Obs, time: Array, cmd: Array) -> ControllerState:
        """Standing at `time`, about to take the first step under command `cmd`.

        The first step is planned for the followed command (`start_command`); the foot that lifts
        first is chosen for the given one, the way the robot is about to go.
        """
        stance = self.first_stance(key, cmd, obs.rpy[2])
        followed = self.start_command(obs, cmd)
        zeros2 = jnp.zeros(2)
        return ControllerState(
            stance=stance, step_start=time, alpha=self.plan(params, obs.q, stance, followed, zeros2),
            v_sum=zeros2, v_count=jnp.zeros(()), v_avg=zeros2, v_prev=zeros2, beta=zeros2, ground=zeros2,
            lifted=jnp.zeros((), bool), hold=obs.q[stance, self.hips], cmd=followed)

    def start_command(self, obs: Obs, cmd: Array) -> Array:
        """The command followed from standing (not in the paper): `cmd` itself, or with
        `regulators.start_from_rest` zero velocity at the present heading, from which `follow` ramps
        to `cmd` as after any change. A standing robot told to walk backwards and turn at once
        fell in its second step (Digit, docs/results.md); a user's robot starts from rest."""
        cmd = jnp.asarray(cmd, jnp.float32)
        if not self.cfg.regulators.start_from_rest:
            return cmd
        return jnp.stack([jnp.zeros(()), jnp.zeros(()), obs.rpy[2].astype(jnp.float32)])

    # ------------------------------------------------------------------ one tick
    def tick(self, params: Array, c: ControllerState, obs: Obs, time: Array, cmd: Array
             ) -> tuple[Array, Array, ControllerState]:
        """pi_m o pi_y at `time` for the given command `cmd`: `(u [2, J] joint torques, the walking
        step ended, the new state)`."""
        c = self.follow(c, cmd)
        c, ended, tau = self.bookkeeping(params, c, obs, time)
        ref, ref_v = self.learned_reference(c, tau)
        v_bar, height = self.lip_prediction(c, obs, tau)
        ref = self.swing_regulation(ref, c, obs, tau, v_bar, height)
        c, ref = self.terrain_regulation(ref, c, obs)
        ref = gait.role_to_absolute(ref, c.stance, self.robot.mirror)
        ref_v = gait.role_to_absolute(ref_v, c.stance, self.robot.mirror)
        ref, ref_v = self.foot_orientation(ref, ref_v, c, obs, v_bar)
        return self.torso_and_pd(ref, ref_v, c, obs, regulators.blend(tau, self.cfg.regulators)), ended, c

    def follow(self, c: ControllerState, cmd: Array) -> ControllerState:
        """The followed command moves towards `cmd` at `regulators.command_rate` (not in the paper)."""
        return c.replace(cmd=regulators.rate_limit(c.cmd, cmd, self.dt, self.cfg.regulators))

    def bookkeeping(self, params: Array, c: ControllerState, obs: Obs, time: Array
                    ) -> tuple[ControllerState, Array, Array]:
        """Sec. III-C: `(state, step ended, phase tau)`. A swing-foot touchdown (or a time-out) ends
        the step: the swing foot stands, the step's average velocity becomes v^ls, the drift terms
        integrate it (eq. 26), and the policy plans the next step from the joints where they are."""
        g = self.cfg.gait
        tau = (time - c.step_start) / g.step_time
        swing_force = obs.foot_force[1 - c.stance]
        lifted = c.lifted | (swing_force < g.grf_threshold)
        ended = gait.step_ended(tau, swing_force, lifted, g.min_phase, g.max_phase, g.grf_threshold)
        v_sum, v_count = c.v_sum + obs.v_heading, c.v_count + 1.0
        v_step = v_sum / v_count
        stance = jnp.where(ended, 1 - c.stance, c.stance)
        v_avg = jnp.where(ended, v_step, c.v_avg)
        c = c.replace(
            stance=stance,
            step_start=jnp.where(ended, time, c.step_start),
            alpha=jnp.where(ended, self.plan(params, obs.q, stance, c.cmd, v_avg), c.alpha),
            v_sum=jnp.where(ended, 0.0, v_sum),
            v_count=jnp.where(ended, 0.0, v_count),
            v_avg=v_avg,
            v_prev=jnp.where(ended, c.v_avg, c.v_prev),
            beta=jnp.where(ended, regulators.drift_update(c.beta, v_step, c.cmd[:2], self.cfg.regulators), c.beta),
            lifted=lifted & ~ended,
            hold=jnp.where(ended, obs.q[stance, self.hips], c.hold),
        )
        return c, ended, jnp.where(ended, 0.0, tau)

    def learned_reference(self, c: ControllerState, tau: Array) -> tuple[Array, Array]:
        """Eq. 11: the learned joints follow their Bezier curves; the others hold the nominal pose."""
        r = self.robot
        y, yd = bezier.evaluate(c.alpha, tau, self.cfg.gait.step_time)
        ref = jnp.asarray(r.nominal_role, jnp.float32).at[r.learned_role, r.learned_joint].set(y)
        ref_v = jnp.zeros_like(ref).at[r.learned_role, r.learned_joint].set(yd)
        return ref, ref_v

    def lip_prediction(self, c: ControllerState, obs: Obs, tau: Array) -> tuple[Array, Array]:
        """vbar of eq. 25: `(the pelvis velocity the LIP predicts for the step's end, the CoM's height
        over the stance foot)`, heading frame (`regulators.predicted_velocity` says why not an average)."""
        rel = features.to_heading_frame(obs.com[:2] - obs.feet[c.stance, :2], obs.rpy[2])
        height = jnp.maximum(obs.com[2] - obs.feet[c.stance, 2], MIN_LIP_HEIGHT)
        remaining = jnp.maximum(1.0 - tau, 0.0) * self.cfg.gait.step_time
        return regulators.predicted_velocity(rel, obs.v_heading, height, remaining), height

    def swing_regulation(self, ref: Array, c: ControllerState, obs: Obs, tau: Array, v_bar: Array,
                         height: Array) -> Array:
        """Eq. 22-26: the swing hip places the foot against the velocity error (with Raibert's neutral
        point and the pelvis tilt cancelled), and its yaw turns the pelvis towards the heading."""
        r, reg, g = self.robot, self.cfg.regulators, self.cfg.gait
        b = regulators.blend(tau, reg)
        place = (regulators.swing_placement(v_bar, c.cmd[:2], c.v_avg, c.beta, tau, reg)
                 + b * regulators.neutral_point(v_bar, height, g.step_time, reg)
                 + b * regulators.swing_levelling(obs.rpy))
        turn = regulators.heading(obs.rpy[2], c.cmd[2], tau, reg)
        swing = 1 - c.stance
        ref = ref.at[gait.SWING, r.hip_pitch].add(jnp.asarray(r.forward_sign)[swing] * place[0])
        ref = ref.at[gait.SWING, r.hip_roll].add(jnp.asarray(r.lateral_sign)[swing] * place[1])
        return ref.at[gait.SWING, r.hip_yaw].add(-jnp.asarray(r.yaw_sign)[swing] * turn)

    def terrain_regulation(self, ref: Array, c: ControllerState, obs: Obs) -> tuple[ControllerState, Array]:
        """Sec. IV-A: the stance foot is taken to lie on the ground, so a low-pass of its (pitch, roll)
        estimates the slope; the stance knee extends for a pelvis below `regulators.height`
        (`regulators.height_fix`, not in the paper). The height is measured through the stance leg
        and taken over the estimated ground plane under the pelvis, not over the foot: downhill, a
        stance foot ahead of the pelvis would read as a pelvis too high, one behind it as too low."""
        r, reg = self.robot, self.cfg.regulators
        a = self.dt / (GROUND_FILTER + self.dt)
        ground = c.ground + a * (obs.foot_angles[c.stance] - c.ground)
        c = c.replace(ground=ground)
        if reg.k_height == 0:  # the stance knee is the policy's alone
            return c, ref
        leg_height = obs.pos[2] - obs.feet[c.stance, 2] + self.foot_rest
        offset = features.to_heading_frame(obs.pos[:2] - obs.feet[c.stance, :2], obs.rpy[2])
        leg_height = leg_height - regulators.ground_rise(ground * r.slope_sensed, offset)
        lift = regulators.height_fix(leg_height, reg.height, reg)
        return c, ref.at[gait.STANCE, r.knee].add(jnp.asarray(r.knee_extension)[c.stance] * lift)

    def foot_orientation(self, ref: Array, ref_v: Array, c: ControllerState, obs: Obs, v_bar: Array
                         ) -> tuple[Array, Array]:
        """Sec. IV-A: both feet parallel to the estimated ground, the stance foot tilted against the
        velocity error (eq. 24 rows 6-7); one Newton step of decoupled IK per foot, absolute angles."""
        r = self.robot
        want = jnp.stack([c.ground, c.ground])
        want = want.at[c.stance].add(regulators.stance_foot_tilt(v_bar, c.cmd[:2], self.cfg.regulators))
        toe_step = jnp.einsum("lkc,lc->lk", r.toe_pinv, want - obs.foot_angles) * self.side[:, r.toe]
        return ref.at[:, r.toe].set(obs.q[:, r.toe] + toe_step), ref_v.at[:, r.toe].set(0.0)

    def torso_and_pd(self, ref: Array, ref_v: Array, c: ControllerState, obs: Obs, b: Array) -> Array:
        """Eq. 21 and Sec. IV-B: joint PD torques; the torso torques take over the stance hip roll and
        pitch from a PD hold of their touchdown angles as the new stance foot loads (phase blend `b`)."""
        r, hips, stance = self.robot, self.hips, c.stance
        ref = ref.at[stance, hips].set(c.hold)
        ref_v = ref_v.at[stance, hips].set(0.0)
        u = pd.pd_torque(obs.q, obs.qd, ref, ref_v, r.kp, r.kd)
        torso = regulators.torso_torque(obs.rpy, obs.omega, self.cfg.regulators)
        torso = jnp.asarray(r.torso_sign)[stance] * torso * self.side[stance, hips]
        return u.at[stance, hips].set((1.0 - b) * u[stance, hips] + b * torso)
