"""The C engine backend (`impl: mujoco`) against MJX: the same controller, the same randomized
bodies and pushes, the same trajectory within the physics' tolerance."""

import copy

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_cascade import policies, randomization, robots
from mjx_cascade.env import Env

# compiles the controller's step twice (MJX and the C engine's callback), about 45 s
pytestmark = pytest.mark.slow

STEPS = 600  # 0.6 s at 1 ms: the first two walking steps from standing, through a push


def _walk(env: Env, params: np.ndarray, push: np.ndarray, runs: int = 1) -> list[np.ndarray]:
    """Pelvis positions `[STEPS, B, 3]` of a batch whose bodies are randomized per environment,
    from `runs` calls of one compiled program."""
    batch = push.shape[0]
    keys = jax.random.split(jax.random.PRNGKey(3), batch)
    model = randomization.randomize(env.model, keys, env.cfg.randomization)
    axes = randomization.in_axes(env.model)
    cmd = jnp.array([[0.4, 0.1, 0.2], [-0.2, -0.2, -0.3], [0.0, 0.3, 0.0]])[:batch]
    p = jnp.asarray(params)
    data = env.data_template(batch)
    state = jax.vmap(lambda m, k, c: env.reset(p, k, c, model=m, data=data), in_axes=(axes, 0, 0))(model, keys, cmd)
    step = jax.vmap(lambda m, s, c, f: env.step(p, s, c, force=f, model=m)[0], in_axes=(axes, 0, 0, 0))

    def tick(s, n):
        force = jnp.where((n >= 300) & (n < 400), jnp.asarray(push), 0.0)  # 0.1 s from 0.3 s on
        return step(model, s, cmd, force), s.data.qpos[:, :3]

    walk = jax.jit(lambda s: jax.lax.scan(tick, s, jnp.arange(STEPS))[1])
    return [np.asarray(walk(state)) for _ in range(runs)]


@pytest.fixture(scope="module")
def c_cfg(cassie_cfg):
    return cassie_cfg.override(**{"physics.impl": "mujoco"})


@pytest.fixture(scope="module")
def c_cassie(c_cfg):
    """Cassie compiled for the C engine: the same model with its engine sensors."""
    return robots.build(robots.get("cassie"), c_cfg.physics)


@pytest.fixture(scope="module")
def walks(cassie, c_cassie, cassie_cfg, cassie_pool, cassie_network):
    params = policies.load("cassie").params
    push = np.array([[60.0, 0.0, 0.0], [0.0, -60.0, 0.0], [0.0, 0.0, 0.0]])
    out = {}
    for impl, robot, runs in (("jax", cassie, 1), ("mujoco", c_cassie, 2)):
        env = Env(robot, cassie_cfg.override(**{"physics.impl": impl}), cassie_pool, cassie_network.apply)
        first, *again = _walk(env, params, push, runs)
        out[impl] = first
        out.update({f"{impl} again": a for a in again})
    return out


def test_the_c_engine_walks_the_same_path_as_mjx(walks):
    """Pelvis within 2 mm of MJX's at every step of 0.6 s, each environment with its own masses
    and centres of mass, two of them pushed: float64 C against float32 MJX."""
    gap = np.abs(walks["mujoco"] - walks["jax"]).max()
    assert gap < 2e-3, gap


def test_the_comparison_would_see_a_different_path(walks):
    """The environments differ (commands, bodies, pushes) by far more than the engines do, so
    the agreement above is not a trajectory that ignores what it is given."""
    moved = walks["jax"][-1] - walks["jax"][0]
    assert np.abs(moved[:, None, :2] - moved[None, :, :2]).max() > 0.05
    assert np.abs(walks["mujoco"][-1] - walks["mujoco"][0]).max() > 0.05


def test_the_c_engine_repeats_itself_bit_for_bit(walks):
    """Threads share the batch out differently from call to call; each environment's step does
    not depend on which thread takes it, so training with the C engine reproduces."""
    np.testing.assert_array_equal(walks["mujoco"], walks["mujoco again"])


def _packed(engine, batch: int, live) -> np.ndarray:
    """A batch of `CEngine._host_step`'s packed inputs: each environment standing at the model's
    qpos0, under the model's own fields, `live` as given."""
    m = engine.model
    parts = {"qpos": np.tile(m.qpos0, (batch, 1)),
             "fields": np.tile(np.concatenate([m.body_mass.ravel(), m.body_ipos.ravel()]), (batch, 1)),
             "live": np.asarray(live, np.float32)[:, None]}
    packed = np.zeros((batch, engine.inputs["size"]), np.float32)
    for name, value in parts.items():
        packed[:, engine.inputs[name]] = value
    return packed


def test_the_c_engine_refuses_a_batch_of_several_terrains_rather_than_walk_one(c_cassie):
    """Per-environment height fields (the sweep's rough ground) are not written to its models, so
    such a batch is refused; one terrain for all (what training and `eval` batches use) runs."""
    from mjx_cascade.physics import CEngine

    engine = CEngine(c_cassie.model, threads=1)
    packed = _packed(engine, 2, [1, 1])
    out = engine._host_step(packed, np.zeros((1, 1)))  # one terrain: the model's
    assert out.shape == (2, engine.outputs["size"]) and np.all(np.isfinite(out))
    with pytest.raises(ValueError, match="several terrains"):
        engine._host_step(packed, np.zeros((2, 1)))


