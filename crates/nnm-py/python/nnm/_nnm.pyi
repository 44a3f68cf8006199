# Stubs of the native module (crates/nnm-py/src/). Private: use the `nnm` package.
from typing import Any, Callable

import numpy as np

SETTINGS_KEYS: list[str]
FAMILIES: list[str]
# (key, name, unit, doc, kind, csv, per_output_dof) of each point column, in declaration order.
POINT_COLUMNS: list[tuple[str, str, str, str, str, bool, bool]]
__version__: str
# The keys of a forced response's settings (nnm_io::job::RESPONSE_SETTINGS_KEYS).
RESPONSE_SETTINGS_KEYS: list[str]
# Their defaults (nnm::forced::ResponseSettings::default()).
RESPONSE_DEFAULTS: dict[str, Any]
# The columns of a response's points, as POINT_COLUMNS for a branch's.
RESPONSE_COLUMNS: list[tuple[str, str, str, str, str, bool, bool]]

def family_defaults(family: str) -> dict[str, Any]: ...

class NativeBranch: ...

class NativeModel:
    @staticmethod
    def from_table(table: dict[str, Any]) -> NativeModel: ...
    @staticmethod
    def from_job(path: str, overrides: dict[str, Any] | None = None) -> NativeModel: ...
    @staticmethod
    def general(
        mass: np.ndarray | tuple[int, int, np.ndarray, np.ndarray, np.ndarray],
        stiffness: np.ndarray | tuple[int, int, np.ndarray, np.ndarray, np.ndarray],
        elements: list[tuple[Any, ...]],
        fixed_dofs: list[int] | None = None,
        cyclic: tuple[int, int] | None = None,
    ) -> NativeModel: ...
    @property
    def dofs(self) -> int: ...
    @property
    def family(self) -> str: ...
    @property
    def cyclic(self) -> tuple[int, int] | None: ...
    @property
    def has_layout(self) -> bool: ...
    def write_vtk(self, path: str, times: list[float], x: np.ndarray) -> None: ...
    @property
    def branch_names(self) -> list[str]: ...
    @property
    def response_names(self) -> list[str]: ...
    def job_response(self, name: str) -> dict[str, Any]: ...
    def job_damping(self) -> tuple[dict[str, Any], NativeDamping] | None: ...
    def branch_mode(self, name: str) -> tuple[str, str | None] | None: ...
    def matrix(self, name: str) -> np.ndarray | tuple[int, np.ndarray, np.ndarray, np.ndarray]: ...
    def internal_force(self, x: np.ndarray) -> np.ndarray: ...
    def tangent_stiffness(self, x: np.ndarray) -> np.ndarray | tuple[int, np.ndarray, np.ndarray, np.ndarray]: ...
    def modes(self) -> dict[str, Any]: ...
    def backbone(
        self,
        mode: int | str | None,
        settings: dict[str, Any],
        branch: str | None = None,
        callback: Callable[[int, float, float, bool], Any] | None = None,
        damping: NativeDamping | None = None,
    ) -> dict[str, Any]: ...
    def switch(
        self,
        parent: NativeBranch,
        event: int,
        direction: int,
        settings: dict[str, Any],
        callback: Callable[[int, float, float, bool], Any] | None = None,
    ) -> dict[str, Any]: ...
    def motion(self, state0: np.ndarray, period: float, samples: int, tolerance: float) -> np.ndarray: ...

class NativeDamping: ...

def damping(model: NativeModel, spec: dict[str, Any] | np.ndarray | tuple[int, int, np.ndarray, np.ndarray, np.ndarray]) -> NativeDamping: ...
def force_amplitude(force: dict[str, Any]) -> float: ...
# `force`: the job file's `force = { ... }` keys, forced dofs and vector in the model's full
# numbering (before `fixed_dofs`); `output_dofs` after `fixed_dofs` (nnm_io::job::force_shape).
def response(
    model: NativeModel,
    damping: NativeDamping | None,
    force: dict[str, Any],
    sweep: tuple[str, float, float, float],
    output_dofs: list[int] | None,
    settings: dict[str, Any],
    curve: int = 0,
    callback: Callable[[int, float, float, bool], Any] | None = None,
) -> dict[str, Any]: ...
def forced_motion(
    model: NativeModel,
    damping: NativeDamping | None,
    force: dict[str, Any],
    state0: np.ndarray,
    frequency: float,
    amplitude: float,
    samples: int,
    tolerance: float,
) -> np.ndarray: ...
