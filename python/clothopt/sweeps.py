"""Sweeps on Ray: one plan per task, one result JSON per task, a summary CSV, resumable.

    import clothopt
    rows = clothopt.sweep(["u_obstacle"], {"delta": [0.05, 0.2, 0.4]}, "out/delta")

Each task is a scene and one point of the grid (keyword arguments of
:meth:`clothopt.Scene.optimize`). Ray runs the tasks: ``ray.init()`` starts a local instance by
default; ``address="ray://host:10001"`` (or ``"auto"``) runs the same sweep on a cluster. A task
whose result file exists is skipped (resume after an interruption by calling the same sweep again).
"""

from __future__ import annotations

import csv
import io
import itertools
import json
import math
import os
import re
import sys
import tempfile
from pathlib import Path
from typing import Any, Iterable, Mapping, Optional, Sequence, Union

from ._clothopt import Scene

__all__ = ["sweep", "tasks_of", "SUMMARY_COLUMNS"]

SceneSpec = Union[str, os.PathLike, Scene, Mapping[str, Any]]
Grid = Union[Mapping[str, Sequence[Any]], Sequence[Mapping[str, Any]]]

#: Columns of ``summary.csv`` after ``task``, ``scene`` and the grid's keys.
SUMMARY_COLUMNS = [
    "status", "achieved", "safe", "reason", "L", "G", "T", "E", "C", "min_sdf",
    "iterations", "file",
]


def _scene_dict(spec: SceneSpec) -> dict:
    """A scene given by name, path, `Scene` or dict, as a validated scene dict (so a task sent
    to another machine needs no file there)."""
    if isinstance(spec, Scene):
        return spec.to_dict()
    if isinstance(spec, Mapping):
        return Scene.from_dict(dict(spec)).to_dict()
    return Scene.load(os.fspath(spec)).to_dict()


def _grid_points(grid: Grid) -> list[dict]:
    """The grid's points: the product of a dict's value lists, or an explicit list of dicts."""
    if isinstance(grid, Mapping):
        keys = list(grid)
        for k in keys:
            if isinstance(grid[k], (str, bytes)) or not isinstance(grid[k], Iterable):
                raise ValueError(f"grid[{k!r}]: must be a list of values, got {grid[k]!r}")
        return [dict(zip(keys, values)) for values in itertools.product(*(grid[k] for k in keys))]
    points = [dict(p) for p in grid]
    for i, p in enumerate(points):
        if not isinstance(p, dict):
            raise ValueError(f"grid[{i}]: must be a dict of optimize() arguments")
    return points


def _slug(value: Any) -> str:
    text = "default" if value is None else str(value)
    return re.sub(r"[^A-Za-z0-9.+-]+", "_", text).strip("_") or "_"


def tasks_of(scenes: Sequence[SceneSpec], grid: Grid) -> list[dict]:
    """The sweep's tasks in order: every scene × every grid point. Each task is a dict with
    ``id`` (unique, used as the result's file name), ``scene`` (its name), ``scene_dict`` and
    ``options`` (the :meth:`Scene.optimize` arguments). ``None`` in a grid means the scene's own
    value (e.g. ``{"alpha": [0.0, None]}``: without the term, and with the scene's weight)."""
    if isinstance(scenes, (str, bytes, os.PathLike, Scene, Mapping)):
        scenes = [scenes]
    points = _grid_points(grid)
    tasks, seen = [], set()
    for spec in scenes:
        scene = _scene_dict(spec)
        for point in points:
            parts = [_slug(scene["name"])] + [f"{_slug(k)}={_slug(v)}" for k, v in point.items()]
            task_id = "__".join(parts)
            if task_id in seen:
                raise ValueError(f"two tasks would both be written to {task_id}.json")
            seen.add(task_id)
            options = {k: v for k, v in point.items() if v is not None}
            tasks.append({"id": task_id, "scene": scene["name"], "scene_dict": scene,
                          "options": options, "point": point})
    return tasks


