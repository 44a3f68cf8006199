"""Checks a study's event lists against an independent fine scan of each backbone's multipliers.

    python scripts/event-scan.py OUT [--samples 800] [--window 0.03] [--cache FILE]

OUT is the folder of `nnm example bladed-disk --out OUT` (or `nnm study`). Each backbone of
OUT/backbones is recomputed with the Python API, events off, with points placed exactly at
`--samples` energies spaced geometrically over the backbone's range (`at_energies`); the
pattern of its multipliers off the unit circle by more than 1e-4 (complex, positive real,
negative real) is compared sample to sample. Every change of the pattern is at least one event
(a Krein collision, a pair through +1 or -1). Printed per family (n = 0, n = 1): the scan's
changes, the study's events (folds excepted), how many of those lie at a change (within
`--window` relative in energy: the scan sees a change only once the pair is 1e-4 off the
circle) and how many changes have an event there. docs/method.md §8 "What detection cannot
see" quotes the figures (about 5 minutes on one core). With `--cache FILE` the scan's changes
are kept in FILE (JSON) and read from it when it exists, so several study outputs of the same
model (builds, settings) are compared with one scan.
"""

import argparse
import csv
import json
import pathlib
import sys

import numpy as np

import nnm

STABILITY_TOLERANCE = 1e-4


def pattern(multipliers):
    """Counts of complex, positive-real and negative-real multipliers off the circle."""
    z = np.asarray(multipliers).astype(complex)[:-2]  # the trivial pair is listed last
    off = np.abs(np.abs(z) - 1) > STABILITY_TOLERANCE
    real = np.abs(z.imag) <= 1e-6
    return (
        int(np.sum(off & ~real)),
        int(np.sum(off & real & (z.real > 0))),
        int(np.sum(off & real & (z.real < 0))),
    )


def scan(model, label, e_first, e_last, samples):
    """Energies at which the pattern changes along the backbone `label`."""
    energies = np.geomspace(e_first * 1.0001, e_last * 0.9999, samples)
    branch = nnm.backbone(
        model, label, energy_max=e_last, at_energies=list(energies), events=False,
        max_step=0.05, progress=False, raise_on_failure=False,
    )
    changes, previous = [], None
    for energy, label_i, multipliers in zip(branch.energy, branch.label, branch.multipliers):
        if not label_i:
            continue
        current = pattern(multipliers)
        if previous is not None and current != previous:
            changes.append(float(energy))
        previous = current
    return changes


def near(value, others, window):
    return any(abs(o - value) <= window * max(o, value) for o in others)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=pathlib.Path)
    parser.add_argument("--samples", type=int, default=800)
    parser.add_argument("--window", type=float, default=0.03)
    parser.add_argument("--cache", type=pathlib.Path, help="JSON file keeping the scan's changes")
    args = parser.parse_args()
    cached = json.loads(args.cache.read_text()) if args.cache and args.cache.exists() else {}
    job = args.out / "bladed-disk.toml"
    if not job.exists():
        sys.exit(f"error: {job} not found (run nnm example bladed-disk --out {args.out})")
    model = nnm.Model.from_job(str(job))
    totals = {}
    for path in sorted((args.out / "backbones").glob("mode-*.csv")):
        if path.name.endswith(".events.csv"):
            continue
        name = path.stem
        n, d = map(int, name.split("-")[1:3])
        rows = list(csv.DictReader(open(path)))
        if name not in cached:
            cached[name] = scan(
                model, (n, d), float(rows[0]["energy"]), float(rows[-1]["energy"]), args.samples
            )
            if args.cache:
                args.cache.write_text(json.dumps(cached))
        changes = cached[name]
        events = [
            float(r["energy"])
            for r in csv.DictReader(open(path.with_suffix(".events.csv")))
            if r["type"] != "fold"
        ]
        at_change = sum(near(e, changes, args.window) for e in events)
        found = sum(near(c, events, args.window) for c in changes)
        print(f"{name}: {len(changes)} changes, {len(events)} events ({at_change} at a change), "
              f"{found} changes found", flush=True)
        t = totals.setdefault(n, [0, 0, 0, 0])
        for k, v in enumerate((len(changes), len(events), at_change, found)):
            t[k] += v
    for n, (changes, events, at_change, found) in sorted(totals.items()):
        print(f"n = {n}: {changes} changes, {events} events, {at_change / max(events, 1):.0%} of "
              f"the events at a change, {found / max(changes, 1):.0%} of the changes found")


if __name__ == "__main__":
    main()
