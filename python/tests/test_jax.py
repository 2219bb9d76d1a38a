"""The JAX adapter: values and VJPs equal `Scene.grad`, checked with JAX's own gradient checker."""

from __future__ import annotations

import numpy as np
import pytest

jax = pytest.importorskip("jax")
jax.config.update("jax_enable_x64", True)
import jax.numpy as jnp  # noqa: E402
from jax.test_util import check_grads  # noqa: E402

import clothopt  # noqa: E402
from clothopt.jax import rollout_loss  # noqa: E402


def test_values_and_gradient_equal_scene_grad(quick_scene_dict):
    scene = clothopt.Scene.from_dict(quick_scene_dict)
    u = jnp.asarray(scene.initial_controls())
    values, dl_du, _ = scene.grad(np.asarray(u))
    loss, grad = jax.value_and_grad(lambda v: rollout_loss(scene, v))(u)
    assert loss.dtype == jnp.float64 and float(loss) == values["L"]
    assert np.array_equal(np.asarray(grad), dl_du)
    # Under jit too, and composed with other JAX code (chain rule through the adapter).
    jitted = jax.jit(jax.grad(lambda v: 3.0 * rollout_loss(scene, 2.0 * v)))(u)
    assert np.allclose(np.asarray(jitted), 6.0 * scene.grad(2.0 * np.asarray(u))[1], rtol=0, atol=0)


def test_check_grads_float64(quick_scene_dict):
    scene = clothopt.Scene.from_dict(quick_scene_dict)
    rng = np.random.default_rng(3)
    u = jnp.asarray(scene.initial_controls() + 0.01 * rng.standard_normal(scene.controls_shape))
    check_grads(lambda v: rollout_loss(scene, v), (u,), order=1, modes=["rev"], eps=1e-6)
