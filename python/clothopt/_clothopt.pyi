"""Type hints of the native module (`python/src/*.rs`)."""

from __future__ import annotations

import os
from typing import Any, Optional, Sequence, Union

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
    def fit(
        self,
        observed: Union[dict[str, Any], str, os.PathLike[str]],
        params: Union[Sequence[str], str],
        max_iterations: int = 50,
        range: float = 1e3,
    ) -> Fit:
        """Fits material parameters to observed motion as `clothopt fit` does, from this scene's
        values: `observed` the observation JSON (dict) or its file, `params` names ("stretch",
        "bending", a custom constraint type, "mass", "gravity", "friction"), a list or
        comma-separated. ValueError names a bad field, e.g. `points[0].particle`."""

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

class Fit:
    """A material fit's result (the record `clothopt fit --out` writes) and the fitted scene."""

    def summary(self, timing: bool = True) -> str:
        """The text `clothopt fit` prints (timing=False leaves out the wall time)."""

    @property
    def status(self) -> str:
        """"converged", "stalled" or "iteration_limit"."""
    @property
    def converged(self) -> bool: ...
    @property
    def parameters(self) -> dict[str, dict[str, Any]]:
        """By name: field, start, value, std_error, relative_std_error, identifiable, at_bound."""
    @property
    def noise(self) -> dict[str, Any]:
        """`value` and `source` ("given" or "estimated")."""
    @property
    def iterations(self) -> int: ...
    @property
    def simulations(self) -> int: ...
    @property
    def wall_s(self) -> float: ...
    @property
    def points(self) -> int: ...
    @property
    def rms_error_start(self) -> float: ...
    @property
    def rms_error(self) -> float: ...
    @property
    def max_error(self) -> float: ...
    @property
    def residual_per_step(self) -> list[Optional[float]]:
        """Per step, the RMS distance of the points seen then (None where none was)."""
    @property
    def fitted_scene(self) -> Scene:
        """The scene with the fitted values (its contact barrier pinned)."""
    def to_json(self) -> str: ...
    def to_dict(self) -> dict[str, Any]: ...
    def save(self, path: Union[str, os.PathLike[str]]) -> None:
        """Writes the result JSON atomically, as `--out`."""
    def save_scene(self, path: Union[str, os.PathLike[str]]) -> None:
        """Writes the fitted scene atomically, as `--scene-out` (the same bytes)."""
