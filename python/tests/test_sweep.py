"""A two-task sweep on a local Ray instance with 2 CPUs; a second call resumes (skips done tasks)."""

from __future__ import annotations

import csv
import json

import pytest

ray = pytest.importorskip("ray")

import clothopt  # noqa: E402
from clothopt.sweeps import tasks_of  # noqa: E402


@pytest.fixture(scope="module")
def local_ray():
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield
    ray.shutdown()


def test_tasks_of_grid_product_and_scene_defaults(quick_scene_dict):
    tasks = tasks_of([quick_scene_dict], {"delta": [0.1, 0.2], "alpha": [0.0, None]})
    assert [t["id"] for t in tasks] == [
        "u_obstacle__delta=0.1__alpha=0.0", "u_obstacle__delta=0.1__alpha=default",
        "u_obstacle__delta=0.2__alpha=0.0", "u_obstacle__delta=0.2__alpha=default",
    ]
    assert tasks[1]["options"] == {"delta": 0.1}  # None: the scene's own α
    with pytest.raises(ValueError, match=r"grid\['delta'\]"):
        tasks_of(["u_obstacle"], {"delta": 0.2})


def test_two_task_sweep_and_resume(local_ray, quick_scene_dict, tmp_path):
    grid = [{"delta": 0.1, "iterations": 2, "search": "off"},
            {"delta": 0.2, "iterations": 2, "search": "off"}]
    rows = clothopt.sweep([quick_scene_dict], grid, tmp_path, progress=False)
    files = sorted(p.name for p in tmp_path.glob("*.json"))
    assert files == [r["file"] for r in rows] and len(files) == 2
    assert not list(tmp_path.glob(".*tmp"))  # no temporary file left behind
    scene = clothopt.Scene.from_dict(quick_scene_dict)
    for row, point in zip(rows, grid):
        record = json.loads((tmp_path / row["file"]).read_text())
        assert record["delta"] == point["delta"] and record["sweep_task"]["options"] == point
        # Each task's result is the plan the API makes with the same settings.
        plan = scene.optimize(timing=False, **point)
        assert record["metrics"]["L"] == plan.metrics["L"] == row["L"]
    with open(tmp_path / "summary.csv", newline="") as f:
        summary = list(csv.DictReader(f))
    assert [r["task"] for r in summary] == [r["task"] for r in rows]
    assert [float(r["delta"]) for r in summary] == [0.1, 0.2]

    # Resume: the finished tasks are skipped (their files untouched), a removed one is redone.
    first = tmp_path / rows[0]["file"]
    second = tmp_path / rows[1]["file"]
    mtime = first.stat().st_mtime_ns
    second.unlink()
    again = clothopt.sweep([quick_scene_dict], grid, tmp_path, progress=False)
    assert first.stat().st_mtime_ns == mtime
    assert second.exists()
    assert [r["L"] for r in again] == [r["L"] for r in rows]
