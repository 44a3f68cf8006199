"""Cost of the bindings on a bladed-disk backbone (the target: under 5% of the
backbone's time): the wall time of `nnm.backbone` against the time the library's
continuation took inside it (`Branch.wall_time`). The difference is everything the Python
call adds: modal analysis and start (also paid by `nnm run`), argument parsing, the GIL,
and copying the results into numpy arrays.

    python crates/nnm-py/benches/overhead.py [REPEATS]
"""

import statistics
import sys
import time

import nnm

repeats = int(sys.argv[1]) if len(sys.argv) > 1 else 7
model = nnm.bladed_disk()
for label, settings in [
    ("(1,5) to +10%, events off", {"frequency_shift_max": 0.1, "events": False}),
    ("(1,5) to +10%, events located", {"frequency_shift_max": 0.1}),
]:
    walls, shares = [], []
    for _ in range(repeats):
        began = time.perf_counter()
        branch = nnm.backbone(model, (1, 5), progress=False, **settings)
        wall = time.perf_counter() - began
        walls.append(wall)
        shares.append((wall - branch.wall_time) / wall)
    print(
        f"{label}: {len(branch)} points, wall {min(walls):.3f} s (best of {repeats}), "
        f"bindings + modal analysis {100 * statistics.median(shares):.2f}% (median)"
    )
