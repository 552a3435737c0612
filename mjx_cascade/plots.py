"""Figures from trajectories and metrics: velocity tracking (Fig. 7), limit cycles (Fig. 8),
learning curves (Fig. 6). Everything is drawn with matplotlib's Agg backend into PNG files."""

from __future__ import annotations

import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from mjx_cascade.trajectory import heading_velocity, moving_average  # noqa: E402


def tracking(traj: dict, path: Path, title: str = "") -> None:
    """Commanded against achieved heading-frame velocity (1-s average) and heading, Fig. 7."""
    t, cmd = traj["t"], traj["cmd"]
    v, yaw = heading_velocity(traj["qpos"], traj["qvel"])
    v_avg = moving_average(v, t, 1.0)
    fig, axes = plt.subplots(4, 1, figsize=(9, 9), sharex=True)
    for ax, i, name in ((axes[0], 0, "v_x"), (axes[1], 1, "v_y")):
        ax.plot(t, v[:, i], color="0.8", lw=0.8, label="pelvis")
        ax.plot(t, v_avg[:, i], color="C0", label="1 s average")
        ax.step(t, cmd[:, i], where="post", color="C3", ls="--", label="command")
        ax.set_ylabel(f"{name} [m/s]")
    axes[0].legend(loc="upper right", fontsize=8)
    axes[2].plot(t, np.unwrap(yaw), color="C0", label="heading")
    axes[2].step(t, cmd[:, 2], where="post", color="C3", ls="--", label="command")
    axes[2].set_ylabel("yaw [rad]")
    height = traj["qpos"][:, 2] - traj.get("ground", 0.0)
    axes[3].plot(t, height, color="C2")
    axes[3].set_ylabel("pelvis height [m]")
    axes[3].set_xlabel("time [s]")
    for ax in axes:
        ax.grid(alpha=0.3)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def limit_cycles(traj: dict, path: Path, title: str = "", skip: float = 2.0) -> None:
    """Phase portraits (angle against velocity) of every actuated leg joint, left and right, Fig. 8."""
    names = [str(n) for n in traj["joints"]]
    q = traj["qpos"][:, traj["joint_qpos"]]
    qd = traj["qvel"][:, traj["joint_qvel"]]
    keep = traj["t"] >= min(skip, traj["t"][-1] / 2)
    per_leg = len(names) // 2
    fig, axes = plt.subplots(1, per_leg, figsize=(3.2 * per_leg, 3.2))
    for j, ax in enumerate(np.atleast_1d(axes)):
        for side, color in ((0, "C0"), (1, "C3")):
            k = side * per_leg + j
            ax.plot(q[keep, k], qd[keep, k], color=color, lw=0.6, label=names[k])
        ax.set_title(names[j].split("-", 1)[-1], fontsize=9)
        ax.set_xlabel("q [rad]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6)
    np.atleast_1d(axes)[0].set_ylabel("dq/dt [rad/s]")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def learning_curve(metrics_jsonl: Path, path: Path, title: str = "") -> None:
    """Mean and best fitness per generation against physics steps, Fig. 6."""
    rows = [json.loads(line) for line in Path(metrics_jsonl).read_text().splitlines() if line]
    steps = np.array([r["physics_steps_total"] for r in rows])
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.plot(steps, [r["fitness_mean"] for r in rows], label="population mean")
    ax.plot(steps, [r["fitness_max"] for r in rows], alpha=0.6, label="best member")
    ax.set_xlabel("physics steps")
    ax.set_ylabel("normalised return")
    ax.grid(alpha=0.3)
    ax.legend()
    ax.set_title(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def robustness(results: dict, units: dict, path: Path, title: str = "") -> None:
    """Success rate against each swept disturbance (`units[axis] = (name, unit, scale)`); pushes
    with one curve per direction."""
    cells = results["cells"]
    fig, axes = plt.subplots(1, len(cells), figsize=(3.6 * len(cells), 3.4), squeeze=False)
    for ax, (axis, rows) in zip(axes[0], cells.items()):
        name, unit, scale = units[axis]
        for d in dict.fromkeys(r["direction"] for r in rows):
            mine = [r for r in rows if r["direction"] == d]
            ax.plot([r["level"] * scale for r in mine], [r["rate"] for r in mine], "o-", label=d or None)
        ax.set_xlabel(f"{name} [{unit}]")
        ax.set_ylim(-0.05, 1.05)
        ax.grid(alpha=0.3)
        if axis == "push":
            ax.legend(fontsize=7)
    axes[0, 0].set_ylabel("success rate")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def push_response(runs: list[tuple[str, dict, float, float]], path: Path, title: str = "") -> None:
    """Heading-frame velocity through a push, one column per `(label, traj, push_t, duration)`, Fig. 11."""
    fig, axes = plt.subplots(2, len(runs), figsize=(3.6 * len(runs), 5), sharex=True, squeeze=False)
    for col, (label, traj, t0, dur) in enumerate(runs):
        t = traj["t"]
        v, _ = heading_velocity(traj["qpos"], traj["qvel"])
        v_avg = moving_average(v, t, 1.0)
        for row, name in enumerate(("v_x", "v_y")):
            ax = axes[row, col]
            ax.axvspan(t0, t0 + dur, color="C1", alpha=0.3, label="push")
            ax.plot(t, v[:, row], color="0.75", lw=0.8, label="pelvis")
            ax.plot(t, v_avg[:, row], color="C0", label="1 s average")
            ax.axhline(traj["cmd"][row], color="C3", ls="--", label="command")
            ax.grid(alpha=0.3)
            if col == 0:
                ax.set_ylabel(f"{name} [m/s]")
        axes[0, col].set_title(label, fontsize=9)
        axes[1, col].set_xlabel("time [s]")
    axes[0, 0].legend(fontsize=7)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def push_limit_cycle(traj: dict, t0: float, dur: float, path: Path, title: str = "", recover: float = 1.5) -> None:
    """Phase portraits of one leg's joints before, during (and `recover` s after) and after a push, Fig. 12."""
    names = [str(n) for n in traj["joints"]]
    per_leg = len(names) // 2
    q = traj["qpos"][:, traj["joint_qpos"][:per_leg]]
    qd = traj["qvel"][:, traj["joint_qvel"][:per_leg]]
    t = traj["t"]
    periods = (((t >= t0 - 2.0) & (t < t0), "C0", "before"),
               ((t >= t0) & (t < t0 + dur + recover), "C3", "push and recovery"),
               (t >= t0 + dur + recover, "C2", "after"))
    fig, axes = plt.subplots(1, per_leg, figsize=(3.2 * per_leg, 3.2), squeeze=False)
    for j, ax in enumerate(axes[0]):
        for keep, color, label in periods:
            ax.plot(q[keep, j], qd[keep, j], color=color, lw=0.7, label=label)
        ax.set_title(names[j], fontsize=8)
        ax.set_xlabel("q [rad]")
        ax.grid(alpha=0.3)
    axes[0, 0].set_ylabel("dq/dt [rad/s]")
    axes[0, 0].legend(fontsize=6)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def terrain_tracking(groups: dict[str, list[tuple[str, dict]]], path: Path, title: str = "") -> None:
    """Forward velocity (1-s average) and pelvis height above the ground on each terrain, Fig. 14."""
    fig, axes = plt.subplots(2, len(groups), figsize=(5 * len(groups), 5.5), sharex=True, squeeze=False)
    for col, (name, runs) in enumerate(groups.items()):
        colors = plt.cm.viridis(np.linspace(0, 0.9, len(runs)))
        for (label, traj), color in zip(runs, colors):
            t = traj["t"]
            v, _ = heading_velocity(traj["qpos"], traj["qvel"])
            axes[0, col].plot(t, moving_average(v, t, 1.0)[:, 0], color=color, label=label)
            axes[1, col].plot(t, traj["qpos"][:, 2] - traj["ground"], color=color)
        axes[0, col].axhline(runs[0][1]["cmd"][0], color="C3", ls="--", label="command")
        axes[0, col].set_title(name)
        axes[0, col].legend(fontsize=6, ncol=2)
        axes[1, col].set_xlabel("time [s]")
        for ax in axes[:, col]:
            ax.grid(alpha=0.3)
    axes[0, 0].set_ylabel("v_x, 1 s average [m/s]")
    axes[1, 0].set_ylabel("pelvis above ground [m]")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
