#!/usr/bin/env python3
"""Mistuned forced response of a LINEAR bladed disk against Whitehead's bound (issue 30,
docs/method.md §21): a sweep of the disk's engine-order response over blade-stiffness
mistuning, SAMPLES draws per level, on a 2-worker Dask LocalCluster. Fails (exit 1) unless

- every amplification factor stays below Whitehead's (1 + √N)/2;
- the mean factor tends to 1 as σ → 0 (within 1e-3 at the smallest level);
- the mean factor is largest at an intermediate σ, not at the smallest or the largest level
  (the classical curve: small mistuning barely localizes, large mistuning detunes the blades
  from one another).

Too long for CI (a few minutes); run by hand:

    .venv/bin/python scripts/whitehead-check.py [--samples 200] [--out whitehead/]
"""

from __future__ import annotations

import argparse
import csv
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import nnm
from nnm import sweeps

SECTORS = 8
JOB = f"""
[model]
family = "bladed-disk"
sectors = {SECTORS}
cubic = 0.0
damping = {{ rayleigh = [0.0, 4e-3] }}

[[response]]
name = "eo2"
force = {{ engine_order = 2, amplitude = 0.01, sector_dof = 1 }}
frequency_start = 1.5
frequency_end = 3.2
"""
LEVELS = [1e-5, 1e-3, 3e-3, 0.01, 0.03, 0.1, 0.2]  # 0.3 puts a blade below zero stiffness in 200 draws


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=200)
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()
    out = args.out or Path(tempfile.mkdtemp(prefix="whitehead-"))
    out.mkdir(parents=True, exist_ok=True)
    job = out / "job.toml"
    job.write_text(JOB)
    started = time.perf_counter()
    result = nnm.sweep(job, out / "sweep", responses=["eo2"], samples=args.samples, mistuning=LEVELS, seed=11, workers=2, progress=False)
    seconds = time.perf_counter() - started
    if result.failed or result.missing:
        print(f"FAIL: {result.failed} failed rows, {len(result.missing)} missing samples", file=sys.stderr)
        return 1
    with (out / "sweep" / "sweep.csv").open(newline="") as f:
        rows = list(csv.DictReader(f))
    bound = sweeps.whitehead_bound(SECTORS)
    print(f"{len(rows)} samples in {seconds:.0f} s on 2 workers; Whitehead's bound (1 + √{SECTORS})/2 = {bound:.4f}")
    print(f"{'sigma':>8} {'mean':>8} {'q90':>8} {'max':>8}")
    means = []
    worst = 0.0
    for sigma in LEVELS:
        factors = np.array([float(r["amplification"]) for r in rows if float(r["sigma"]) == sigma])
        means.append(factors.mean())
        worst = max(worst, factors.max())
        print(f"{sigma:>8g} {factors.mean():>8.4f} {np.quantile(factors, 0.9):>8.4f} {factors.max():>8.4f}")
    failures = []
    if worst >= bound:
        failures.append(f"a factor {worst:.4f} reaches Whitehead's bound {bound:.4f}")
    if abs(means[0] - 1.0) > 1e-3:
        failures.append(f"the mean at σ = {LEVELS[0]:g} is {means[0]:.6f}, not 1 to 1e-3")
    top = int(np.argmax(means))
    if top in (0, len(LEVELS) - 1):
        failures.append(f"the mean is largest at σ = {LEVELS[top]:g}, an end of the levels")
    for why in failures:
        print(f"FAIL: {why}", file=sys.stderr)
    print(f"results in {out}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
