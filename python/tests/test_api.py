"""The bindings against the CLI: the same values and gradients bit for bit, the same plan."""

from __future__ import annotations

import json

import numpy as np
import pytest

import clothopt
from conftest import run_cli


def cli_grad(cli, scene: str, *extra: str) -> dict:
    return json.loads(run_cli(cli, "grad", scene, *extra).stdout)


def test_builtin_scenes_and_repr():
    names = [n for n, _ in clothopt.builtin_scenes()]
    assert {"u_obstacle", "swing", "drop"} <= set(names)
    scene = clothopt.Scene.load("u_obstacle")
    assert scene.name == "u_obstacle"
    assert scene.controls_shape == (scene.horizon, scene.n_controls, 3)
    assert "u_obstacle" in repr(scene) and "horizon=10" in repr(scene)


def test_initial_controls_shape_and_dtype():
    scene = clothopt.Scene.load("u_obstacle")
    u = scene.initial_controls()
    assert u.dtype == np.float64 and u.shape == (10, scene.n_controls, 3)


@pytest.mark.parametrize("name", ["u_obstacle", "swing"])
def test_grad_equals_cli_bit_for_bit(cli, name):
    scene = clothopt.Scene.load(name)
    values, dl_du, dc_du = scene.grad()
    expected = cli_grad(cli, name)
    for key in ("L", "G", "T", "E", "C", "min_sdf"):
        # Exact: same code, same floats (JSON writes ∞, min_sdf without obstacles, as null).
        want = float("inf") if expected[key] is None else expected[key]
        assert values[key] == want, key
    assert dl_du.dtype == np.float64 and dl_du.shape == scene.controls_shape
    assert np.array_equal(dl_du, np.array(expected["grad_L"]))
    if expected["grad_C"] is None:  # no safety obstacles: C ≡ 0
        assert not dc_du.any()
    else:
        assert np.array_equal(dc_du, np.array(expected["grad_C"]))
        assert np.abs(dc_du).max() > 0 or values["C"] == 0


def test_grad_of_given_controls_and_delta_equals_cli(cli, quick_scene_file, tmp_path):
    scene = clothopt.Scene.load(str(quick_scene_file))
    rng = np.random.default_rng(7)
    u = scene.initial_controls() + 0.01 * rng.standard_normal(scene.controls_shape)
    controls = tmp_path / "u.json"
    controls.write_text(json.dumps({"controls": u.tolist()}))
    values, dl_du, dc_du = scene.grad(u, delta=0.3)
    expected = cli_grad(cli, str(quick_scene_file), "--controls", str(controls), "--delta", "0.3")
    assert values["L"] == expected["L"] and values["C"] == expected["C"]
    assert values["C"] < 0  # δ = 0.3 is violated by the initial guess, so dC/dU is informative
    assert np.array_equal(dl_du, np.array(expected["grad_L"]))
    assert np.array_equal(dc_du, np.array(expected["grad_C"]))
    # The flat (T, 3K) layout and a non-contiguous array give the same result.
    flat = u.reshape(scene.horizon, -1)
    assert np.array_equal(scene.grad(flat, delta=0.3)[1], dl_du)
    fortran = np.asfortranarray(u)
    assert np.array_equal(scene.grad(fortran, delta=0.3)[2], dc_du)


def test_simulate_equals_cli(cli, quick_scene_file, tmp_path):
    scene = clothopt.Scene.load(str(quick_scene_file))
    rollout = scene.simulate()
    out = tmp_path / "sim.json"
    run_cli(cli, "simulate", str(quick_scene_file), "--out", str(out))
    expected = json.loads(out.read_text())
    assert rollout.states.shape == (scene.horizon + 1, scene.n_particles, 3)
    assert np.array_equal(rollout.states, np.array(expected["states"]))
    assert np.array_equal(rollout.controls, np.array(expected["controls"]))
    for key, value in expected["metrics"].items():
        assert rollout.metrics[key] == value, key
    assert "Rollout(L=" in repr(rollout)


def test_from_dict_round_trip(quick_scene_dict):
    scene = clothopt.Scene.from_dict(quick_scene_dict)
    assert scene.to_dict() == quick_scene_dict


def test_small_optimize_equals_cli(cli, quick_scene_file, tmp_path):
    scene = clothopt.Scene.load(str(quick_scene_file))
    plan = scene.optimize(iterations=3, search="off", timing=False)
    out = tmp_path / "plan.json"
    done = run_cli(cli, "optimize", str(quick_scene_file), "--iterations", "3", "--search", "off",
                   "--no-timing", "--out", str(out), ok=(0, 3, 4))
    assert plan.to_json() == out.read_text()  # the same record, byte for byte
    assert plan.summary(timing=False) == done.stdout  # the same summary the CLI prints
    assert "wall" in plan.summary() and "wall" not in plan.summary(timing=False)
    assert plan.controls.shape == scene.controls_shape
    assert plan.states.shape == (scene.horizon + 1, scene.n_particles, 3)
    assert plan.metrics["L"] == plan.to_dict()["metrics"]["L"]
    assert isinstance(plan.achieved, bool) and plan.task["achieved"] == plan.achieved
    assert plan.status in repr(plan)
    saved = tmp_path / "saved.json"
    plan.save(saved)
    assert saved.read_text() == plan.to_json()
    # The planned controls simulate to the reported metrics.
    assert scene.simulate(plan.controls, delta=plan.delta).metrics["L"] == plan.metrics["L"]


def test_checked_optimize_equals_cli(cli, quick_scene_file, tmp_path):
    scene = clothopt.Scene.load(str(quick_scene_file))
    plan = scene.optimize(iterations=3, search="off", timing=False, check="xpbd:50", check_rounds=1)
    out = tmp_path / "checked.json"
    run_cli(cli, "optimize", str(quick_scene_file), "--iterations", "3", "--search", "off",
            "--no-timing", "--check", "xpbd:50", "--check-rounds", "1", "--out", str(out),
            ok=(0, 3, 4))
    assert plan.to_json() == out.read_text()
    check = plan.to_dict()["check"]
    assert check["physics"] == {"solver": "xpbd", "iterations": 50}
    assert 1 <= len(check["rounds"]) <= 2


def test_step_only_optimize_equals_cli(cli, quick_scene_file, tmp_path):
    scene = clothopt.Scene.load(str(quick_scene_file))
    plan = scene.optimize(iterations=3, search="off", timing=False, step_only=True)
    out = tmp_path / "step_only.json"
    done = run_cli(cli, "optimize", str(quick_scene_file), "--iterations", "3", "--search", "off",
                   "--no-timing", "--step-only", "--out", str(out), ok=(0, 3, 4))
    assert plan.to_json() == out.read_text()
    assert plan.summary(timing=False) == done.stdout
    assert "(step-only check" in done.stdout.splitlines()[0]
    assert plan.to_dict()["safety"]["check"] == "step_only"
    # The old keyword: swept=False is step_only=True; the default checks the motion between steps.
    assert scene.optimize(iterations=3, search="off", timing=False, swept=False).to_json() == plan.to_json()
    continuous = scene.optimize(iterations=3, search="off", timing=False)
    assert continuous.to_dict()["safety"]["check"] == "continuous"
