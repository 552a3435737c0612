"""mjx_cascade: RL cascade motion policies for 3D bipedal walking, trained by ES on MuJoCo MJX.

Importing the package sets the XLA flag that keeps JAX's CPU backend from deadlocking
inside batched MJX steps (see `_xla.py`); it must run before JAX creates its CPU backend,
so import `mjx_cascade` before running any JAX computation.
"""

from mjx_cascade import _xla

_xla.configure()

__version__ = "0.1.0"
