"""Robot definitions, one module per robot; `get(name)` returns one."""

from __future__ import annotations

from mjx_cascade.config import ROBOTS, ConfigError
from mjx_cascade.robots.base import Robot, RobotDefinition, build, model_path, requested_model


def get(name: str) -> RobotDefinition:
    if name == "cassie":
        from mjx_cascade.robots.cassie import CASSIE

        return CASSIE
    if name == "digit":
        from mjx_cascade.robots.digit import DIGIT

        return DIGIT
    raise ConfigError(f"unknown robot {name!r}; choose from {', '.join(ROBOTS)}")


__all__ = ["Robot", "RobotDefinition", "build", "get", "model_path", "requested_model"]
