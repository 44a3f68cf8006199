"""Sweeps: a job's mode families followed over many models, in parallel on Dask.

A sweep varies a job file two ways and follows each of its branches on every variant:

- **grid** parameters: any numeric key of the job, as a dotted key and a list of values
  (``{"model.cubic": [0.05, 0.1, 0.2], "branch.mode-1-5.energy_max": [5, 10]}``; every
  combination is run);
- **random mistuning** of a bladed disk's blades, ``k_i = k (1 + σ ξ_i)`` with ``ξ`` standard
  normal: ``samples`` replicates for each ``σ`` in ``mistuning``. Replicate ``r`` draws the same
  ``ξ`` (from ``numpy.random.default_rng([seed, r])``) for every ``σ`` and grid point (common
  random numbers: the trend in ``σ`` is not masked by sampling noise), so a row is reproduced
  from its ``seed``, ``replicate`` and ``sigma`` alone.

A mistuned disk has no cyclic symmetry: each degenerate pair of the tuned disk splits into two
close modes. A sample follows the mistuned mode most like the branch's tuned mode: the largest
mass-weighted modal assurance criterion ``MAC_j = (φ_tᵀ M φ_j)²`` (both mass-normalised; the
``mac`` column says how alike they are).

Along each branch the **localization** is the share of the blades' kinetic energy, averaged
over the period, held by the ``localization_sectors`` most energetic sectors (docs/method.md
§16, eq. (79)): about ``k·2/N`` for a tuned standing wave, 1 when a single sector moves. A
row gives it in the linear regime (the branch's first point), at the branch's end, its
largest value, and ``localization_energy``, the energy at which it first exceeds
``LOCALIZED`` (one half).

Results are written as samples complete, so an interrupted sweep loses only the samples
running at that moment: ``OUT/sweep.csv`` (one row per sample), ``OUT/samples/*.csv`` (each
sample's branch: energy, frequency, stability, localization, regime and peak displacement), and
at the end ``OUT/statistics.csv`` and the figures ``OUT/localization.png`` and
``OUT/frequency.png`` (docs/output.md has every column).
A rerun into the same ``OUT`` skips the samples already in ``sweep.csv`` (more samples, σ or
grid values may be added); ``sweep.json`` records what defines a row — the job file, its
content (SHA-256 of it and of the files it names), the seed, the grid's keys,
``localization_sectors``, :data:`MOTION_SAMPLES` — and a rerun whose differ is refused, naming
what changed, before anything is written (the rows would not be this sweep's); a row of
``sweep.csv`` that cannot be read is refused with the file and its line. A worker lost
mid-sample is replaced by Dask and its sample rerun elsewhere; samples whose branch fails
numerically, or whose forced curve does not reach the end of its sweep, are kept as rows with
``status = "failed"`` and the reason; a sample that raises
on its worker has no row (``SweepResult.missing``; a rerun computes it).

A sweep of **forced responses** (``responses=[...]``, ``--response NAME``) runs a job's
``[[response]]`` (one force level) on every mistuned disk and on the tuned one, and reports per
sample the largest amplitude of its output dofs (every blade, for an engine-order force) over
the curve, where (blade, frequency) it is reached, and the **amplification**: that peak over
the tuned disk's at the same grid point — bounded by Whitehead's ``(1 + √N)/2`` for a linear
disk (:func:`whitehead_bound`), unknown in general for a nonlinear one (docs/method.md §21).
A mistuned row waits for its tuned sample when that one is still running; the tuned sample
is part of the sweep (σ = 0), resumed and repeated like the others.

Command line: ``python -m nnm sweep JOB.toml --out DIR ...`` (``python -m nnm sweep --help``).
"""

from __future__ import annotations

import csv
import hashlib
import itertools
import json
import math
import os
import re
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Iterable, Sequence

import numpy as np

from . import _checks, _nnm
from ._model import Model, backbone, modes
from ._response import job_response

if TYPE_CHECKING:
    import distributed

SWEEP_CSV = "sweep.csv"
SWEEP_JSON = "sweep.json"
SAMPLES_DIR = "samples"
STATISTICS_CSV = "statistics.csv"

#: Times per period at which the motion is sampled for the localization: the average of a
#: smooth periodic function over equal samples converges spectrally, and 32 resolve the
#: harmonics that carry the blades' energy to well below a percent.
MOTION_SAMPLES = 32

#: The most samples a sweep plans (branches × grid points × replicates of every level): each is
#: a branch followed (about a second of a core) and a row held in memory, so a count beyond it
#: (``samples=10**400``) is refused up front instead of filling the memory while planning.
MAX_SAMPLES = 1_000_000

#: Times a forced sample's curve that closed on itself (a step that jumped onto an isolated
#: loop) or turned back out of the start of its sweep is computed again, each at half the
#: largest step of the last: three of the example's 1,000 mistuned disks did one or the other
#: at 0.1 and covered their sweep at 0.05.
CLOSED_CURVE_RETRIES = 2

#: Processes of a local cluster per core of this machine, at most: each computes on one thread,
#: and more only wait (``workers=10**6`` started processes until the system killed the sweep).
WORKERS_PER_CORE = 4

#: The localization above which a motion counts as localized (``localization_energy``).
LOCALIZED = 0.5


@dataclass(frozen=True)
class Sample:
    """One computation of a sweep: a branch of the job on one variant of its model.

    ``parameters`` are the grid's ``(dotted key, value)`` pairs; ``sigma`` is the mistuning
    level (0 for the tuned model) and ``replicate`` the draw of ``ξ`` (0 when tuned)."""

    index: int
    branch: str
    parameters: tuple[tuple[str, int | float], ...]
    sigma: float
    replicate: int

    @property
    def key(self) -> tuple:
        """What identifies the sample across reruns (its ``index`` depends on the plan)."""
        return (self.branch, self.parameters, self.sigma, self.replicate)

    @property
    def name(self) -> str:
        """A file name for the sample's branch, unique within the sweep."""
        params = "".join(f"_{k.split('.')[-1]}={v:.6g}" for k, v in self.parameters)
        sigma = f"_sigma={self.sigma:.6g}_r{self.replicate}" if self.sigma else ""
        return f"{self.branch}{params}{sigma}"


def plan(
    branches: Sequence[str],
    *,
    samples: int = 0,
    mistuning: Sequence[float] = (),
    grid: dict[str, Sequence[int | float]] | None = None,
) -> list[Sample]:
    """Every sample of a sweep, in order: branch, then grid point, then ``σ``, then replicate.
    Without ``mistuning`` each grid point is one tuned sample; ``σ = 0`` among ``mistuning``
    also means the tuned model (one sample, whatever ``samples``)."""
    grid = grid or {}
    for key, values in grid.items():
        if len(values) == 0:
            raise ValueError(f"grid parameter `{key}` has no values")
    for sigma in mistuning:
        if not (math.isfinite(sigma) and sigma >= 0):
            raise ValueError(f"a mistuning level must be finite and non-negative, got {_checks.number(sigma)}")
    if mistuning and any(s > 0 for s in mistuning) and samples < 1:
        raise ValueError("mistuning needs `samples` >= 1 (replicates per level)")
    keys = list(grid)
    levels = sorted(set(float(s) for s in mistuning)) or [0.0]
    # Counted before anything is listed (one branch when none is named yet).
    count = max(len(branches), 1) * math.prod(len(v) for v in grid.values()) * sum(samples if s > 0 else 1 for s in levels)
    if count > MAX_SAMPLES:
        raise ValueError(
            f"the sweep would have {_checks.number(count)} samples, more than {MAX_SAMPLES} (nnm.sweeps.MAX_SAMPLES): "
            "fewer `samples`, levels or grid values"
        )
    points = [tuple(zip(keys, values)) for values in itertools.product(*grid.values())]
    out: list[Sample] = []
    for branch in branches:
        for point in points:
            for sigma in levels:
                for replicate in range(samples if sigma > 0 else 1):
                    out.append(Sample(len(out), branch, point, sigma, replicate))
    return out