def _write_atomic(path: Path, text: str) -> None:
    """Writes `text` through a temporary file in the same directory and a rename."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def run_task(task: dict, out_dir: str, timing: bool) -> dict:
    """Plans one task and writes its result JSON atomically; returns its summary row. Runs in a
    Ray worker (or anywhere: it needs only the task and a writable `out_dir`)."""
    scene = Scene.from_dict(task["scene_dict"])
    plan = scene.optimize(timing=timing, **task["options"])
    path = Path(out_dir) / f"{task['id']}.json"
    record = plan.to_dict()
    record["sweep_task"] = {"id": task["id"], "options": task["point"]}
    _write_atomic(path, json.dumps(record, indent=2, allow_nan=True))
    return _row(task, record, path)


def _row(task: dict, record: dict, path: Path) -> dict:
    metrics = record.get("metrics", {})
    verdict = record.get("task", {})
    row = {"task": task["id"], "scene": task["scene"]}
    row.update({k: ("" if v is None else v) for k, v in task["point"].items()})
    row.update({
        "status": record.get("status"),
        "achieved": verdict.get("achieved"),
        "safe": None,
        "reason": verdict.get("reason"),
        "file": path.name,
    })
    for k in ("L", "G", "T", "E", "C", "min_sdf"):
        v = metrics.get(k)
        row[k] = math.inf if v is None and k == "min_sdf" else v
    c, tol = metrics.get("C"), record.get("feasibility_tolerance")
    row["safe"] = None if c is None else bool(c >= -(tol if tol is not None else 1e-8))
    row["iterations"] = record.get("iterations")
    return row


def _progress(total: int, done: int, enabled: bool):
    """A tqdm bar if tqdm is installed, else one line per finished task on stderr."""
    if not enabled:
        return None
    try:
        from tqdm.auto import tqdm
    except ImportError:
        return None
    return tqdm(total=total, initial=done, desc="sweep", unit="plan")


def sweep(
    scenes: Union[SceneSpec, Sequence[SceneSpec]],
    grid: Grid,
    out_dir: Union[str, os.PathLike],
    *,
    address: Optional[str] = None,
    num_cpus: Optional[int] = None,
    threads_per_task: int = 1,
    timing: bool = False,
    progress: bool = True,
) -> list[dict]:
    """Runs one plan per task (every scene × every grid point) on Ray and returns the summary
    rows in task order.

    - `scenes`: built-in names, scene JSON paths, `Scene` objects or scene dicts.
    - `grid`: ``{"delta": [0.05, 0.2], "safety": ["per_step", "scalar"]}`` (the product) or a
      list of argument dicts; keys are :meth:`Scene.optimize` arguments, ``None`` the scene's own.
    - `out_dir`: gets ``<task id>.json`` per task (the result JSON, written atomically, with a
      ``sweep_task`` entry) and ``summary.csv`` (one row per task). A task whose JSON exists is
      skipped and read back: calling the same sweep again resumes it.
    - `address`: ``None`` starts a local Ray instance (``ray.init()``) unless one is running;
      a cluster's address runs there (every node needs ``clothopt`` installed and `out_dir`
      shared). `num_cpus` caps a local instance.
    - `threads_per_task`: rayon threads inside each plan (results are identical for any count).
    - `timing`: keep wall-clock times in the results (off: byte-identical reruns).
    - `progress`: a tqdm bar if tqdm is installed, else a line per finished task on stderr.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    if threads_per_task < 1:
        raise ValueError(f"threads_per_task: must be at least 1, got {threads_per_task}")
    tasks = tasks_of(scenes, grid)
    rows: list[Optional[dict]] = [None] * len(tasks)
    pending = []
    for i, task in enumerate(tasks):
        path = out / f"{task['id']}.json"
        if path.exists():
            rows[i] = _row(task, json.loads(path.read_text(encoding="utf-8")), path)
        else:
            pending.append(i)
    done = len(tasks) - len(pending)
    bar = _progress(len(tasks), done, progress)
    if progress and bar is None:
        print(f"sweep: {len(tasks)} tasks, {done} already done", file=sys.stderr)
    if pending:
        import ray

        if not ray.is_initialized():
            ray.init(address=address, num_cpus=num_cpus, include_dashboard=False,
                     log_to_driver=False)
        remote = ray.remote(num_cpus=threads_per_task)(run_task).options(
            runtime_env={"env_vars": {"RAYON_NUM_THREADS": str(threads_per_task)}})
        refs = {remote.remote(tasks[i], str(out.resolve()), timing): i for i in pending}
        waiting = list(refs)
        while waiting:
            ready, waiting = ray.wait(waiting, num_returns=1)
            i = refs[ready[0]]
            rows[i] = ray.get(ready[0])
            done += 1
            if bar is not None:
                bar.update(1)
            elif progress:
                r = rows[i]
                print(f"[{done}/{len(tasks)}] {r['task']}: {r['status']}, L {r['L']}",
                      file=sys.stderr)
    if bar is not None:
        bar.close()
    _write_summary(out / "summary.csv", tasks, rows)
    return rows  # type: ignore[return-value]


def _write_summary(path: Path, tasks: list[dict], rows: list[Optional[dict]]) -> None:
    keys: list[str] = []
    for task in tasks:
        keys += [k for k in task["point"] if k not in keys]
    columns = ["task", "scene"] + keys + SUMMARY_COLUMNS
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=columns, extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow(row)
    _write_atomic(path, buffer.getvalue())
