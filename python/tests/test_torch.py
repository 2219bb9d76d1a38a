"""The PyTorch adapter, checked with `torch.autograd.gradcheck` in float64.

CI does not install PyTorch (its default wheel pulls the CUDA libraries); run this test with
`pip install torch` and `pytest python/tests/test_torch.py` (see README, "From Python")."""

from __future__ import annotations

import numpy as np
import pytest

torch = pytest.importorskip("torch")

import clothopt  # noqa: E402
from clothopt.torch import rollout_loss  # noqa: E402


def test_values_and_gradient_equal_scene_grad(quick_scene_dict):
    scene = clothopt.Scene.from_dict(quick_scene_dict)
    u = torch.tensor(scene.initial_controls(), requires_grad=True)
    loss = rollout_loss(scene, u)
    loss.backward()
    values, dl_du, _ = scene.grad(scene.initial_controls())
    assert loss.dtype == torch.float64 and loss.item() == values["L"]
    assert np.array_equal(u.grad.numpy(), dl_du)


def test_gradcheck_float64(quick_scene_dict):
    scene = clothopt.Scene.from_dict(quick_scene_dict)
    rng = np.random.default_rng(3)
    u0 = scene.initial_controls() + 0.01 * rng.standard_normal(scene.controls_shape)
    u = torch.tensor(u0, dtype=torch.float64, requires_grad=True)
    assert torch.autograd.gradcheck(
        lambda v: rollout_loss(scene, v), (u,), eps=1e-6, atol=1e-5, rtol=1e-4, fast_mode=True
    )
