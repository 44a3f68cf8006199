"""Branch switching from Python is `nnm run`'s `start = { branch, event }`: the same switched
branch, bit for bit, and the same refusals."""

from __future__ import annotations

import json
import subprocess

import numpy as np
import pytest

import nnm
from conftest import ROOT


@pytest.mark.parametrize(
    "job, parent, child",
    [
        ("two-dof-bifurcation.toml", "in-phase", "symmetry-broken"),
        ("period-doubling.toml", None, None),
    ],
)
def test_a_switched_branch_is_the_command_lines(job, parent, child, cli, tmp_path) -> None:
    path = ROOT / "examples" / job
    model = nnm.Model.from_job(path)
    if parent is None:  # the job's first branch and the one switched from it
        parent, child = model.branches[0], model.branches[1]
    out = tmp_path / "out"
    subprocess.run([str(cli), "run", str(path), "--out", str(out), "--quiet"], check=True, capture_output=True)
    document = json.loads((out / f"{child}.json").read_text())
    parent_branch = nnm.backbone(model, branch=parent)
    settings = _child_settings(path, child)
    switched = parent_branch.switch(document["switched_from"]["event"], progress=False, **settings)
    assert switched.switched_from["kind"] == document["switched_from"]["type"]
    assert switched.switched_from["phase"] == document["switched_from"]["phase"]
    assert switched.mode == parent_branch.mode
    points = document["points"]
    assert len(switched) == len(points) > 3
    assert np.array_equal(switched.state0, [p["z0"] for p in points])
    assert np.array_equal(switched.energy, [p["energy"] for p in points])
    assert np.array_equal(switched.period, [p["period_s"] for p in points])


def _child_settings(path, child: str) -> dict:
    """The switched branch's settings as the job gives them: its [settings] overridden by the
    branch's own keys (without `name` and `start`)."""
    import tomllib

    job = tomllib.loads(path.read_text())
    table = next(b for b in job["branch"] if b["name"] == child)
    own = {k: v for k, v in table.items() if k not in ("name", "start")}
    return {**job.get("settings", {}), **own}


def test_switching_is_refused_where_it_does_not_apply() -> None:
    parent = nnm.backbone(nnm.two_dof(), 0, energy_max=100.0, progress=False)
    assert [e.kind for e in parent.events] == ["branch-point"]
    with pytest.raises(ValueError, match="^the branch has 1 event, so no event 3$"):
        nnm.switch(parent, 3, energy_max=100.0)
    with pytest.raises(ValueError, match="^the branch has 1 event, so no event -2$"):
        nnm.switch(parent, -2, energy_max=100.0)
    with pytest.raises(TypeError, match="^event must be an integer, got str$"):
        nnm.switch(parent, "0", energy_max=100.0)
    with pytest.raises(ValueError, match="^direction must be 0 or more, got -1$"):
        nnm.switch(parent, 0, direction=-1, energy_max=100.0)
    assert nnm.switch(parent, -1, max_points=1, progress=False).switched_from["event"] == 0
    with pytest.raises(ValueError, match="`pattern` does not apply to a branch that starts from an event"):
        nnm.switch(parent, 0, energy_max=100.0, pattern="cos")
    with pytest.raises(ValueError, match="give a stop limit"):
        nnm.switch(parent, 0)
    with pytest.raises(ValueError, match=r"direction 1 asked, but the event has 1 new null direction"):
        nnm.switch(parent, 0, direction=1, energy_max=100.0)
