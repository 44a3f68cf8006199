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
A rerun into the same ``OUT`` with the same job, branches and seed skips the samples already
in ``sweep.csv`` (more samples, σ or grid values may be added). A worker lost mid-sample is
replaced by Dask and its sample rerun elsewhere; samples whose branch fails numerically are
kept as rows with ``status = "failed"`` and the reason.

Command line: ``python -m nnm sweep JOB.toml --out DIR ...`` (``python -m nnm sweep --help``).
"""

from __future__ import annotations

import csv
import itertools
import json
import math
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Iterable, Sequence

import numpy as np

from ._model import Model, backbone, modes

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
            raise ValueError(f"a mistuning level must be finite and non-negative, got {sigma}")
    if mistuning and any(s > 0 for s in mistuning) and samples < 1:
        raise ValueError("mistuning needs `samples` >= 1 (replicates per level)")
    keys = list(grid)
    points = [tuple(zip(keys, values)) for values in itertools.product(*grid.values())]
    levels = sorted(set(float(s) for s in mistuning)) or [0.0]
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
    mode_text, pattern = _branch_start(tuned, sample.branch)
    tuned_modes = modes(tuned)
    tuned_index = int(mode_text) if mode_text.isdigit() else tuned_modes.index(mode_text, pattern or "cos")
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


def _read_rows(path: Path, columns: list[str]) -> list[dict[str, str]]:
    """The complete rows of an existing ``sweep.csv`` (a row cut short by an interruption is
    dropped, to be computed again)."""
    if not path.exists():
        return []
    with path.open(newline="") as f:
        reader = csv.reader(f)
        header = next(reader, None)
        if header is None:
            return []
        if header != columns:
            raise ValueError(f"{path} has other columns than this sweep's (another grid?): use another --out")
        return [dict(zip(header, r)) for r in reader if len(r) == len(header)]


def _row_key(row: dict[str, str], grid_keys: list[str]) -> tuple:
    return (
        row["branch"],
        tuple((k, float(row[k])) for k in grid_keys),
        float(row["sigma"]),
        int(row["replicate"]),
    )


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
    finished earlier ones included), the counts ``computed``, ``skipped`` and ``failed``, and
    the output folder ``out``."""

    def __init__(self, out: Path, rows: list[dict[str, str]], computed: int, skipped: int) -> None:
        self.out, self.rows, self.computed, self.skipped = out, rows, computed, skipped
        self.failed = sum(r["status"] != "ok" for r in rows)

    def to_pandas(self) -> Any:
        """``sweep.csv`` as a DataFrame."""
        import pandas

        return pandas.read_csv(self.out / SWEEP_CSV)

    def __repr__(self) -> str:
        return (
            f"<nnm sweep in {self.out}: {len(self.rows)} samples "
            f"({self.computed} computed, {self.skipped} already done, {self.failed} failed)>"
        )


