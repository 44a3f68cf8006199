"""Shared fixtures: the `nnm` command-line tool (to compare the bindings with it), job
files written into a temporary folder, and a two-process Dask cluster for the sweeps."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")  # figures render headless

ROOT = Path(__file__).resolve().parents[3]


# An 8-blade linear disk under engine order 2, with Rayleigh damping: the forced sweeps' test
# model (its linear responses are a complex solve away).
LINEAR_DISK = """
[model]
family = "bladed-disk"
sectors = 8
cubic = 0.0
damping = { rayleigh = [0.0, 4e-3] }

[[response]]
name = "eo2"
force = { engine_order = 2, amplitude = 0.01, sector_dof = 1 }
frequency_start = 1.9
frequency_end = 2.7
"""


@pytest.fixture(scope="session")
def cli() -> Path:
    """The release build of the `nnm` binary (`scripts/test-all` builds it through
    `cargo test`); built here when missing, so that the comparisons with the command line
    never silently skip."""
    target = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    binary = target / "release" / "nnm"
    if not binary.exists():
        cargo = shutil.which("cargo")
        if cargo is None:
            pytest.fail(f"{binary} is missing and cargo is not on PATH to build it")
        subprocess.run([cargo, "build", "--release", "-q", "-p", "nnm-cli"], cwd=ROOT, check=True)
    return binary


@pytest.fixture
def write_job(tmp_path: Path):
    """Writes a job file (and any extra files) into a temporary folder; returns its path."""

    def write(text: str, **files: str) -> Path:
        for name, content in files.items():
            (tmp_path / name).write_text(content)
        path = tmp_path / "job.toml"
        path.write_text(text)
        return path

    return write


def cli_error(cli: Path, *args: str) -> str:
    """The one-line message of a command that must fail (`error: ` removed)."""
    result = subprocess.run([str(cli), *map(str, args)], capture_output=True, text=True)
    assert result.returncode == 1, result.stderr
    lines = [line for line in result.stderr.splitlines() if line.startswith("error: ")]
    assert len(lines) == 1, result.stderr
    return lines[0].removeprefix("error: ")


def check_declared_columns(points, declared, columns, module) -> list:
    """That the per-point arrays of ``points`` (a Branch, a Response) and its ``to_pandas()``
    come from the library's one list of columns ``declared`` (the native tuples), read by
    ``module`` as ``columns``, not from a list of their own: one array per column, of its
    kind and shape; the arrays a type checker is told of are the columns and the two that are
    not columns of the points' table; no CSV header that differs from its array's name is
    spelled out in ``module``; ``to_pandas()`` has the CSV's columns in their order. Returns
    the columns the CSV has."""
    import inspect

    keys = [c[0] for c in declared]
    assert [c.key for c in columns] == keys and len(set(keys)) == len(keys)
    dtypes = {"float": np.float64, "integer": np.int64, "optional-integer": np.float64, "bool": np.bool_,
              "text": object}
    for c in columns:
        values = getattr(points, c.key)
        shape = (len(points), len(points.output_dofs)) if c.per_output_dof else (len(points),)
        assert values.dtype == dtypes[c.kind] and values.shape == shape, c
        assert c.unit and c.doc and ("<d>" in c.name) == c.per_output_dof, c
    arrays = {name for name, hint in type(points).__annotations__.items() if hint == "np.ndarray"}
    assert arrays == set(keys) | {"state0", "multipliers"}
    source = inspect.getsource(module)
    for c in columns:
        if c.name != c.key:
            assert f'"{c.name.split("<")[0]}' not in source, c.name
    csv = [c for c in columns if c.csv]
    header = [name for c in csv for name in (
        [c.name.replace("<d>", str(d)) for d in points.output_dofs] if c.per_output_dof else [c.name])]
    assert list(points.to_pandas().columns) == header
    return csv


@pytest.fixture(scope="module")
def client():
    """Two worker processes, one thread each: what `--workers 2` starts (one cluster per test
    module that sweeps)."""
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with distributed.Client(cluster) as c:
            yield c