def _numeric(key: str, value: Any) -> int | float:
    """A grid value: an int stays one (keys such as `sectors` take only integers)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"grid parameter `{key}` takes numbers, got {value!r}")
    if value != value:  # a NaN row would match no sample on a rerun
        raise ValueError(f"grid parameter `{key}` takes numbers, got {value!r}")
    return int(value) if isinstance(value, (int, np.integer)) else float(value)


def mistuning_draw(seed: int, replicate: int, sectors: int) -> np.ndarray:
    """``ξ`` of replicate ``replicate``: ``sectors`` standard normal numbers from
    ``numpy.random.default_rng([seed, replicate])`` (the same for every ``σ``)."""
    return np.random.default_rng([seed, replicate]).standard_normal(sectors)


def localization(
    model: Model, branch: Any, sectors: tuple[int, int], top: int, samples: int = MOTION_SAMPLES
) -> np.ndarray:
    """Per point of ``branch``: the share of the period-averaged kinetic energy of the sectors'
    blades held by the ``top`` most energetic sectors (docs/method.md eq. (79)).

    ``sectors = (N, dofs_per_sector)`` in sector-major numbering. On the bladed disk the
    blade is dof 1 of each sector; on other cyclic models every dof of a sector counts, each
    weighted by its diagonal mass."""
    n_sectors, per_sector = sectors
    mass = model.M
    diagonal = np.asarray(mass.diagonal() if hasattr(mass, "diagonal") else np.diag(mass), dtype=float)
    local = [1] if model.family == "bladed-disk" else list(range(per_sector))
    dofs = np.array([[s * per_sector + d for d in local] for s in range(n_sectors)])
    shares = np.empty(len(branch))
    for i in range(len(branch)):
        v = branch.motion(i, samples).v[:-1]  # the last sample repeats the first
        kinetic = (0.5 * diagonal[dofs] * (v[:, dofs] ** 2)).mean(axis=0).sum(axis=1)
        total = kinetic.sum()
        shares[i] = np.sort(kinetic)[-top:].sum() / total if total > 0 else math.nan
    return shares


def first_crossing(energy: np.ndarray, share: np.ndarray, level: float = LOCALIZED) -> float:
    """The energy at which ``share`` first reaches ``level`` along the branch, interpolated
    linearly in ``log E`` between the two points around it; NaN if it never does (or the first
    point is already past it: then the linear mode itself is localized, and the first
    point's energy is returned)."""
    above = np.flatnonzero(share >= level)
    if len(above) == 0:
        return math.nan
    k = int(above[0])
    if k == 0:
        return float(energy[0])
    a, b = share[k - 1], share[k]
    t = (level - a) / (b - a)
    return float(np.exp(np.log(energy[k - 1]) + t * (np.log(energy[k]) - np.log(energy[k - 1]))))


def _branch_start(model: Model, name: str) -> tuple[str, str | None]:
    """The starting mode (as written) and pattern of the job's branch `name`; a branch
    switched from an event cannot be swept."""
    start = model._native.branch_mode(name)
    if start is None:
        raise ValueError(f"branch `{name}` starts from an event of another branch: a sweep follows branches started from modes")
    return start


def default_top(sectors: int) -> int:
    """Sectors counted by the localization unless told: a tenth of them, at least one."""
    return max(1, math.ceil(sectors / 10))


def run_sample(
    job: str, sample: Sample, seed: int, top: int | None = None, motion_samples: int = MOTION_SAMPLES
) -> dict[str, Any]:
    """Computes one sample (on a Dask worker, or anywhere): the model of ``job`` with the
    sample's grid values and mistuning, its mode found, the branch followed, and the
    localization along it. Returns ``{"row": ..., "curve": ...}``: the sample's row of
    ``sweep.csv`` and its branch's arrays. A branch that fails numerically gives a row with
    ``status = "failed"`` and the points it reached; bad input raises."""
    started = time.perf_counter()
    overrides = dict(sample.parameters)
    tuned = Model.from_job(job, overrides)
    tuned_modes = modes(tuned)
    tuned_index = _tuned_index(tuned, sample.branch, tuned_modes)
    cyclic = tuned.cyclic
    model, mode, mac = tuned, None, 1.0
    if sample.sigma > 0:
        if tuned.family != "bladed-disk" or cyclic is None:
            raise ValueError("mistuning applies to a bladed disk (`family = \"bladed-disk\"`); vary other models with a grid")
        deviations = sample.sigma * mistuning_draw(seed, sample.replicate, cyclic[0])
        model = Model.from_job(job, {**overrides, "model.blade_stiffness_mistuning": deviations.tolist()})
        mistuned = modes(model)
        mass = model.M
        tuned_shape = tuned_modes.shapes[:, tuned_index]
        alike = (mistuned.shapes.T @ (mass @ tuned_shape)) ** 2
        mode = int(np.argmax(alike))
        mac = float(alike[mode])
    # A failed branch comes back with its points (raise_on_failure=False), its reason in `stop`.
    branch = backbone(model, mode, branch=sample.branch, progress=False, raise_on_failure=False)
    error = branch.stop if branch.stop_kind in ("step-too-small", "first-point") else ""
    top = top or (default_top(cyclic[0]) if cyclic else 1)
    share = localization(model, branch, cyclic, top, motion_samples) if cyclic and len(branch) else np.full(len(branch), math.nan)
    last = len(branch) - 1
    finite = share[np.isfinite(share)]
    row = {
        "index": sample.index,
        "branch": sample.branch,
        **{key: value for key, value in sample.parameters},
        "sigma": sample.sigma,
        "replicate": sample.replicate,
        "seed": seed if sample.sigma > 0 else "",
        "mode": branch.mode,
        "mac": mac,
        "linear_frequency": branch.linear_frequency,
        "points": len(branch),
        "energy": branch.energy[last] if last >= 0 else math.nan,
        "frequency": branch.frequency[last] if last >= 0 else math.nan,
        "frequency_shift": branch.frequency_shift[last] if last >= 0 else math.nan,
        "localization_linear": share[0] if last >= 0 else math.nan,
        "localization": share[last] if last >= 0 else math.nan,
        "localization_max": float(finite.max()) if len(finite) else math.nan,
        "localization_energy": first_crossing(branch.energy, share) if len(finite) else math.nan,
        "stable": bool(branch.stable[last]) if last >= 0 else "",
        "events": len(branch.events),
        "stop": branch.stop_kind,
        "status": "failed" if error else "ok",
        "message": error,
        "seconds": round(time.perf_counter() - started, 3),
    }
    curve = {
        "energy": branch.energy,
        "frequency_rad_s": branch.frequency,
        "stable": branch.stable,
        "localization": share,
        "regime": branch.regime,
        "peak": branch.peak_displacement[:, 0],
    }
    return {"row": row, "curve": curve}


# ----------------------------------------------------------------------------------------
# Files of a sweep


def _columns(grid_keys: Iterable[str]) -> list[str]:
    return [
        "index", "branch", *grid_keys, "sigma", "replicate", "seed", "mode", "mac",
        "linear_frequency", "points", "energy", "frequency", "frequency_shift",
        "localization_linear", "localization", "localization_max", "localization_energy", "stable", "events", "stop", "status", "message", "seconds",
    ]  # fmt: skip


def _format(value: Any) -> str:
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    if isinstance(value, (float, np.floating)):
        return repr(float(value))  # shortest exact form
    return str(value)


def _read_rows(path: Path, columns: list[str], grid_keys: list[str]) -> list[dict[str, str]]:
    """The complete rows of an existing ``sweep.csv``, each checked (a last row cut short by
    an interruption is dropped, to be computed again); a row that cannot be read is refused
    with the file and its line."""
    if not path.exists():
        return []
    try:
        with path.open(newline="") as f:
            reader = csv.reader(f)
            header = next(reader, None)
            if header is None:
                return []
            if header != columns:
                raise ValueError(f"{path} has other columns than this sweep's (another grid?): use another --out")
            records = [(reader.line_num, r) for r in reader if r]
    except (csv.Error, UnicodeDecodeError) as e:
        raise ValueError(f"{path}: not a sweep's CSV file ({e}): repair it or use another --out") from None
    rows: list[dict[str, str]] = []
    lines: dict[tuple, int] = {}
    for k, (line, record) in enumerate(records):
        where = f"{path}, line {line}"
        if len(record) != len(columns):
            if k == len(records) - 1 and len(record) < len(columns):
                continue  # the last row, cut short as the sweep stopped
            raise ValueError(f"{where}: {len(record)} fields where the header has {len(columns)}: repair or delete the row to go on")
        row = dict(zip(columns, record))
        try:
            key = _row_key(row, grid_keys)
            _check_row(row)
        except ValueError as e:
            raise ValueError(f"{where}: {e}: repair or delete the row to go on") from None
        if key in lines:
            raise ValueError(f"{where}: the same sample as line {lines[key]}: delete one of the two to go on")
        lines[key] = line
        rows.append(row)
    return rows


#: Columns of ``sweep.csv`` that hold numbers (empty where a branch has no point).
_NUMBER_COLUMNS = ["mode", "mac", "linear_frequency", "points", "energy", "frequency", "frequency_shift",
                   "localization_linear", "localization", "localization_max", "localization_energy", "events"]  # fmt: skip


def _check_row(row: dict[str, str]) -> None:
    if row["status"] not in ("ok", "failed"):
        raise ValueError(f"status `{row['status']}` is neither `ok` nor `failed`")
    for column in _RESPONSE_NUMBER_COLUMNS if "response" in row else _NUMBER_COLUMNS:
        text = row[column]
        # A failed row has no numbers; a response row none of its tuned disk's when that
        # sample failed or is still to compute (filled in when it is).
        if text == "" and (row["status"] == "failed" or column in _REFERENCE_COLUMNS):
            continue
        try:
            float(text)
        except ValueError:
            raise ValueError(f"{column} `{text}` is not a number") from None


def _row_key(row: dict[str, str], grid_keys: list[str]) -> tuple:
    """What identifies a row's sample (:attr:`Sample.key`); a ``ValueError`` naming the column
    that cannot be read."""

    def read(column: str, kind: Callable[[str], Any]) -> Any:
        try:
            value = kind(row[column])
        except ValueError:
            value = None
        if value is None or (kind is float and not math.isfinite(value)) or (kind is int and value < 0):
            raise ValueError(f"{column} `{row[column]}` is not {'a finite number' if kind is float else 'a non-negative integer'}")
        return value

    def grid_value(column: str) -> float:
        # A grid value may be infinite, as a job's limit may (`energy_max = inf`, none).
        text = row[column]
        if text.strip().lower().lstrip("+-") in ("inf", "infinity"):
            return float(text)
        try:
            return read(column, float)
        except ValueError:
            raise ValueError(f"{column} `{text}` is not a number") from None

    name = row.get("branch", row.get("response", ""))
    if not name:
        raise ValueError("the branch is empty" if "branch" in row else "the response is empty")
    return (name, tuple((k, grid_value(k)) for k in grid_keys), read("sigma", float), read("replicate", int))


def _write_rows(path: Path, columns: list[str], rows: list[dict[str, str]]) -> None:
    """``sweep.csv`` rewritten whole from ``rows`` (through a temporary file)."""
    tmp = path.with_suffix(".tmp")
    with tmp.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(columns)
        for r in rows:
            w.writerow([r[c] for c in columns])
    tmp.replace(path)


def _write_curve(path: Path, curve: dict[str, np.ndarray]) -> None:
    tmp = path.with_suffix(".tmp")
    with tmp.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(list(curve))
        for values in zip(*curve.values()):
            w.writerow([_format(v) for v in values])
    tmp.replace(path)


class SweepResult:
    """What :func:`sweep` did: ``rows`` (every sample's row of ``sweep.csv``, as strings,
    finished earlier ones included), the counts ``computed``, ``skipped`` and ``failed``,
    ``failed_rows`` (the rows whose branch failed), ``missing`` (the names of the samples of
    this sweep that have no row: they raised, or their worker was lost too often; a rerun
    computes them), and the output folder ``out``."""

    def __init__(self, out: Path, rows: list[dict[str, str]], computed: int, skipped: int, missing: Sequence[str] = ()) -> None:
        self.out, self.rows, self.computed, self.skipped = out, rows, computed, skipped
        self.failed_rows = [r for r in rows if r["status"] != "ok"]
        self.failed = len(self.failed_rows)
        self.missing = list(missing)

    def to_pandas(self) -> Any:
        """``sweep.csv`` as a DataFrame."""
        import pandas

        return pandas.read_csv(self.out / SWEEP_CSV)

    def __repr__(self) -> str:
        return (
            f"<nnm sweep in {self.out}: {len(self.rows)} samples "
            f"({self.computed} computed, {self.skipped} already done, {self.failed} failed"
            f"{f', {len(self.missing)} missing' if self.missing else ''})>"
        )


def sweep(
    job: str | os.PathLike,
    out: str | os.PathLike,
    *,
    branches: Sequence[str] | None = None,
    responses: Sequence[str] | None = None,
    samples: int = 0,
    mistuning: Sequence[float] = (),
    seed: int = 0,
    grid: dict[str, Sequence[float]] | None = None,
    localization_sectors: int | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    client: "distributed.Client | None" = None,
    on_row: Callable[[dict[str, Any]], Any] | None = None,
    progress: bool = True,
    figures: bool = True,
) -> SweepResult:
    """Runs a sweep of ``job``'s branches (all of those started from a mode, or ``branches``) —
    or of its forced responses ``responses`` (the ``[[response]]`` names, one force level
    each) — over ``grid`` and ``mistuning`` (see the module's doc), writing into ``out`` as samples
    complete, on Dask: a ``client`` given, a scheduler at ``scheduler`` (``"tcp://host:8786"``),
    or a ``LocalCluster`` of ``workers`` processes (default, ``None``: one per core of this
    machine; at least 1), one thread each; at most one of the three. ``on_row(row)`` is called
    on this process as each sample's row is written.

    Everything is checked before anything runs or is written, raising ``ValueError``
    (``TypeError`` for a value of the wrong type): the job with every grid point, each
    branch's mode, every replicate's mistuned blades, the seed, the counts, the scheduler's
    address, and what ``out`` already holds (see the module's doc on reruns); a scheduler that
    cannot be reached within :data:`SCHEDULER_TIMEOUT` seconds raises ``ConnectionError``, with
    nothing written. The result's ``failed`` and ``missing`` say which samples have no
    usable row."""
    job_path = Path(job).resolve()
    if not str(os.fspath(out)).strip():
        raise ValueError("out is empty: give the sweep's output folder")
    out = Path(out)
    grid = _checked_grid(grid)
    mistuning = [_real("a mistuning level", s) for s in mistuning]
    samples = _integer("samples", samples, 0)
    seed = _integer("seed", seed, 0)
    if localization_sectors is not None:
        localization_sectors = _integer("localization_sectors", localization_sectors, 1)
    if workers is not None:
        workers = _integer("workers", workers, 1, "leave it out for one per core")
        most = WORKERS_PER_CORE * (os.cpu_count() or 1)
        if workers > most:
            raise ValueError(
                f"workers must be at most {most} ({WORKERS_PER_CORE} per core of this machine; each computes on one core), "
                f"got {_checks.number(workers)}"
            )
    if branches and responses is not None:
        raise ValueError("a sweep follows either branches or responses, not both")
    if responses is not None:
        if isinstance(responses, (str, bytes)):
            raise TypeError(f"responses takes a list of the job's [[response]] names, got {responses!r}")
        responses = list(responses)
        if not responses:
            raise ValueError("responses is empty: name at least one of the job's [[response]]")
        if localization_sectors is not None:
            raise ValueError("localization_sectors applies to a sweep of branches, not of responses")
    if sum(x is not None for x in (workers, scheduler, client)) > 1:
        raise ValueError("give at most one of `workers`, `scheduler` and `client`")
    if scheduler is not None:
        _check_address(scheduler)

    # Validate on this process, before any worker starts: the job with every grid point's
    # overrides (every key then checked by the job file's rules), each branch's start, the
    # levels, every replicate's draw.
    plan([], samples=samples, mistuning=mistuning, grid=grid)  # the levels and samples
    points = [dict(p) for p in itertools.product(*([(k, v) for v in vs] for k, vs in grid.items()))]
    tuned = _model_at(job_path, points[0], grid)
    for key in grid:
        if key.startswith("model.") and key.split(".", 1)[1] == "blade_stiffness_mistuning":
            raise ValueError("vary the mistuning with `mistuning` (levels) and `samples`, not as a grid key")
    if responses is not None:
        names = responses
        for point in points:
            model = _model_at(job_path, point, grid) if point is not points[0] else tuned
            for name in names:
                _check_response(model, name)
        _check_points(job_path, points, grid, [], mistuning, samples, seed, None)
        # The tuned disk is every level's reference: its sample runs beside the mistuned ones.
        todo = plan(names, samples=samples, mistuning=[0.0, *mistuning], grid=grid)
    else:
        names = list(branches) if branches else [b for b in tuned.branches if tuned._native.branch_mode(b)]
        if not names:
            raise ValueError(f"{job_path}: the job has no branch started from a mode to sweep")
        _check_points(job_path, points, grid, names, mistuning, samples, seed, localization_sectors)
        todo = plan(names, samples=samples, mistuning=mistuning, grid=grid)

    # What `out` holds, read and checked before anything is written.
    identity = {
        "job": str(job_path),
        "job_sha256": _job_digest(job_path),
        "seed": seed,
        "grid_keys": list(grid),
        "localization_sectors": localization_sectors,
        "motion_samples": MOTION_SAMPLES,
    }
    if responses is not None:
        identity["responses"] = names
    columns = _response_columns(grid) if responses is not None else _columns(grid)
    csv_path = out / SWEEP_CSV
    config_path = out / SWEEP_JSON
    rows = _read_rows(csv_path, columns, list(grid))
    if rows:
        _check_identity(config_path, identity)
    # A row's index is its sample's place in this plan (an earlier run with fewer samples or
    # levels numbered them otherwise); rows of samples this plan leaves out are kept, after.
    place = {s.key: s.index for s in todo}
    extra = itertools.count(len(todo))
    for r in rows:
        r["index"] = str(place.get(_row_key(r, list(grid)), next(extra)))
    rows.sort(key=lambda r: int(r["index"]))
    done = {_row_key(r, list(grid)) for r in rows}
    pending = [s for s in todo if s.key not in done]

    say = (lambda text: print(text, file=sys.stderr, flush=True)) if progress else (lambda text: None)
    computed = 0
    own_client = None
    if pending and client is None:
        # Before any file is written: an unreachable scheduler leaves `out` as it was.
        client, own_client = _start_client(workers, scheduler)
    try:
        out.mkdir(parents=True, exist_ok=True)
        (out / SAMPLES_DIR).mkdir(exist_ok=True)
        record = {**identity, "nnm": _version(), "samples": samples, "mistuning": mistuning, "grid": grid}
        record["responses" if responses is not None else "branches"] = names
        config_path.write_text(json.dumps(record, indent=2) + "\n")
        # Rewrite without any row cut short (and with the tuned peaks an earlier run lacked),
        # then append as samples complete.
        if responses is not None:
            _fill_references(rows, list(grid))
        _write_rows(csv_path, columns, rows)

        say(f"nnm sweep: {len(todo)} samples, {len(todo) - len(pending)} already in {csv_path}, {len(pending)} to run")
        if pending:
            if own_client is not None:
                say(f"nnm sweep: on {_describe(client)}")
            # Line-buffered: each row reaches the file in the one write of its line (a signal
            # that quits at once, between rows, loses none).
            with csv_path.open("a", newline="", buffering=1) as f:
                writer = csv.writer(f)

                def emit(result: dict[str, Any]) -> None:
                    nonlocal computed
                    row = result["row"]
                    if responses is not None:
                        _amplification(row, reference, list(grid))
                    _write_curve(out / SAMPLES_DIR / f"{todo[row['index']].name}.csv", result["curve"])
                    writer.writerow([_format(row.get(c, "")) for c in columns])
                    f.flush()
                    rows.append({c: _format(row.get(c, "")) for c in columns})
                    computed += 1
                    say(_progress_line(row, computed, len(pending)))
                    if on_row is not None:
                        on_row(row)

                if responses is None:
                    for result in _results(client, run_sample, (str(job_path), seed, localization_sectors), pending, say):
                        emit(result)
                else:
                    # A mistuned row waits for its tuned disk's peak (its amplification's
                    # reference) while that sample is still running.
                    reference = _references(rows, list(grid))
                    running = {(s.branch, s.parameters) for s in pending if s.sigma == 0}
                    waiting: list[dict[str, Any]] = []
                    try:
                        for result in _results(client, run_response_sample, (str(job_path), seed), pending, say):
                            row = result["row"]
                            key = _reference_key(row, list(grid))
                            if float(row["sigma"]) == 0:
                                if row["status"] == "ok" and math.isfinite(row["peak"]):
                                    reference[key] = row["peak"]
                                running.discard(key)
                                emit(result)
                                for held in [w for w in waiting if _reference_key(w["row"], list(grid)) == key]:
                                    waiting.remove(held)
                                    emit(held)
                            elif key in running:
                                waiting.append(result)
                            else:
                                emit(result)
                    finally:
                        # Their tuned sample raised, or the sweep is stopping: written without
                        # the reference, which a rerun fills in.
                        for held in waiting:
                            emit(held)
    finally:
        if own_client is not None:
            cluster = own_client.cluster
            own_client.close()
            if cluster is not None:
                cluster.close()
    rows.sort(key=lambda r: int(r["index"]))
    have = {_row_key(r, list(grid)) for r in rows}
    missing = [s.name for s in todo if s.key not in have]
    if responses is not None and _fill_references(rows, list(grid)):
        _write_rows(csv_path, columns, rows)
    result = SweepResult(out, rows, computed, len(todo) - len(pending), missing)
    if responses is not None:
        _write_response_statistics(out / STATISTICS_CSV, rows, list(grid))
        if figures:
            # Whitehead's N: the disk's blades, unless the grid varies them (one line would be wrong).
            sectors = tuned.cyclic[0] if tuned.cyclic and "model.sectors" not in grid else None
            _write_amplification_figure(out, rows, sectors)
        return result
    _write_statistics(out / STATISTICS_CSV, rows, list(grid))
    if figures:
        _write_figures(out, rows, todo, list(grid))
    return result


#: Seconds to wait for a ``scheduler`` to answer before the sweep gives up (nothing written).
SCHEDULER_TIMEOUT = 5

#: The protocols a Dask scheduler's address may name (``tcp://`` when none is written).
SCHEDULER_PROTOCOLS = ("tcp", "tls", "ws", "wss")


def _check_address(address: Any) -> None:
    """A scheduler address Dask can connect to, ``[PROTOCOL://]HOST:PORT``, refused at once
    when it cannot be one (whether the host answers is found when connecting)."""
    if not isinstance(address, str):
        raise TypeError(f"scheduler takes an address such as tcp://host:8786, got {address!r}")
    protocol, sep, location = address.strip().rpartition("://")
    protocol = protocol if sep else "tcp"
    why = ""
    if protocol not in SCHEDULER_PROTOCOLS:
        why = f"unknown protocol `{protocol}://` (Dask's are {', '.join(p + '://' for p in SCHEDULER_PROTOCOLS)})"
    else:
        host, colon, port = location.rpartition(":")
        if not colon or not host.strip("[]"):
            why = "expected HOST:PORT"
        elif not (port.isdigit() and 1 <= int(port) <= 65535):
            why = f"the port `{port}` is not a number from 1 to 65535"
        elif ":" in host and not (host.startswith("[") and host.endswith("]")):
            why = "expected HOST:PORT (an IPv6 host in brackets, [::1]:8786)"
    if why:
        raise ValueError(f"scheduler address `{address}`: {why}; e.g. tcp://host:8786")


def _start_client(workers: int | None, scheduler: str | None) -> tuple[Any, Any]:
    from dask.distributed import Client, LocalCluster

    if scheduler is not None:
        try:
            client = Client(scheduler.strip(), timeout=SCHEDULER_TIMEOUT)
        except OSError as e:  # Dask's timeout, a refused connection, an unknown host
            raise ConnectionError(
                f"no Dask scheduler answered at {scheduler} within {SCHEDULER_TIMEOUT} s ({e}); is it running? Nothing was written"
            ) from None
        except Exception as e:  # noqa: BLE001 — a server that is not a scheduler: Dask reads its reply
            # as a frame (an HTTP server's bytes were a length of exabytes: a MemoryError)
            raise ConnectionError(
                f"what answered at {scheduler} is not a Dask scheduler ({type(e).__name__} reading its reply); "
                "is that the scheduler's address and port? Nothing was written"
            ) from None
        return client, client
    cluster = LocalCluster(
        n_workers=workers or os.cpu_count() or 1,
        threads_per_worker=1,  # the library computes on one thread: one sample per core
        processes=True,
        dashboard_address=None,
    )
    client = Client(cluster)
    return client, client


def _integer(name: str, value: Any, least: int, hint: str = "") -> int:
    """A count or seed: an integer (not a bool, not a float) of at least ``least``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} takes an integer, got {value!r}")
    if value < least:
        raise ValueError(f"{name} must be at least {least}{f' ({hint})' if hint else ''}, got {_checks.number(value)}")
    return int(value)


def _real(what: str, value: Any) -> float:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{what} is a number, got {value!r}")
    return _checks.real(what, value)  # an int beyond the doubles (10**400) a ValueError


def _checked_grid(grid: Any) -> dict[str, list[int | float]]:
    if grid is None:
        return {}
    if not isinstance(grid, dict):
        raise TypeError(f"grid takes a dict of dotted keys and lists of values, got {type(grid).__name__}")
    checked = {}
    for key, values in grid.items():
        if not isinstance(key, str):
            raise TypeError(f"a grid key is a dotted key such as `model.cubic`, got {key!r}")
        if isinstance(values, (str, bytes)) or not isinstance(values, Iterable):
            raise TypeError(f"grid parameter `{key}` takes a list of values, got {values!r}")
        checked[key] = [_numeric(key, v) for v in values]
        if not checked[key]:
            raise ValueError(f"grid parameter `{key}` has no values")
        if len(set(checked[key])) != len(checked[key]):
            raise ValueError(f"grid parameter `{key}` has a value twice: {checked[key]}")
    return checked


def _point_text(point: dict[str, Any]) -> str:
    return ", ".join(f"{k} = {v}" for k, v in point.items())


def _model_at(job: Path, point: dict[str, Any], grid: dict[str, Any]) -> Model:
    """The job's model with a grid point's values, its errors naming the point when the grid
    has more than one."""
    try:
        return Model.from_job(job, point)
    except (ValueError, TypeError) as e:
        if not any(len(vs) > 1 for vs in grid.values()):
            raise
        raise type(e)(f"grid point {_point_text(point)}: {e}") from None


def _tuned_index(tuned: Model, name: str, tuned_modes: "Any") -> int:
    """The tuned mode a branch starts from, as an index of ``tuned_modes``."""
    mode_text, pattern = _branch_start(tuned, name)
    if mode_text.isdigit():
        index = int(mode_text)
        if index >= len(tuned_modes):
            raise ValueError(f"branch `{name}`: mode {index} is out of range (the model has {len(tuned_modes)} modes)")
        return index
    # A travelling wave is made of the pair's two standing waves: its tuned mode is the cos one.
    try:
        return tuned_modes.index(mode_text, pattern if pattern in ("cos", "sin") else "cos")
    except ValueError as e:
        raise ValueError(f"branch `{name}`: {e}") from None


def _check_points(
    job: Path,
    points: list[dict[str, Any]],
    grid: dict[str, Any],
    names: list[str],
    mistuning: list[float],
    samples: int,
    seed: int,
    top: int | None,
) -> None:
    """What :func:`run_sample` does before it computes, for every grid point: the job read
    with the point's values, each branch's mode found (the modes computed once per distinct
    set of ``model.`` values), ``top`` at most the sectors, and every replicate's mistuned
    blades accepted by the job file's rule (checked on each level's draw with the blade
    furthest below its tuned stiffness)."""
    levels = sorted({s for s in mistuning if s > 0})
    modes_of: dict[tuple, Any] = {}
    for point in points:
        tuned = _model_at(job, point, grid)
        where = f"grid point {_point_text(point)}: " if any(len(vs) > 1 for vs in grid.values()) else ""
        model_key = tuple((k, v) for k, v in point.items() if k.startswith("model."))
        if model_key not in modes_of:
            modes_of[model_key] = modes(tuned)
        for name in names:
            try:
                _tuned_index(tuned, name, modes_of[model_key])
            except ValueError as e:
                raise ValueError(f"{where}{e}") from None
        cyclic = tuned.cyclic
        if top is not None:
            if cyclic is None:
                raise ValueError(f"{where}localization_sectors applies to a cyclic model (a bladed disk), and this one is not")
            if top > cyclic[0]:
                raise ValueError(f"{where}localization_sectors = {_checks.number(top)} is more than the model's {cyclic[0]} sectors")
        if not levels:
            continue
        if tuned.family != "bladed-disk" or cyclic is None:
            raise ValueError("mistuning applies to a bladed disk (`family = \"bladed-disk\"`); vary other models with a grid")
        # The replicate with the blade furthest below its tuned stiffness, one draw at a time
        # (all at once would hold samples × sectors numbers).
        lowest, draw = min(((r, mistuning_draw(seed, r, cyclic[0])) for r in range(samples)), key=lambda rd: rd[1].min())
        for sigma in levels:
            try:
                Model.from_job(job, {**point, "model.blade_stiffness_mistuning": (sigma * draw).tolist()})
            except (ValueError, TypeError) as e:
                raise ValueError(f"{where}mistuning σ = {sigma:g}, replicate {lowest} of seed {seed}: {e}") from None


def _job_digest(job: Path) -> str:
    """SHA-256 of the job file and of every file it names (matrices, tensors: any quoted
    string that is a file beside it), so that a changed input is seen on a rerun."""
    try:
        text = job.read_bytes()
    except OSError:
        return ""  # Model.from_job has already said why
    digest = hashlib.sha256(text)
    named = set()
    for quoted in re.findall(rb'"([^"\\\n]+)"|\'([^\'\n]+)\'', text):
        name = (quoted[0] or quoted[1]).decode("utf-8", "replace")
        path = job.parent / name
        try:
            if path.is_file() and path.resolve() != job:
                named.add(name)
        except OSError:  # a name too long for the file system, say
            continue
    for name in sorted(named):
        digest.update(b"\0" + name.encode() + b"\0")
        digest.update((job.parent / name).read_bytes())
    return digest.hexdigest()


#: What ``sweep.json`` records of the rows it describes, with how a change is named.
_IDENTITY = {
    "job": "job file",
    "job_sha256": "job content (the job file or a file it names changed)",
    "seed": "seed",
    "grid_keys": "grid keys",
    "localization_sectors": "localization_sectors",
    "motion_samples": "motion samples per period (another nnm)",
}


def _check_identity(path: Path, identity: dict[str, Any]) -> None:
    """That the rows already in ``path``'s folder were computed as this sweep would compute
    them; else a one-line refusal naming what changed."""
    try:
        earlier = json.loads(path.read_text())
        if not isinstance(earlier, dict):
            raise ValueError("not a JSON object")
    except FileNotFoundError:
        raise ValueError(f"{path.parent} holds {SWEEP_CSV} without {SWEEP_JSON}, which says how its rows were computed: use another --out") from None
    except ValueError as e:
        raise ValueError(f"{path}: not a sweep's record ({e}): use another --out") from None
    changed = []
    for key, what in _IDENTITY.items():
        if key not in earlier:
            changed.append(f"{what} (not recorded by the nnm that wrote it)")
        elif earlier[key] != identity[key]:
            if key == "job_sha256":
                changed.append(what)
            else:
                changed.append(f"{what} ({_shown(earlier[key])}, now {_shown(identity[key])})")
    if changed:
        raise ValueError(
            f"{path.parent} holds rows of a sweep with another {'; another '.join(changed)}: "
            "they would not be this sweep's; use another --out"
        )


def _shown(value: Any) -> str:
    return "the default" if value is None else str(value)


def _version() -> str:
    from ._nnm import __version__

    return __version__


def _describe(client: Any) -> str:
    info = client.scheduler_info()
    return f"{len(info.get('workers', {}))} Dask workers at {info.get('address', '?')}"


def _results(
    client: Any, task: Callable[..., dict[str, Any]], args: tuple, pending: list[Sample], say: Callable[[str], None]
) -> Iterable[dict[str, Any]]:
    """Submits the samples and yields their results as they complete. A sample whose worker
    was lost is rerun by Dask on another (up to the scheduler's allowed failures); one that
    still cannot finish, or raises, is reported and left out of ``sweep.csv``, so that a
    rerun computes it."""
    from dask.distributed import as_completed

    futures = [
        client.submit(task, args[0], s, *args[1:], key=f"nnm-sample-{s.index}-{s.name}", pure=False)
        for s in pending
    ]
    try:
        for future in as_completed(futures):
            try:
                yield future.result()
            except Exception as e:  # noqa: BLE001 (a lost worker, an error of one sample)
                say(f"nnm sweep: {future.key}: {type(e).__name__}: {e} (left for a rerun)")
            finally:
                future.release()
    finally:
        for future in futures:
            future.cancel()


def _progress_line(row: dict[str, Any], done: int, total: int) -> str:
    name = row.get("branch", row.get("response", ""))
    what = name + "".join(f" {k}={row[k]}" for k in row if k.startswith(("model.", "settings.", "branch.")))
    if row["sigma"]:
        what += f" σ={row['sigma']:g} r={row['replicate']}"
    if "response" in row:
        if row["status"] != "ok":
            return f"nnm sweep: [{done}/{total}] {what}: failed after {row['points']} points: {row['message']}"
        factor = row.get("amplification", "")
        factor = f", amplification {float(factor):.4f}" if factor not in ("", None) else ""
        return (
            f"nnm sweep: [{done}/{total}] {what}: peak {row['peak']:.6g} at {row['peak_frequency']:.6g} rad/s "
            f"(blade {row['peak_blade']}){factor} ({row['seconds']:.2f} s)"
        )
    if row["status"] != "ok":
        return f"nnm sweep: [{done}/{total}] {what}: failed after {row['points']} points: {row['message']}"
    return (
        f"nnm sweep: [{done}/{total}] {what}: E = {row['energy']:.4g}, ω = {row['frequency']:.6g} rad/s, "
        f"localization {row['localization']:.3f} ({row['seconds']:.2f} s)"
    )


# ----------------------------------------------------------------------------------------
# Statistics and figures


def _groups(rows: list[dict[str, str]], grid_keys: list[str], name: str = "branch") -> dict[tuple, list[dict[str, str]]]:
    """The rows by branch (or response: ``name``), grid point and ``σ``, failed ones included."""
    groups: dict[tuple, list[dict[str, str]]] = {}
    for r in rows:
        key = (r[name], *(float(r[k]) for k in grid_keys), float(r["sigma"]))
        groups.setdefault(key, []).append(r)
    return dict(sorted(groups.items()))


#: The columns of ``sweep.csv`` summarised in ``statistics.csv``.
STATISTICS = [
    "linear_frequency", "frequency", "frequency_shift", "localization_linear", "localization",
    "localization_max", "localization_energy",
]  # fmt: skip


def _write_statistics(path: Path, rows: list[dict[str, str]], grid_keys: list[str]) -> None:
    """Per branch, grid point and ``σ``: the count of samples (and of failed ones) and the
    mean, standard deviation and 10/50/90% quantiles of each quantity of :data:`STATISTICS`
    over the samples that succeeded and where it is defined (``localization_energy`` is not
    where a branch never localizes); a group whose samples all failed has counts only."""
    quantities = STATISTICS
    header = ["branch", *grid_keys, "sigma", "samples", "failed"]
    for q in quantities:
        header += [f"{q}_{s}" for s in ("mean", "std", "q10", "q50", "q90")]
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        for key, group in _groups(rows, grid_keys).items():
            ok = [r for r in group if r["status"] == "ok"]
            line = [*map(_format, key), len(group), len(group) - len(ok)]
            for q in quantities:
                x = np.array([float(r[q]) for r in ok])
                x = x[np.isfinite(x)]
                if len(x):
                    line += [_format(v) for v in (x.mean(), x.std(), *np.quantile(x, [0.1, 0.5, 0.9]))]
                else:
                    line += [""] * 5
            w.writerow(line)


def _write_figures(out: Path, rows: list[dict[str, str]], todo: list[Sample], grid_keys: list[str]) -> None:
    """``localization.png`` and ``frequency.png``, one row of panels per branch: each sample's
    branch against energy (coloured by ``σ``), then summary values against ``σ`` (each
    sample, and the median). Skipped without matplotlib."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return
    by_key = {s.key: s for s in todo}
    ok = [r for r in rows if r["status"] == "ok"]
    branches = sorted({r["branch"] for r in ok})
    if not branches:
        return
    sigmas = sorted({float(r["sigma"]) for r in ok})
    colours = plt.get_cmap("viridis")
    norm = matplotlib.colors.Normalize(min(sigmas), max(sigmas) if max(sigmas) > min(sigmas) else min(sigmas) + 1)
    curves: dict[tuple, np.ndarray] = {}
    for r in ok:
        sample = by_key.get(_row_key(r, grid_keys))
        path = out / SAMPLES_DIR / f"{sample.name}.csv" if sample else None
        if path is not None and path.exists():
            curves[id(r)] = np.atleast_1d(np.genfromtxt(path, delimiter=",", names=True))
    figures = (
        ("localization.png", "localization", "localization (share of the top sectors)",
         [("localization_linear", "localization, linear regime", False),
          ("localization_energy", f"energy where localization > {LOCALIZED:g}", True)]),
        ("frequency.png", "frequency_rad_s", "frequency (rad/s)",
         [("linear_frequency", "linear frequency (rad/s)", False),
          ("frequency", "frequency at the branch's end (rad/s)", False)]),
    )  # fmt: skip
    for filename, along_column, along_label, summaries in figures:
        columns = 1 + len(summaries)
        fig, axes = plt.subplots(len(branches), columns, figsize=(4.6 * columns, 3.6 * len(branches)), squeeze=False)
        for panels, name in zip(axes, branches):
            along, *rest = panels
            mine = [r for r in ok if r["branch"] == name]
            for r in mine:
                if id(r) in curves:
                    c = curves[id(r)]
                    along.plot(c["energy"], c[along_column], color=colours(norm(float(r["sigma"]))), lw=0.7, alpha=0.7)
            along.set_xscale("log")
            along.set_xlabel("energy")
            along.set_ylabel(along_label)
            along.set_title(f"{name}: each sample's branch", fontsize="medium")
            x = np.array([float(r["sigma"]) for r in mine])
            for ax, (column, label, log) in zip(rest, summaries):
                y = np.array([float(r[column]) if r[column] else math.nan for r in mine])
                ax.plot(x, y, ".", color="0.5", label="samples")
                levels = sorted(set(x))
                medians = [np.nanmedian(y[x == s]) if np.isfinite(y[x == s]).any() else math.nan for s in levels]
                ax.plot(levels, medians, "o-", color="C3", label="median")
                if log:
                    ax.set_yscale("log")
                ax.set_xlabel("mistuning σ")
                ax.set_ylabel(label)
                ax.legend(loc="best", fontsize="small")
            fig.colorbar(matplotlib.cm.ScalarMappable(norm=norm, cmap=colours), ax=along, label="σ")
        fig.tight_layout()
        fig.savefig(out / filename, dpi=110)
        plt.close(fig)


# ----------------------------------------------------------------------------------------
# Forced responses of mistuned disks (docs/method.md §21)


def run_response_sample(job: str, sample: Sample, seed: int) -> dict[str, Any]:
    """Computes one forced sample (on a Dask worker, or anywhere): the model of ``job`` with
    the sample's grid values and mistuning, and the job's ``[[response]]`` ``sample.branch``
    (one force level) on it. Returns ``{"row": ..., "curve": ...}``: the row's largest
    amplitude of the output dofs (every blade for an engine-order force) over the curve, the
    blade and frequency where it is reached, the folds; the amplification against the tuned
    disk is the driver's (it needs the tuned sample). A curve that closes on an isolated loop
    or turns back out of the start of its sweep is computed again at half the largest step
    (:data:`CLOSED_CURVE_RETRIES` times at most); one that fails numerically or does not
    reach the end of its sweep gives a row with ``status = "failed"``, why, and the points it
    reached; bad input raises."""
    started = time.perf_counter()
    overrides = dict(sample.parameters)
    model = Model.from_job(job, overrides)
    cyclic = model.cyclic
    if sample.sigma > 0:
        if model.family != "bladed-disk" or cyclic is None:
            raise ValueError("mistuning applies to a bladed disk (`family = \"bladed-disk\"`); vary other models with a grid")
        deviations = sample.sigma * mistuning_draw(seed, sample.replicate, cyclic[0])
        model = Model.from_job(job, {**overrides, "model.blade_stiffness_mistuning": deviations.tolist()})
    def curve(**settings: Any) -> Any:
        response = job_response(model, sample.branch, progress=False, raise_on_failure=False, **settings)
        return response[0] if isinstance(response, list) else response  # `amplitudes = [a]`: one level

    response = curve()
    # A curve that closed on itself jumped onto an isolated loop in a step too long, and one
    # that came back out of the start of its sweep jumped across its own folds: computed again
    # at half the largest step, then a quarter (docs/method.md §19), not below the smallest.
    table = model._native.job_response(sample.branch)
    max_step, min_step = (table.get(k, _nnm.RESPONSE_DEFAULTS[k]) for k in ("max_step", "min_step"))
    retried, first_stop = [], response.stop_kind
    while response.stop_kind in ("closed", "start") and len(retried) < CLOSED_CURVE_RETRIES and max_step / 2 >= min_step:
        retried.append(max_step)
        max_step /= 2
        response = curve(max_step=max_step)
    # A curve that did not cover its sweep (failed, closed on a loop, out of points) cannot say
    # where the largest peak is: its row is failed, with why, and left out of the statistics.
    error = "" if response.stop_kind == "end" else response.stop
    note = ""
    if retried:
        tried = ", ".join(f"{s:g}" for s in retried)
        if error:
            error += f" (also at max_step {tried})"
        else:
            why = "closed on a loop" if first_stop == "closed" else "turned back"
            note = f"{why} at max_step {tried}; complete at {max_step:g}"
    peaks = np.asarray(response.peaks, dtype=float)
    peaks = peaks.reshape(len(response), -1) if len(response) else np.zeros((0, 1))
    row: dict[str, Any] = {
        "index": sample.index,
        "response": sample.branch,
        **{key: value for key, value in sample.parameters},
        "sigma": sample.sigma,
        "replicate": sample.replicate,
        "seed": seed if sample.sigma > 0 else "",
        "force_amplitude": float(response.force_amplitude[0]) if len(response) else math.nan,
        "points": len(response),
        "peak": math.nan,
        "peak_blade": "",
        "peak_frequency": math.nan,
        "folds": len(response.folds),
        "stop": response.stop_kind,
        "status": "failed" if error else "ok",
        "message": error or note,
    }
    if peaks.size:
        point, column = np.unravel_index(int(np.nanargmax(peaks)), peaks.shape)
        dof = response.output_dofs[column]
        row["peak"] = float(peaks[point, column])
        row["peak_blade"] = dof // cyclic[1] if cyclic else dof
        row["peak_frequency"] = float(response.frequency[point])
    row["seconds"] = round(time.perf_counter() - started, 3)
    curve = {
        "frequency_rad_s": response.frequency,
        "stable": response.stable,
        "peak": peaks.max(axis=1) if peaks.size else np.zeros(0),
    }
    return {"row": row, "curve": curve}


def _response_columns(grid_keys: Iterable[str]) -> list[str]:
    return [
        "index", "response", *grid_keys, "sigma", "replicate", "seed", "force_amplitude", "points",
        "peak", "peak_blade", "peak_frequency", "tuned_peak", "amplification", "folds", "stop", "status",
        "message", "seconds",
    ]  # fmt: skip


#: Columns of a response sweep's ``sweep.csv`` that hold numbers (empty where a curve has none).
_RESPONSE_NUMBER_COLUMNS = ["force_amplitude", "points", "peak", "peak_frequency", "tuned_peak", "amplification", "folds"]
#: The columns that come from the tuned sample, empty while it has no peak.
_REFERENCE_COLUMNS = ("tuned_peak", "amplification")


def whitehead_bound(sectors: int) -> float:
    """Whitehead's bound on the forced amplification of a linear mistuned disk of ``sectors``
    blades, ``(1 + √N)/2`` (the worst blade against the tuned disk's response)."""
    return 0.5 * (1.0 + math.sqrt(sectors))


#: The columns of a response sweep summarised in ``statistics.csv``.
RESPONSE_STATISTICS = ["amplification", "peak", "peak_frequency"]


def _write_response_statistics(path: Path, rows: list[dict[str, str]], grid_keys: list[str]) -> None:
    """Per response, grid point and ``σ``: the count of samples (and of failed ones) and the
    mean, 10/50/90/99% quantiles and maximum of each of :data:`RESPONSE_STATISTICS` over the
    samples that succeeded."""
    header = ["response", *grid_keys, "sigma", "samples", "failed"]
    for q in RESPONSE_STATISTICS:
        header += [f"{q}_{s}" for s in ("mean", "q10", "q50", "q90", "q99", "max")]
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        for key, group in _groups(rows, grid_keys, "response").items():
            ok = [r for r in group if r["status"] == "ok"]
            line = [*map(_format, key), len(group), len(group) - len(ok)]
            for q in RESPONSE_STATISTICS:
                x = np.array([float(r[q]) if r[q] else math.nan for r in ok])
                x = x[np.isfinite(x)]
                if len(x):
                    line += [_format(v) for v in (x.mean(), *np.quantile(x, [0.1, 0.5, 0.9, 0.99]), x.max())]
                else:
                    line += [""] * 6
            w.writerow(line)


def _write_amplification_figure(out: Path, rows: list[dict[str, str]], sectors: int | None) -> None:
    """``amplification.png``: each sample's amplification factor against ``σ``, the mean and
    the largest per level, and Whitehead's bound for the disk's ``sectors`` blades (``None``: not
    drawn — a grid of ``model.sectors``). Skipped without matplotlib."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return
    ok = [r for r in rows if r["status"] == "ok" and r["amplification"] and float(r["sigma"]) > 0]
    if not ok:
        return
    names = sorted({r["response"] for r in ok})
    fig, axes = plt.subplots(1, len(names), figsize=(5.2 * len(names), 3.9), squeeze=False)
    for ax, name in zip(axes[0], names):
        mine = [r for r in ok if r["response"] == name]
        x = np.array([float(r["sigma"]) for r in mine])
        y = np.array([float(r["amplification"]) for r in mine])
        ax.plot(x, y, ".", color="0.6", ms=3, label="samples")
        levels = sorted(set(x))
        ax.plot(levels, [y[x == s].mean() for s in levels], "o-", color="C0", label="mean")
        ax.plot(levels, [y[x == s].max() for s in levels], "s--", color="C3", label="largest")
        if sectors:
            ax.axhline(whitehead_bound(sectors), color="k", lw=1, ls=":", label=f"Whitehead (1 + √{sectors})/2")
        ax.axhline(1.0, color="0.3", lw=0.8)
        if len(levels) > 1 and min(levels) > 0 and max(levels) / min(levels) > 20:
            ax.set_xscale("log")
        ax.set_xlabel("mistuning σ")
        ax.set_ylabel("amplification (largest blade / tuned)")
        ax.set_title(f"{name}", fontsize="medium")
        ax.legend(loc="best", fontsize="small")
    fig.tight_layout()
    fig.savefig(out / "amplification.png", dpi=110)
    plt.close(fig)


def _check_response(model: Model, name: str) -> None:
    """That the job has the ``[[response]]`` ``name`` (a ``ValueError`` listing its responses)
    with one force level: a sample's row is one curve."""
    table = model._native.job_response(name)
    levels = table.get("amplitudes")
    if levels is not None and len(levels) != 1:
        raise ValueError(
            f"response `{name}` has {len(levels)} force levels (`amplitudes`): a sweep takes one level per response "
            "(a [[response]] per level)"
        )


def _references(rows: list[dict[str, str]], grid_keys: list[str]) -> dict[tuple, float]:
    """The tuned samples' peaks among written rows, by response and grid point."""
    out = {}
    for r in rows:
        if float(r["sigma"]) == 0 and r["status"] == "ok" and r["peak"] and math.isfinite(float(r["peak"])):
            out[_reference_key(r, grid_keys)] = float(r["peak"])
    return out


def _fill_references(rows: list[dict[str, str]], grid_keys: list[str]) -> bool:
    """Fills the empty ``tuned_peak`` and ``amplification`` of written rows whose tuned sample
    has a peak now (it failed or raised in an earlier run, or the sweep stopped before it);
    whether any changed."""
    reference = _references(rows, grid_keys)
    changed = False
    for r in rows:
        tuned = reference.get(_reference_key(r, grid_keys))
        if r["tuned_peak"] == "" and tuned and r["peak"] and math.isfinite(float(r["peak"])):
            r["tuned_peak"] = _format(tuned)
            r["amplification"] = _format(float(r["peak"]) / tuned)
            changed = True
    return changed


def _reference_key(row: dict[str, Any], grid_keys: list[str]) -> tuple:
    """The tuned sample a response row is amplified against: its response and grid point."""
    return (row["response"], tuple((k, float(row[k])) for k in grid_keys))


def _amplification(row: dict[str, Any], reference: dict[tuple, float], grid_keys: list[str]) -> None:
    """Sets ``tuned_peak`` and ``amplification`` (the row's peak over its tuned disk's) of a
    response row, empty without a reference."""
    tuned = reference.get(_reference_key(row, grid_keys))
    peak = row["peak"]
    row["tuned_peak"] = tuned if tuned else ""
    row["amplification"] = peak / tuned if tuned and math.isfinite(peak) else ""
