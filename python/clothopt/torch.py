"""PyTorch adapter: the rollout loss `L(U)` as a ``torch.autograd.Function``.

    import torch
    from clothopt.torch import rollout_loss
    u = torch.tensor(scene.initial_controls(), requires_grad=True)   # float64, (T, K, 3)
    loss = rollout_loss(scene, u)
    loss.backward()                                                # u.grad = dL/dU

The simulation runs on the CPU in float64; a tensor of another dtype or device is converted for
the call and the results are converted back. Only first derivatives are defined.
"""

from __future__ import annotations

import numpy as np
import torch

from ._clothopt import Scene

__all__ = ["RolloutLoss", "rollout_loss"]


class RolloutLoss(torch.autograd.Function):
    """``L = G + αT + βE`` of a scene's controls; backward multiplies ``dL/dU`` by the incoming
    gradient."""

    @staticmethod
    def forward(ctx, controls: torch.Tensor, scene: Scene):
        u = controls.detach().to(device="cpu", dtype=torch.float64).numpy()
        values, dl_du, _ = scene.grad(np.ascontiguousarray(u))
        ctx.save_for_backward(torch.from_numpy(dl_du).to(controls.device, controls.dtype))
        return torch.tensor(values["L"], dtype=controls.dtype, device=controls.device)

    @staticmethod
    def backward(ctx, grad_output: torch.Tensor):
        (dl_du,) = ctx.saved_tensors
        return grad_output * dl_du, None


def rollout_loss(
    scene: Scene, controls: torch.Tensor
) -> torch.Tensor:
    """The scene's loss of `controls` `(T, K, 3)` as a 0-d tensor with a gradient
    ``dL/dU`` (exactly ``scene.grad(controls)[1]``)."""
    return RolloutLoss.apply(controls, scene)
