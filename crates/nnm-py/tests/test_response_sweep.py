"""Mistuned forced responses on Dask (``nnm.sweep(..., responses=[...])``, ``python -m nnm sweep
--response``, docs/method.md §21): on a linear 8-blade disk the sweep's peaks are those of the
complex solve ``(K − Ω²M + iΩC)⁻¹F`` done here with numpy on the mistuned matrices at the curve's
own frequencies, every amplification stays below Whitehead's bound ``(1 + √N)/2`` and tends to 1
as σ → 0; a rerun resumes, a second sweep gives the same numbers; bad input is one line."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
import pytest

import nnm
from conftest import LINEAR_DISK
from nnm import sweeps

distributed = pytest.importorskip("distributed")


def rows(out: Path) -> list[dict[str, str]]:
    with (out / "sweep.csv").open(newline="") as f:
        return sorted(csv.DictReader(f), key=lambda r: int(r["index"]))


def test_a_linear_mistuned_disk_stays_below_whiteheads_bound(write_job, tmp_path: Path, client) -> None:
    job = write_job(LINEAR_DISK)
    levels = [1e-5, 0.02, 0.1]
    result = nnm.sweep(job, tmp_path / "out", responses=["eo2"], samples=12, mistuning=levels, seed=3, client=client, progress=False)
    assert result.failed == 0 and not result.missing
    table = rows(tmp_path / "out")
    assert len(table) == 1 + 3 * 12
    tuned = [r for r in table if float(r["sigma"]) == 0]
    assert len(tuned) == 1 and float(tuned[0]["amplification"]) == 1.0
    bound = sweeps.whitehead_bound(8)
    factor = {s: [float(r["amplification"]) for r in table if float(r["sigma"]) == s] for s in levels}
    assert all(0 < f < bound for fs in factor.values() for f in fs), factor
    # σ → 0: the tuned disk's peak (a factor 1 + O(σ)); some real amplification at σ = 0.02.
    assert max(abs(f - 1.0) for f in factor[1e-5]) < 1e-3, factor[1e-5]
    assert max(factor[0.02]) > 1.05, factor[0.02]

    # One mistuned sample against numpy's complex solve on the same mistuned matrices.
    row = next(r for r in table if float(r["sigma"]) == 0.1 and r["replicate"] == "5")
    deviations = 0.1 * sweeps.mistuning_draw(3, 5, 8)
    model = nnm.Model.from_job(job, {"model.blade_stiffness_mistuning": deviations.tolist()})
    dense = lambda a: np.asarray(a.todense() if hasattr(a, "todense") else a)  # noqa: E731
    M, K = dense(model.M), dense(model.K)
    C = 4e-3 * K
    F = np.zeros(16, dtype=complex)
    for s in range(8):
        F[2 * s + 1] = 0.01 * np.exp(-2j * np.pi * 2 * s / 8)  # a cos(Ωt − 2πks/N)
    curve = np.genfromtxt(tmp_path / "out" / "samples" / "eo2_sigma=0.1_r5.csv", delimiter=",", names=True)
    blades = np.arange(1, 16, 2)
    exact = [np.abs(np.linalg.solve(K - w * w * M + 1j * w * C, F))[blades].max() for w in curve["frequency_rad_s"]]
    # At the default tolerance (1e-8 in the residual) a point's peak is good to a few 1e-7.
    np.testing.assert_allclose(curve["peak"], exact, rtol=2e-6)
    assert float(row["peak"]) == pytest.approx(max(exact), rel=2e-6)
    assert int(row["peak_blade"]) == int(np.argmax(np.abs(np.linalg.solve(
        K - float(row["peak_frequency"]) ** 2 * M + 1j * float(row["peak_frequency"]) * C, F))[blades]))

    # Statistics per level: the mean, quantiles and the largest of the factors above.
    with (tmp_path / "out" / "statistics.csv").open(newline="") as f:
        stats = {float(r["sigma"]): r for r in csv.DictReader(f)}
    for s in levels:
        assert float(stats[s]["amplification_max"]) == pytest.approx(max(factor[s]), rel=1e-12)
        assert float(stats[s]["amplification_mean"]) == pytest.approx(np.mean(factor[s]), rel=1e-12)
    assert (tmp_path / "out" / "amplification.png").exists()


def test_a_response_sweep_resumes_and_repeats_its_numbers(write_job, tmp_path: Path, client) -> None:
    job = write_job(LINEAR_DISK)
    first = nnm.sweep(job, tmp_path / "a", responses=["eo2"], samples=2, mistuning=[0.05], client=client, progress=False)
    again = nnm.sweep(job, tmp_path / "a", responses=["eo2"], samples=3, mistuning=[0.05], client=client, progress=False)
    assert (first.computed, again.computed, again.skipped) == (3, 1, 3)
    other = nnm.sweep(job, tmp_path / "b", responses=["eo2"], samples=3, mistuning=[0.05], client=client, progress=False)
    drop = ("seconds",)
    assert [{k: v for k, v in r.items() if k not in drop} for r in rows(tmp_path / "a")] == [
        {k: v for k, v in r.items() if k not in drop} for r in rows(tmp_path / "b")
    ]
    assert other.computed == 4


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"responses": ["nope"]}, "the job has no response `nope` (its responses: `eo2`)"),
        ({"responses": ["eo2"], "branches": ["b"]}, "a sweep follows either branches or responses, not both"),
        ({"responses": []}, "responses is empty"),
        ({"responses": ["eo2"], "localization_sectors": 2}, "localization_sectors applies to a sweep of branches"),
    ],
)
def test_bad_response_sweeps_are_refused_before_anything_is_written(write_job, tmp_path: Path, kwargs, message) -> None:
    job = write_job(LINEAR_DISK)
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        nnm.sweep(job, tmp_path / "out", samples=2, mistuning=[0.01], progress=False, **kwargs)
    assert not (tmp_path / "out").exists()


def test_a_response_with_several_levels_is_refused(write_job, tmp_path: Path) -> None:
    job = write_job(LINEAR_DISK.replace("frequency_end = 2.7", "frequency_end = 2.7\namplitudes = [0.01, 0.02]"))
    with pytest.raises(ValueError, match="response `eo2` has 2 force levels"):
        nnm.sweep(job, tmp_path / "out", responses=["eo2"], samples=2, mistuning=[0.01], progress=False)


def test_command_line_response_sweep(write_job, tmp_path: Path) -> None:
    """`python -m nnm sweep --response`: the rows of the Python call, computed on a worker
    process (here one, without figures); a response the job lacks is one line, status 2."""
    import subprocess
    import sys

    job = write_job(LINEAR_DISK)
    out = tmp_path / "cli"
    command = [sys.executable, "-m", "nnm", "sweep", str(job), "--out", str(out), "--response", "eo2",
               "--samples", "1", "--mistuning", "0.02", "--workers", "1", "--no-figures"]  # fmt: skip
    run = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    table = rows(out)
    assert [r["sigma"] for r in table] == ["0.0", "0.02"] and all(r["status"] == "ok" for r in table)
    here = sweeps.run_response_sample(str(job.resolve()), sweeps.Sample(1, "eo2", (), 0.02, 0), seed=0)["row"]
    assert float(table[1]["peak"]) == here["peak"]
    assert float(table[1]["amplification"]) == here["peak"] / float(table[0]["peak"])
    bad = subprocess.run([sys.executable, "-m", "nnm", "sweep", str(job), "--out", str(tmp_path / "bad"),
                          "--response", "nope", "--samples", "1", "--mistuning", "0.02"],
                         capture_output=True, text=True, timeout=300)  # fmt: skip
    assert bad.returncode == 2 and bad.stderr.strip().splitlines() == [
        "error: the job has no response `nope` (its responses: `eo2`)"
    ], bad.stderr
    assert not (tmp_path / "bad").exists()


def test_a_row_without_its_tuned_peak_is_read_back_and_filled_when_the_peak_comes() -> None:
    """A mistuned row written before its tuned sample had a peak (it failed, raised or the
    sweep stopped) has empty `tuned_peak` and `amplification`: a rerun reads it, and fills
    both once the tuned row is there."""
    def row(sigma: str, replicate: str, peak: str) -> dict[str, str]:
        values = {c: "1" for c in sweeps._RESPONSE_NUMBER_COLUMNS}
        return {**values, "response": "eo2", "sigma": sigma, "replicate": replicate, "peak": peak,
                "tuned_peak": "", "amplification": "", "status": "ok"}  # fmt: skip

    mistuned = row("0.02", "0", "0.75")
    sweeps._check_row(mistuned)
    assert sweeps._row_key(mistuned, []) == ("eo2", (), 0.02, 0)
    assert not sweeps._fill_references([mistuned], [])
    rows = [mistuned, row("0.0", "0", "0.5")]
    assert sweeps._fill_references(rows, [])
    assert (float(mistuned["tuned_peak"]), float(mistuned["amplification"])) == (0.5, 1.5)
    # A tuned row whose peak is not a number is no reference.
    other = row("0.02", "1", "0.75")
    assert not sweeps._fill_references([other, row("0.0", "0", "nan")], [])

