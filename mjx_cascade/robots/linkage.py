"""Closed kinematic chains: how the passive joints of a linkage follow the driven ones.

Both robots close their leg linkages with equality constraints (Cassie's achilles and plantar
rods, Digit's achilles and toe A/B rods), which `mj_kinematics` ignores: moving one joint of a
loop alone breaks the loop. Here the loops are kept closed, to first order for velocities
(J_eq qdot = 0) and exactly for poses (Gauss-Newton on the constraint residuals).

Which joints follow: every joint that is not the free joint, not actuated and not a spring.
Unloaded springs stay at rest; holding them fixed also removes the freedom they would
otherwise add to the loops (Digit's shin and heel springs would make the tarsus angle
underdetermined). What remains underdetermined, such as a ball-jointed rod spinning about
its own axis, moves nothing else: least squares takes the minimum-norm motion.
"""

from __future__ import annotations

from typing import Callable

import mujoco
import numpy as np

# residuals and their Jacobian with respect to qvel, at the state of `data` after `mj_fwdPosition`
Residual = Callable[[mujoco.MjModel, mujoco.MjData], tuple[np.ndarray, np.ndarray]]


def passive_dofs(model: mujoco.MjModel) -> np.ndarray:
    """Dof indices of the joints that follow the closed chains."""
    driven = set(model.actuator_trnid[model.actuator_trntype == mujoco.mjtTrn.mjTRN_JOINT, 0].tolist())
    dofs = []
    for j in range(model.njnt):
        if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE or j in driven or model.jnt_stiffness[j] > 0:
            continue
        n = 3 if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_BALL else 1
        dofs.extend(range(model.jnt_dofadr[j], model.jnt_dofadr[j] + n))
    return np.array(dofs, dtype=int)


def equality(model: mujoco.MjModel, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
    """(residual [E], Jacobian [E, nv]) of the active equality constraints; needs `mj_fwdPosition`."""
    rows = np.nonzero(data.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY)[0]
    if mujoco.mj_isSparse(model):
        jac = np.zeros((data.nefc, model.nv))
        mujoco.mju_sparse2dense(jac, data.efc_J, data.efc_J_rownnz, data.efc_J_rowadr, data.efc_J_colind)
    else:
        jac = data.efc_J.reshape(data.nefc, model.nv)
    return data.efc_pos[rows].copy(), jac[rows].copy()


def follow(model: mujoco.MjModel, data: mujoco.MjData, qvel: np.ndarray) -> np.ndarray:
    """`qvel` with its passive dofs replaced by the motion that keeps the loops closed (J_eq qvel = 0)."""
    mujoco.mj_fwdPosition(model, data)
    _, jac = equality(model, data)
    passive = passive_dofs(model)
    qvel = np.array(qvel, dtype=np.float64)
    qvel[passive] = 0.0
    if len(jac):
        qvel[passive] = np.linalg.lstsq(jac[:, passive], -jac @ qvel, rcond=None)[0]
    return qvel


def close(model: mujoco.MjModel, qpos: np.ndarray, dofs: np.ndarray | None = None, extra: Residual | None = None,
          iterations: int = 30, tol: float = 1e-10) -> np.ndarray:
    """`qpos` with the loops closed: Gauss-Newton on the equality residuals (and `extra`'s) over `dofs`.

    `dofs` defaults to the passive ones; add driven dofs to `dofs` when `extra` asks for more
    than the loops (e.g. a foot held level by its toe motors).
    """
    dofs = passive_dofs(model) if dofs is None else np.asarray(dofs)
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    for _ in range(iterations):
        mujoco.mj_fwdPosition(model, data)
        res, jac = equality(model, data)
        if extra is not None:
            r, j = extra(model, data)
            res, jac = np.concatenate([res, r]), np.concatenate([jac, j])
        if res @ res < tol**2:
            break
        step = np.zeros(model.nv)
        step[dofs] = np.linalg.lstsq(jac[:, dofs], -res, rcond=None)[0]
        mujoco.mj_integratePos(model, data.qpos, step, 1.0)
    else:
        raise RuntimeError(f"the closed chains did not close: residual {np.sqrt(res @ res):.2e}")
    return data.qpos.copy()
