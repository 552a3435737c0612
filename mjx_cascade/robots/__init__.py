"""Robot definitions, one module per robot, each exposing `DEFINITION`; `get(name)` returns one
through the registry `config.ROBOTS`."""

from __future__ import annotations

import importlib

from mjx_cascade.config import ROBOTS, need
from mjx_cascade.robots.base import Robot, RobotDefinition, build, model_path, requested_model


def get(name: str) -> RobotDefinition:
    need(name in ROBOTS, f"unknown robot {name!r}; choose from {', '.join(ROBOTS)}")
    return importlib.import_module(ROBOTS[name]).DEFINITION


__all__ = ["Robot", "RobotDefinition", "build", "get", "model_path", "requested_model"]
