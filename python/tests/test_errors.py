"""Bad input raises a Python exception whose message names the field or setting."""

from __future__ import annotations

import copy

import numpy as np
import pytest

import clothopt


def test_invalid_scene_field_is_value_error(quick_scene_dict):
    d = copy.deepcopy(quick_scene_dict)
    d["physics"]["iterations"] = 0
    with pytest.raises(ValueError, match=r"physics\.iterations"):
        clothopt.Scene.from_dict(d)


def test_unknown_scene_field_is_value_error(quick_scene_dict):
    d = copy.deepcopy(quick_scene_dict)
    d["task"]["no_such_field"] = 1
    with pytest.raises(ValueError, match="no_such_field"):
        clothopt.Scene.from_dict(d)


def test_unknown_builtin_lists_the_scenes():
    with pytest.raises(ValueError, match=r"unknown built-in scene `nope`.*u_obstacle"):
        clothopt.Scene.load("nope")


def test_missing_file_is_file_not_found(tmp_path):
    with pytest.raises(FileNotFoundError, match="missing.json"):
        clothopt.Scene.load(str(tmp_path / "missing.json"))


def test_controls_of_the_wrong_shape():
    scene = clothopt.Scene.load("u_obstacle")
    with pytest.raises(ValueError, match=r"controls: expected shape \(10, 2, 3\)"):
        scene.grad(np.zeros((9, 2, 3)))


def test_non_finite_controls():
    scene = clothopt.Scene.load("u_obstacle")
    u = scene.initial_controls()
    u[3, 1, 2] = np.nan
    with pytest.raises(ValueError, match="controls"):
        scene.simulate(u)


@pytest.mark.parametrize(
    "kwargs, pattern",
    [
        ({"delta": -1.0}, r"delta must be a finite number ≥ 0, got -1"),
        ({"kappa": 0.0}, r"kappa must be a finite number > 0"),
        ({"iterations": 0}, r"iterations must be at least 1"),
        ({"starts": 0}, r"starts must be at least 1"),
        ({"solver": "newton"}, r"solver: must be one of 'sqp', 'lbfgs', got 'newton'"),
        ({"search": "maybe"}, r"search: must be one of 'auto', 'always', 'off'"),
        ({"safety": "soft"}, r"safety: must be one of 'per_step', 'aggregate', 'scalar'"),
        (
            {"target_model": "newton"},
            r"target_model: must be one of 'gauss_newton', 'bfgs', got 'newton'",
        ),
        ({"check": "xpbd"}, r"check must be `xpbd:N`, `newton`, `newton:TOL`, `newton-branch` or `newton-branch:H`, got `xpbd`"),
        ({"check": "newton:2"}, r"check needs Newton's tolerance in \(0, 1\)"),
    ],
)
def test_bad_optimize_settings(kwargs, pattern):
    scene = clothopt.Scene.load("u_obstacle")
    with pytest.raises(ValueError, match=pattern):
        scene.optimize(**kwargs)


def test_bad_delta_of_grad():
    with pytest.raises(ValueError, match="delta"):
        clothopt.Scene.load("u_obstacle").grad(delta=float("nan"))


def test_step_only_and_swept_that_contradict_are_value_error():
    scene = clothopt.Scene.load("u_obstacle")
    with pytest.raises(ValueError, match=r"step_only=True and swept=True contradict"):
        scene.optimize(iterations=1, search="off", step_only=True, swept=True)
