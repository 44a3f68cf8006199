"""Shared fixtures: the `nnm` command-line tool (to compare the bindings with it) and job
files written into a temporary folder."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import matplotlib
import pytest

matplotlib.use("Agg")  # figures render headless

ROOT = Path(__file__).resolve().parents[3]


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
