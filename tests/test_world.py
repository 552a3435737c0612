"""Schedules of commands and pushes by physics step, from timed ones (scenarios, robustness trials)."""

import jax.numpy as jnp
import numpy as np

from mjx_cascade import scenario, world
from mjx_cascade.world import NEVER

DT = 0.0005


def test_a_timed_command_acts_from_the_first_step_starting_at_or_after_its_time():
    s = scenario.parse({"duration": 1.0, "commands": [{"t": 0, "vx": 0.2, "vy": 0, "yaw": 0},
                                                        {"t": 0.3, "vx": -0.1, "vy": 0.1, "yaw": 0.2},
                                                        {"t": 0.40001, "vx": 0.5, "vy": 0, "yaw": 0}],
                        "pushes": [{"t": 0.1, "duration": 0.05, "force": [20, 0, 0]},
                                   {"t": 0.12, "duration": 0.01, "force": [0, 5, 0]}]})
    steps = 2000
    sched = world.schedule([np.array(s.commands)], [[(p.t, p.duration, p.force) for p in s.pushes]], DT, steps)
    starts = (np.arange(steps) + 1) * DT - DT
    want_cmd, want_force = s.command_schedule(starts), s.force_schedule(starts)  # the scenario's own reading
    for n in (0, 599, 600, 800, 801, 1999):
        np.testing.assert_allclose(sched.command_at(jnp.int32(n))[0], want_cmd[n], rtol=1e-6)
    for n in (199, 200, 239, 240, 259, 260, 299, 300):
        np.testing.assert_allclose(sched.force_at(jnp.int32(n))[0], want_force[n], rtol=1e-6)


def test_a_batch_pads_shorter_schedules_so_they_never_change():
    sched = world.schedule([np.array([[0, 0.1, 0, 0]]), np.array([[0, 0.2, 0, 0], [1.0, 0.3, 0, 0]])],
                           [[], [(0.5, 0.1, (1, 2, 3))]], DT, 4000)
    assert sched.command.shape == (2, 2, 3) and int(sched.command_start[0, 1]) == NEVER
    np.testing.assert_allclose(sched.command_at(jnp.int32(3999))[:, 0], [0.1, 0.3], rtol=1e-6)
    np.testing.assert_allclose(sched.force_at(jnp.int32(1000)), [[0, 0, 0], [1, 2, 3]])
    assert world.schedule([np.array([[0, 0.1, 0, 0]])], [[]], DT, 10).force_at(jnp.int32(0)) is None
