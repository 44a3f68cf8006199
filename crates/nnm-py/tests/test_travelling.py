"""Travelling waves from Python (docs/method.md §17): the same branch as `nnm run` with
`pattern = "travelling"`, and an independent check of what the reduced shooting does not
impose — over a whole period, each blade moves as its neighbour did d T / N earlier."""

from __future__ import annotations

import subprocess

import numpy as np
import pandas as pd
import pytest

import nnm

JOB = """
[model]
family = "bladed-disk"

[settings]
frequency_shift_max = 0.05
events = false

[[branch]]
name = "tw"
mode = "1,5"
pattern = "travelling"
"""


@pytest.fixture(scope="module")
def disk() -> nnm.Model:
    return nnm.bladed_disk()


def test_the_travelling_wave_equals_the_command_lines(disk, cli, write_job, tmp_path) -> None:
    branch = nnm.backbone(disk, (1, 5), pattern="travelling", frequency_shift_max=0.05,
                          events=False, progress=False)
    assert branch.pattern == "travelling"
    job = write_job(JOB)
    subprocess.run([str(cli), "run", str(job), "--out", str(tmp_path / "out"), "--quiet"],
                   check=True)
    table = pd.read_csv(tmp_path / "out" / "tw.csv")
    assert np.array_equal(table["frequency_rad_s"].to_numpy(), np.asarray(branch.frequency))
    assert np.array_equal(table["energy"].to_numpy(), np.asarray(branch.energy))


def test_each_blade_moves_as_its_neighbour_did_d_t_over_n_earlier(disk) -> None:
    branch = nnm.backbone(disk, (1, 5), pattern="travelling", frequency_shift_max=0.05,
                          events=False, progress=False)
    sectors, d, samples = 30, 5, 120
    t, x = branch.motion(len(branch.energy) - 1, samples=samples)[:2]
    blades = np.asarray(x)[:, 1::2]  # blade dofs, one column per sector
    lag = d * samples // sectors  # d T / N in samples
    moved = np.roll(blades[:samples], -lag, axis=0)  # x(t + d T/N)
    # Sector k + 1 at t + d T/N is sector k at t (forward wave).
    error = np.abs(np.roll(moved, -1, axis=1) - blades[:samples]).max()
    assert error < 1e-7 * np.abs(blades).max(), error
    # Every blade reaches the same amplitude.
    peaks = np.abs(blades).max(axis=0)
    assert np.ptp(peaks) < 1e-3 * peaks.max()


def test_travelling_needs_a_pair_and_the_dense_formulation(disk) -> None:
    with pytest.raises(ValueError, match="degenerate pair"):
        nnm.backbone(disk, (1, 0), pattern="travelling", max_points=2, progress=False)
    with pytest.raises(ValueError, match="pattern"):
        nnm.backbone(disk, (1, 5), pattern="rotating", max_points=2, progress=False)
    with pytest.raises(ValueError, match="dense formulation"):
        nnm.backbone(disk, (1, 5), pattern="travelling", formulation="matrix-free", max_points=2,
                     progress=False)