def sweep(
    job: str | os.PathLike,
    out: str | os.PathLike,
    *,
    branches: Sequence[str] | None = None,
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
    """Runs a sweep of ``job``'s branches (all of those started from a mode, or ``branches``)
    over ``grid`` and ``mistuning`` (see the module's doc), writing into ``out`` as samples
    complete, on Dask: a ``client`` given, a scheduler at ``scheduler`` (``"tcp://host:8786"``),
    or a ``LocalCluster`` of ``workers`` processes (default: this machine's cores), one thread
    each. ``on_row(row)`` is called on this process as each sample's row is written.

    Bad input (the job, a grid key, a level) raises ``ValueError`` before anything runs."""
    job_path = Path(job).resolve()
    out = Path(out)
    grid = {k: [_numeric(k, v) for v in vs] for k, vs in (grid or {}).items()}
    mistuning = [float(s) for s in mistuning]
    if localization_sectors is not None and localization_sectors < 1:
        raise ValueError(f"localization_sectors must be at least 1, got {localization_sectors}")

    # Validate on this process, before any worker starts: the job with one grid point's
    # overrides (every key then checked by the job file's rules), the branches, the levels.
    first = {k: vs[0] for k, vs in grid.items()}
    tuned = Model.from_job(job_path, first)
    names = list(branches) if branches else [b for b in tuned.branches if tuned._native.branch_mode(b)]
    if not names:
        raise ValueError(f"{job_path}: the job has no branch started from a mode to sweep")
    for name in names:
        _branch_start(tuned, name)
    if any(s > 0 for s in mistuning) and (tuned.family != "bladed-disk" or tuned.cyclic is None):
        raise ValueError("mistuning applies to a bladed disk (`family = \"bladed-disk\"`); vary other models with a grid")
    for key in grid:
        if key.startswith("model.") and key.split(".", 1)[1] == "blade_stiffness_mistuning":
            raise ValueError("vary the mistuning with `mistuning` (levels) and `samples`, not as a grid key")
    todo = plan(names, samples=samples, mistuning=mistuning, grid=grid)

    out.mkdir(parents=True, exist_ok=True)
    (out / SAMPLES_DIR).mkdir(exist_ok=True)
    identity = {"job": str(job_path), "seed": seed, "grid_keys": list(grid)}
    config_path = out / SWEEP_JSON
    if config_path.exists():
        earlier = json.loads(config_path.read_text())
        if {k: earlier.get(k) for k in identity} != identity:
            raise ValueError(
                f"{out} holds a sweep of another job, seed or grid ({earlier.get('job')}, seed {earlier.get('seed')}): use another --out"
            )
    config_path.write_text(json.dumps({**identity, "branches": names, "samples": samples, "mistuning": mistuning, "grid": grid}, indent=2) + "\n")

    columns = _columns(grid)
    csv_path = out / SWEEP_CSV
    rows = _read_rows(csv_path, columns)
    # A row's index is its sample's place in this plan (an earlier run with fewer samples or
    # levels numbered them otherwise); rows of samples this plan leaves out are kept, after.
    place = {s.key: s.index for s in todo}
    extra = itertools.count(len(todo))
    for r in rows:
        r["index"] = str(place.get(_row_key(r, list(grid)), next(extra)))
    rows.sort(key=lambda r: int(r["index"]))
    done = {_row_key(r, list(grid)) for r in rows}
    pending = [s for s in todo if s.key not in done]
    # Rewrite without any row cut short, then append as samples complete.
    tmp = csv_path.with_suffix(".tmp")
    with tmp.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(columns)
        for r in rows:
            w.writerow([r[c] for c in columns])
    tmp.replace(csv_path)

    say = (lambda text: print(text, file=sys.stderr, flush=True)) if progress else (lambda text: None)
    say(f"nnm sweep: {len(todo)} samples, {len(todo) - len(pending)} already in {csv_path}, {len(pending)} to run")
    computed = 0
    if pending:
        own_client = None
        if client is None:
            client, own_client = _start_client(workers, scheduler)
            say(f"nnm sweep: on {_describe(client)}")
        try:
            with csv_path.open("a", newline="") as f:
                writer = csv.writer(f)
                for result in _results(client, str(job_path), pending, seed, localization_sectors, say):
                    row = result["row"]
                    _write_curve(out / SAMPLES_DIR / f"{todo[row['index']].name}.csv", result["curve"])
                    writer.writerow([_format(row.get(c, "")) for c in columns])
                    f.flush()
                    rows.append({c: _format(row.get(c, "")) for c in columns})
                    computed += 1
                    say(_progress_line(row, computed, len(pending)))
                    if on_row is not None:
                        on_row(row)
        finally:
            if own_client is not None:
                cluster = own_client.cluster
                own_client.close()
                if cluster is not None:
                    cluster.close()
    rows.sort(key=lambda r: int(r["index"]))
    result = SweepResult(out, rows, computed, len(todo) - len(pending))
    _write_statistics(out / STATISTICS_CSV, rows, list(grid))
    if figures:
        _write_figures(out, rows, todo, list(grid))
    return result


def _start_client(workers: int | None, scheduler: str | None) -> tuple[Any, Any]:
    from dask.distributed import Client, LocalCluster

    if scheduler is not None:
        client = Client(scheduler)
        return client, client
    cluster = LocalCluster(
        n_workers=workers or os.cpu_count() or 1,
        threads_per_worker=1,  # the library computes on one thread: one sample per core
        processes=True,
        dashboard_address=None,
    )
    client = Client(cluster)
    return client, client


def _describe(client: Any) -> str:
    info = client.scheduler_info()
    return f"{len(info.get('workers', {}))} Dask workers at {info.get('address', '?')}"


def _results(client: Any, job: str, pending: list[Sample], seed: int, top: int | None, say: Callable[[str], None]) -> Iterable[dict[str, Any]]:
    """Submits the samples and yields their results as they complete. A sample whose worker
    was lost is rerun by Dask on another (up to the scheduler's allowed failures); one that
    still cannot finish, or raises, is reported and left out of ``sweep.csv``, so that a
    rerun computes it."""
    from dask.distributed import as_completed

    futures = [
        client.submit(run_sample, job, s, seed, top, key=f"nnm-sample-{s.index}-{s.name}", pure=False)
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
    what = row["branch"] + "".join(f" {k}={row[k]}" for k in row if k.startswith(("model.", "settings.", "branch.")))
    if row["sigma"]:
        what += f" σ={row['sigma']:g} r={row['replicate']}"
    if row["status"] != "ok":
        return f"nnm sweep: [{done}/{total}] {what}: failed after {row['points']} points: {row['message']}"
    return (
        f"nnm sweep: [{done}/{total}] {what}: E = {row['energy']:.4g}, ω = {row['frequency']:.6g} rad/s, "
        f"localization {row['localization']:.3f} ({row['seconds']:.2f} s)"
    )


# ----------------------------------------------------------------------------------------
# Statistics and figures


def _groups(rows: list[dict[str, str]], grid_keys: list[str]) -> dict[tuple, list[dict[str, str]]]:
    """The rows by branch, grid point and ``σ``, failed ones included."""
    groups: dict[tuple, list[dict[str, str]]] = {}
    for r in rows:
        key = (r["branch"], *(float(r[k]) for k in grid_keys), float(r["sigma"]))
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