def test_the_c_engine_steps_only_live_environments_and_each_as_if_alone(c_cassie):
    """An environment whose episode is done keeps its state and sensors (training skips it), and
    a live one's step does not depend on which others share the batch."""
    from mjx_cascade.physics import CEngine

    engine = CEngine(c_cassie.model, threads=2)
    i, o = engine.inputs, engine.outputs
    packed = _packed(engine, 3, [1, 0, 1])
    packed[:, i["qvel"]] = np.random.default_rng(0).normal(0.0, 0.3, (3, c_cassie.model.nv))
    packed[:, i["sensordata"]] = 7.0
    out = engine._host_step(packed, np.zeros((1, 0)))
    for k in ("qpos", "qvel", "sensordata"):
        np.testing.assert_array_equal(out[1, o[k]], packed[1, i[k]])
    assert not np.allclose(out[0, o["qvel"]], packed[0, i["qvel"]]) and not np.allclose(out[0, o["sensordata"]], 7.0)
    alone = engine._host_step(packed[2:], np.zeros((1, 0)))
    np.testing.assert_array_equal(out[2], alone[0])


def test_the_c_engine_reports_the_kinematics_mujoco_computes_before_its_step(c_cassie, cassie):
    """The feet's and pelvis's positions, orientations, subtree centres of mass and velocities that
    the C engine's step returns are MuJoCo's own of the state before the step (what `mjx.step`
    leaves), in a moving, tilted pose: the observation reads them instead of recomputing them."""
    import mujoco

    from mjx_cascade.physics import CEngine, mjx

    m = c_cassie.model
    assert m.nsensordata > cassie.model.nsensordata  # other impls' models carry no engine sensors
    engine = CEngine(m, threads=1)
    rng = np.random.default_rng(1)
    d = mujoco.MjData(m)
    d.qpos[:] = m.qpos0
    d.qpos[3:7] = (0.98, 0.1, -0.15, 0.08)
    d.qpos[3:7] /= np.linalg.norm(d.qpos[3:7])
    d.qvel[:] = rng.normal(0.0, 0.5, m.nv)
    mujoco.mj_forward(m, d)
    mx = mjx.put_model(m)
    before = mjx.make_data(mx).replace(qpos=jnp.asarray(d.qpos, jnp.float32), qvel=jnp.asarray(d.qvel, jnp.float32),
                                       sensordata=jnp.zeros(m.nsensordata, jnp.float32))
    after = engine.step(mx, before)
    bodies = np.array([c_cassie.pelvis_body, *c_cassie.foot_body])
    np.testing.assert_allclose(np.asarray(after.xpos)[bodies], d.xpos[bodies], atol=1e-5)
    np.testing.assert_allclose(np.asarray(after.xmat)[bodies], d.xmat[bodies].reshape(-1, 3, 3), atol=1e-5)
    np.testing.assert_allclose(np.asarray(after.subtree_com)[bodies], d.subtree_com[bodies], atol=1e-5)
    np.testing.assert_allclose(np.asarray(after.cvel)[bodies], d.cvel[bodies], atol=1e-4)
    assert np.abs(d.cvel[bodies]).max() > 0.1 and np.abs(np.asarray(after.qpos) - d.qpos).max() > 1e-4


def test_the_c_engine_reports_the_centre_of_mass_of_the_masses_it_is_given(c_cassie):
    """With every link's mass scaled (as training's randomization and the mass sweep do), the
    subtree centres of mass the C engine's step reports are those of the scaled robot, as MJX's
    are: MuJoCo recomputing all its mass constants (`mj_setConst`) agrees. Away from the origin,
    where a stale total mass shows most: it put a 0.8x robot's centre of mass 0.2 m low."""
    import mujoco

    from mjx_cascade.physics import CEngine, mjx

    m = c_cassie.model
    engine = CEngine(m, threads=1)
    scale = np.random.default_rng(2).uniform(0.8, 1.0, m.nbody)
    scale[0] = 1.0
    d = mujoco.MjData(m)
    d.qpos[:] = m.qpos0
    d.qpos[:2] = (3.0, -2.0)
    mx = mjx.put_model(m)
    mx = mx.tree_replace({"body_mass": mx.body_mass * jnp.asarray(scale, jnp.float32)})
    before = mjx.make_data(mx).replace(qpos=jnp.asarray(d.qpos, jnp.float32),
                                       sensordata=jnp.zeros(m.nsensordata, jnp.float32))
    after = engine.step(mx, before)
    ref = copy.deepcopy(m)
    ref.body_mass[:] = np.asarray(mx.body_mass)
    ds = mujoco.MjData(ref)
    mujoco.mj_setConst(ref, ds)  # computes at qpos0, using ds as scratch
    ds.qpos[:] = d.qpos
    mujoco.mj_forward(ref, ds)
    bodies = np.array([c_cassie.pelvis_body, *c_cassie.foot_body])
    np.testing.assert_allclose(np.asarray(after.subtree_com)[bodies], ds.subtree_com[bodies], atol=1e-5)
    mujoco.mj_forward(m, d)  # the same pose at the model's own masses: a different centre of mass
    assert np.abs(ds.subtree_com[c_cassie.pelvis_body] - d.subtree_com[c_cassie.pelvis_body]).max() > 1e-3


def test_the_c_engine_refuses_a_model_without_its_sensors(cassie):
    """A model compiled for another impl lacks the engine sensors: the engine says so rather than
    hand the observation stale kinematics."""
    from mjx_cascade.physics import CEngine

    with pytest.raises(ValueError, match="engine sensors"):
        CEngine(cassie.model, threads=1)
