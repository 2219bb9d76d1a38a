"""JAX adapter: the rollout loss `L(U)` as a differentiable JAX function (``jax.custom_vjp``).

    import jax, jax.numpy as jnp
    jax.config.update("jax_enable_x64", True)   # the simulator is float64
    from clothopt.jax import rollout_loss
    loss = rollout_loss(scene, jnp.asarray(scene.initial_controls()))
    g = jax.grad(lambda u: rollout_loss(scene, u))(u)  # (T, K, 3), = scene.grad(u)[1]

The simulation runs on the host through ``jax.pure_callback``, so the function also works under
``jax.jit`` and ``jax.vmap`` (sequentially). Only reverse mode is defined (``jax.grad``,
``jax.vjp``); the values are float64 whatever JAX's default precision, cast to the input's dtype.
"""

from __future__ import annotations

import functools
import jax
import jax.numpy as jnp
import numpy as np

from ._clothopt import Scene

__all__ = ["rollout_loss", "rollout_loss_and_grad"]


def rollout_loss_and_grad(scene: Scene, controls: jax.Array):
    """`(L, dL/dU)` of `controls` `(T, K, 3)`, computed on the host (no autodiff)."""
    loss_shape = jax.ShapeDtypeStruct((), controls.dtype)
    grad_shape = jax.ShapeDtypeStruct(controls.shape, controls.dtype)

    def host(u):
        values, dl_du, _ = scene.grad(np.asarray(u, dtype=np.float64))
        dtype = np.dtype(controls.dtype)
        return np.asarray(values["L"], dtype=dtype), dl_du.astype(dtype)

    return jax.pure_callback(host, (loss_shape, grad_shape), controls)


@functools.partial(jax.custom_vjp, nondiff_argnums=(0,))
def _loss(scene: Scene, controls: jax.Array) -> jax.Array:
    return rollout_loss_and_grad(scene, controls)[0]


def _loss_fwd(scene, controls):
    loss, grad = rollout_loss_and_grad(scene, controls)
    return loss, grad


def _loss_bwd(scene, grad, cotangent):
    return (cotangent * grad,)


_loss.defvjp(_loss_fwd, _loss_bwd)


def rollout_loss(scene: Scene, controls: jax.Array) -> jax.Array:
    """The scene's loss ``L = G + αT + βE`` of `controls` `(T, K, 3)` as a JAX scalar,
    differentiable in reverse mode with respect to `controls` (``dL/dU`` from the simulator's
    adjoint, exactly ``scene.grad(controls)[1]``)."""
    return _loss(scene, jnp.asarray(controls))
