"""clothopt: safe, physics-aware cloth manipulation planning (differentiable quasi-static XPBD).

The core needs NumPy alone::

    import clothopt
    scene = clothopt.Scene.load("u_obstacle")
    u = scene.initial_controls()                  # (T, K, 3) float64
    values, dL_dU, dC_dU = scene.grad(u)          # dicts and (T, K, 3) arrays
    plan = scene.optimize(delta=0.2)              # as `clothopt optimize u_obstacle --delta 0.2`
    plan.save("plan.json")

Adapters, imported on first use: ``clothopt.jax.rollout_loss`` (``jax.custom_vjp``),
``clothopt.torch.rollout_loss`` (``torch.autograd.Function``); sweeps on Ray:
``clothopt.sweep`` (needs ``ray``).
"""

from __future__ import annotations

import importlib
from typing import Any

from ._clothopt import Fit, Plan, Rollout, Scene, builtin_scenes

__all__ = ["Scene", "Rollout", "Plan", "Fit", "builtin_scenes", "sweep", "jax", "torch"]

_LAZY = {"jax", "torch", "sweeps"}


def sweep(*args: Any, **kwargs: Any):
    """Runs one plan per task on Ray; see :func:`clothopt.sweeps.sweep`."""
    from .sweeps import sweep as _sweep

    return _sweep(*args, **kwargs)


def __getattr__(name: str) -> Any:
    # `clothopt.jax` and `clothopt.torch` import their framework only when first used, so the
    # core package depends on NumPy alone.
    if name in _LAZY:
        return importlib.import_module(f".{name}", __name__)
    raise AttributeError(f"module 'clothopt' has no attribute {name!r}")
