"""Scene.fit: the material recovered from observed motion, the CLI's record bit for bit, bad
observations named by their field."""

from __future__ import annotations

import copy
import json
import re
from pathlib import Path

import numpy as np
import pytest

import clothopt
from conftest import REPO, run_cli

LAY = REPO / "examples" / "scenes" / "fit" / "lay.json"
PARAMS = ["stretch", "bending", "friction"]


def lay_motion(scene: clothopt.Scene) -> np.ndarray:
    """`lay` as tests/fit.rs records it: the grippers lowered 0.25 and drawn 0.3 along +y."""
    horizon = scene.horizon

    def at(t: int) -> np.ndarray:
        f = t / horizon
        return np.array([0.0, 0.3 * f, -0.25 * f])

    steps = [np.tile(at(t + 1) - at(t), (scene.n_controls, 1)) for t in range(horizon)]
    return np.stack(steps)


def true_values(d: dict) -> dict[str, float]:
    return {
        "stretch": d["material"]["stretch"],
        "bending": d["material"]["bending"]["stiffness"],
        "friction": d["obstacles"][0]["friction"],
    }


@pytest.fixture(scope="module")
def truth() -> dict:
    return clothopt.Scene.load(str(LAY)).to_dict()


@pytest.fixture(scope="module")
def observed(truth) -> dict:
    """The true scene's rollout seen exactly at 21 free particles every other step: grid
    particles as `[r, c]`, every third as its index (both forms the file allows)."""
    scene = clothopt.Scene.from_dict(truth)
    u = lay_motion(scene)
    states = scene.simulate(u).states
    cols = truth["cloth"]["cols"]
    grippers = {r * cols + c for r, c in truth["controls"]}
    free = [i for i in range(scene.n_particles) if i not in grippers]
    tracked = free[1::3]
    assert len(tracked) == 21
    points = []
    for step in range(2, scene.horizon + 1, 2):
        for n, i in enumerate(tracked):
            particle = i if n % 3 == 0 else [i // cols, i % cols]
            points.append({"particle": particle, "step": step, "position": states[step, i]})
    return {"controls": u, "points": points}  # NumPy arrays: Scene.fit takes them as lists


@pytest.fixture(scope="module")
def off(truth) -> dict:
    """The start: stretch 2.5×, bending 0.4×, friction 1.6× the truth."""
    d = copy.deepcopy(truth)
    d["material"]["stretch"] *= 2.5
    d["material"]["bending"]["stiffness"] *= 0.4
    d["obstacles"][0]["friction"] *= 1.6
    return d


@pytest.fixture(scope="module")
def fitted(off, observed) -> clothopt.Fit:
    return clothopt.Scene.from_dict(off).fit(observed, PARAMS)


def jsonable(observed: dict) -> dict:
    return json.loads(json.dumps(observed, default=lambda a: a.tolist()))


def test_fit_recovers_stretch_bending_and_friction(truth, off, fitted):
    assert fitted.status == "converged" and fitted.converged
    want, start = true_values(truth), true_values(off)
    for name in PARAMS:
        p = fitted.parameters[name]
        assert p["start"] == start[name], name
        assert abs(p["value"] / want[name] - 1) <= 0.01, (name, p["value"], want[name])
        assert p["identifiable"] and not p["at_bound"], name
    assert fitted.parameters["stretch"]["field"] == "material.stretch"
    assert fitted.rms_error < 1e-6 < fitted.rms_error_start
    assert fitted.points == 5 * 21 and fitted.noise["source"] == "estimated"
    assert len(fitted.residual_per_step) == 11 and fitted.residual_per_step[1] is None
    assert fitted.max_error >= fitted.rms_error and fitted.iterations >= 1
    assert "stretch=" in repr(fitted) and "converged" in repr(fitted)
    # The fitted scene holds the fitted values.
    scene = fitted.fitted_scene
    assert isinstance(scene, clothopt.Scene)
    assert true_values(scene.to_dict()) == {n: fitted.parameters[n]["value"] for n in PARAMS}
    assert fitted.to_dict()["parameters"] == fitted.parameters


def test_fit_equals_cli(cli, off, observed, fitted, tmp_path):
    scene_file, obs_file = tmp_path / "off.json", tmp_path / "observed.json"
    scene_file.write_text(json.dumps(off))
    obs_file.write_text(json.dumps(jsonable(observed)))
    out, scene_out = tmp_path / "fit.json", tmp_path / "fitted.json"
    done = run_cli(cli, "fit", str(scene_file), "--observed", str(obs_file), "--params",
                   ",".join(PARAMS), "--out", str(out), "--scene-out", str(scene_out))
    assert "converged" in done.stdout
    # The printed summary, its wall time aside.
    assert re.sub(r", [0-9.]+ s\)", ")", done.stdout, count=1) == fitted.summary(timing=False)
    expected = json.loads(out.read_text())
    assert expected.pop("wall_s") >= 0  # the one field that differs from run to run
    # The same inputs as paths and a comma-separated string, as the CLI takes them.
    from_files = clothopt.Scene.load(str(scene_file)).fit(obs_file, "stretch, bending,friction")
    for result in (fitted, from_files):
        got = result.to_dict()
        assert got.pop("wall_s") >= 0
        assert got == expected  # every number bit for bit: the same code on the same floats
        for name in PARAMS:
            assert result.parameters[name]["value"] == expected["parameters"][name]["value"]
        mine = tmp_path / "mine.json"
        result.save_scene(mine)
        assert mine.read_bytes() == scene_out.read_bytes()
        result.save(mine)
        assert json.loads(mine.read_text()) == result.to_dict()
        assert json.loads(result.to_json()) == result.to_dict()
    assert fitted.fitted_scene.to_dict() == json.loads(scene_out.read_text())


def with_edit(observed: dict, edit) -> dict:
    d = copy.deepcopy(jsonable(observed))
    edit(d)
    return d


@pytest.mark.parametrize(
    "edit, pattern",
    [
        (lambda d: d["points"][0].update(particle=[2, 9]),
         r"^observations: points\[0\]\.particle: \(2, 9\) is not a particle of the cloth"),
        (lambda d: d["points"][1].update(particle=64),
         r"^observations: points\[1\]\.particle: vertex 64 is not a particle"),
        (lambda d: d["points"][2].update(step=11), r"points\[2\]\.step: step 11 .* 1 to 10"),
        (lambda d: d["controls"].pop(), r"^observations: controls: .*expected 10 steps"),
        (lambda d: d.update(noise=-1.0), r"^observations: noise: .*> 0"),
        (lambda d: d.update(points=[]), r"^observations: points: no tracked points"),
        (lambda d: d.update(extra=1), r"^observations: extra: unknown field `extra`"),
        (lambda d: d["points"][3]["position"].__setitem__(1, float("nan")),
         r"^observations: points\[3\]\.position\[1\]: not a finite number"),
    ],
)
def test_bad_observation_names_the_field(observed, edit, pattern):
    scene = clothopt.Scene.load(str(LAY))
    with pytest.raises(ValueError, match=pattern):
        scene.fit(with_edit(observed, edit), PARAMS)


def test_bad_observation_file_has_the_cli_message(cli, observed, tmp_path):
    bad = tmp_path / "bad.json"
    unknown = with_edit(observed, lambda d: d["points"][0].update(particle=[2, 9]))
    bad.write_text(json.dumps(unknown))
    with pytest.raises(ValueError, match=r"points\[0\]\.particle") as raised:
        clothopt.Scene.load(str(LAY)).fit(str(bad), PARAMS)
    assert str(raised.value).startswith(f"observations: {bad}: points[0].particle: ")
    done = run_cli(cli, "fit", str(LAY), "--observed", str(bad), "--params", "stretch", ok=(1,))
    assert done.stderr == f"error: {raised.value}\n"
    with pytest.raises(FileNotFoundError, match="missing.json"):
        clothopt.Scene.load(str(LAY)).fit(tmp_path / "missing.json", PARAMS)


@pytest.mark.parametrize(
    "params, kwargs, error, pattern",
    [
        (["stiff"], {}, ValueError, r"custom_constraints \(type `stiff`\): no parameter `stiff`"),
        ([], {}, ValueError, r"params must name at least one parameter"),
        (PARAMS, {"range": 1.0}, ValueError, r"range must be a finite factor > 1, got 1"),
        (PARAMS, {"max_iterations": 0}, ValueError, r"max_iterations"),
        (3, {}, TypeError, r"params: expected a list of parameter names"),
    ],
)
def test_bad_parameters_and_settings(observed, params, kwargs, error, pattern):
    with pytest.raises(error, match=pattern):
        clothopt.Scene.load(str(LAY)).fit(observed, params, **kwargs)


def test_observed_of_the_wrong_type():
    with pytest.raises(TypeError, match=r"observed: expected the observation JSON as a dict"):
        clothopt.Scene.load(str(LAY)).fit(42, PARAMS)
    with pytest.raises(TypeError, match=r"observed: not writable as JSON"):
        clothopt.Scene.load(str(LAY)).fit({"controls": {1, 2}}, PARAMS)
