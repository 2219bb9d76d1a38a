"""Type hints of the native module (`python/src/*.rs`)."""

from __future__ import annotations

import os
from typing import Any, Optional, Union

import numpy as np
import numpy.typing as npt

ArrayLike = npt.ArrayLike
F64Array = npt.NDArray[np.float64]

def builtin_scenes() -> list[tuple[str, str]]:
    """The built-in scene names and their one-line descriptions."""

class Scene:
    """A validated, compiled cloth scene. Controls are float64 arrays `(T, K, 3)`."""

    @classmethod
    def load(cls, name_or_path: str) -> Scene:
        """A built-in scene by name or a scene JSON file; ValueError names a bad field."""
    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Scene:
        """A scene from a dict in the scene JSON format; ValueError names a bad field."""
    def to_dict(self) -> dict[str, Any]:
        """The scene in the scene JSON format."""
    def with_initial_state(self, positions: ArrayLike, settle: bool = True) -> Scene:
        """The scene with the cloth starting at `positions` `(N, 3)` (its `cloth.initial_state`);
        settled when not at rest (`settle=False`: refused); ValueError names a bad start."""
    def start(self) -> F64Array:
        """The cloth's positions at step 0, `(N, 3)`."""
    @property
    def name(self) -> str: ...
    @property
    def horizon(self) -> int:
        """Steps `T`."""
    @property
    def n_particles(self) -> int:
        """Cloth particles `N`."""
    @property
    def n_controls(self) -> int:
        """Control points `K`."""
    @property
    def delta_default(self) -> float:
        """The scene's safety margin δ."""
    @property
    def controls_shape(self) -> tuple[int, int, int]:
        """`(T, K, 3)`."""
    def initial_controls(self) -> F64Array:
        """The scene's initial guess, `(T, K, 3)`."""
    def simulate(
        self, controls: Optional[ArrayLike] = None, delta: Optional[float] = None
    ) -> Rollout:
        """Simulates `(T, K, 3)` controls (default the initial guess); states `(T+1, N, 3)`."""
    def grad(
        self, controls: Optional[ArrayLike] = None, delta: Optional[float] = None
    ) -> tuple[dict[str, float], F64Array, F64Array]:
        """`(values, dL_dU, dC_dU)`: L, G, T, E, C, min_sdf and two `(T, K, 3)` gradients."""
    def optimize(
        self,
        delta: Optional[float] = None,
        *,
        alpha: Optional[float] = None,
        beta: Optional[float] = None,
        iterations: int = 200,
        solver: str = "sqp",
        search: str = "auto",
        starts: int = 6,
        safety: str = "per_step",
        step_only: Optional[bool] = None,
        swept: Optional[bool] = None,
        kappa: Optional[float] = None,
        reuse_band: Optional[float] = None,
        trial_work_factor: Optional[float] = None,
        tol: float = 1e-4,
        feasibility_tol: float = 1e-8,
        allow_unsafe_start: bool = False,
        time_limit: Optional[float] = None,
        start: Optional[ArrayLike] = None,
        timing: bool = True,
        check: Optional[str] = None,
        check_rounds: int = 3,
        target_model: str = "bfgs",
    ) -> Plan:
        """Plans the task as `clothopt optimize` does (same defaults)."""

class Rollout:
    """A simulated control sequence."""

    @property
    def states(self) -> F64Array:
        """`(T+1, N, 3)`, the first the rest state."""
    @property
    def controls(self) -> F64Array:
        """`(T, K, 3)`."""
    @property
    def delta(self) -> float: ...
    @property
    def metrics(self) -> dict[str, Any]:
        """G, T, E, alpha_t, beta_e, C, min_sdf, min_sdf_swept, L (floats) and, with colliders,
        max_penetration (a dict of depth, step and particle)."""

class Plan:
    """An optimizer's result (the record `clothopt optimize --out` writes)."""

    @property
    def status(self) -> str: ...
    @property
    def message(self) -> str: ...
    @property
    def achieved(self) -> bool: ...
    @property
    def safe(self) -> bool: ...
    @property
    def task(self) -> dict[str, Any]: ...
    @property
    def delta(self) -> float: ...
    @property
    def iterations(self) -> int: ...
    @property
    def controls(self) -> F64Array:
        """`(T, K, 3)`."""
    @property
    def states(self) -> Optional[F64Array]:
        """`(T+1, N, 3)`."""
    @property
    def metrics(self) -> dict[str, Any]: ...
    @property
    def warnings(self) -> list[str]: ...
    def summary(self, timing: bool = True) -> str:
        """The summary `clothopt optimize` prints (verdict, counts, route search, metrics)."""
    def to_json(self) -> str: ...
    def to_dict(self) -> dict[str, Any]: ...
    def save(self, path: Union[str, os.PathLike[str]]) -> None:
        """Writes the result JSON atomically."""
