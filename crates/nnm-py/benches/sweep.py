"""Parallel efficiency of a mistuning sweep on Dask (the targets: a 200-sample sweep of
one bladed-disk mode family on a 2-worker LocalCluster within 10% of 200 × one sample's time
÷ 2; a forced one, ``--response eo5``, at an efficiency of at least 0.9). One run measures,
side by side:

- the same samples computed one after another in this process (``nnm.sweeps.run_sample``, or
  ``run_response_sample`` with ``--response``; no Dask): their total time ``T_serial``;
- the sweep itself (``nnm.sweep`` on a fresh 2-worker ``LocalCluster``), wall time with and
  without starting the cluster.

The ratio ``wall / (T_serial / workers)`` is the sweep's cost over the ideal (1.00 = no
overhead; its inverse the efficiency); the target is at most 1.10.

    python crates/nnm-py/benches/sweep.py [--samples 200] [--workers 2] [--branch mode-1-14]
    python crates/nnm-py/benches/sweep.py --response eo5 --samples 100   # forced-bladed-disk.toml
"""

from __future__ import annotations

import argparse
import resource
import shutil
import tempfile
import time
from pathlib import Path

import nnm
from nnm import sweeps

ROOT = Path(__file__).resolve().parents[3]

def main() -> None:
    from dask.distributed import Client, LocalCluster

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--samples", type=int, default=200)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--sigma", type=float, default=0.02)
    parser.add_argument("--branch", default="mode-1-14")
    parser.add_argument("--response", help="a [[response]] of the job: a forced sweep")
    parser.add_argument("--job", help="default: examples/bladed-disk.toml, forced-bladed-disk.toml with --response")
    args = parser.parse_args()
    forced = args.response is not None
    job = args.job or str(ROOT / "examples" / ("forced-bladed-disk.toml" if forced else "bladed-disk.toml"))
    name = args.response if forced else args.branch
    run = sweeps.run_response_sample if forced else sweeps.run_sample
    what = {"responses": [name]} if forced else {"branches": [name]}

    # The tuned sample too when forced: the sweep computes it (the amplification's reference).
    todo = sweeps.plan([name], samples=args.samples, mistuning=[0.0, args.sigma] if forced else [args.sigma])
    began = time.perf_counter()
    for sample in todo:
        run(job, sample, seed=1)
    serial = time.perf_counter() - began

    out = Path(tempfile.mkdtemp(prefix="nnm-sweep-bench-"))
    try:
        began = time.perf_counter()
        with LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
            with Client(cluster) as client:
                client.wait_for_workers(args.workers)
                started = time.perf_counter()
                result = nnm.sweep(
                    job, out, **what, samples=args.samples, mistuning=[args.sigma], seed=1,
                    client=client, progress=False, figures=False,
                )  # fmt: skip
                swept = time.perf_counter() - started
        total = time.perf_counter() - began
    finally:
        shutil.rmtree(out, ignore_errors=True)

    ideal = serial / args.workers
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"{len(todo)} samples of {name}, σ = {args.sigma}, {result.failed} failed")
    print(f"  serial, this process        {serial:8.2f} s   ({serial / len(todo):.3f} s a sample)")
    print(f"  ideal on {args.workers} workers          {ideal:8.2f} s")
    print(f"  sweep on {args.workers} workers          {swept:8.2f} s   ratio {swept / ideal:.3f}, efficiency {ideal / swept:.3f}")
    print(f"  ... with cluster start/stop {total:8.2f} s   ratio {total / ideal:.3f}")
    print(f"  peak memory of this process {peak:8.0f} MB")


# Dask starts its worker processes by spawning: they import this file, which must not run.
if __name__ == "__main__":
    main()
