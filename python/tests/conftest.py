"""Shared fixtures: the CLI binary the bindings are compared against, and a quick scene."""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import pytest

import clothopt

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def cli() -> Path:
    """The `clothopt` CLI built from the same sources (`CLOTHOPT_BIN`, else
    `target/release/clothopt`, which `cargo test --release` or `cargo build --release` makes)."""
    path = Path(os.environ.get("CLOTHOPT_BIN", REPO / "target" / "release" / "clothopt"))
    if not path.exists():
        pytest.fail(f"{path} not found: run `cargo build --release` first (or set CLOTHOPT_BIN)")
    return path


def run_cli(cli: Path, *args: str, ok=(0,)) -> subprocess.CompletedProcess:
    """Runs the CLI; fails the test on an unexpected exit code."""
    done = subprocess.run([str(cli), *args], capture_output=True, text=True)
    assert done.returncode in ok, f"clothopt {' '.join(args)} exited {done.returncode}: {done.stderr}"
    return done


@pytest.fixture(scope="session")
def quick_scene_dict() -> dict:
    """u_obstacle with 10 solver sweeps per step instead of 100, so every test stays fast."""
    d = clothopt.Scene.load("u_obstacle").to_dict()
    d["physics"]["iterations"] = 10
    return d


@pytest.fixture(scope="session")
def quick_scene_file(tmp_path_factory, quick_scene_dict) -> Path:
    """The quick scene as a JSON file the CLI can read."""
    path = tmp_path_factory.mktemp("scene") / "quick.json"
    path.write_text(json.dumps(quick_scene_dict))
    return path
