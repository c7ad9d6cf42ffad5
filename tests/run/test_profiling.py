"""``-log_view`` splits a run's time by pipeline stage, with the hot functions as events."""

import re

import pytest
from conftest import run_cli

from solver import profiling

pytestmark = pytest.mark.serial_only  # launches its own process

# Two documents: slicing + Verlet waves, then KPM + spectral waves; every stage runs.
SCENE = """\
output: {out}a.h5
cache: off
packing: {{n: 64, phi: 0.9}}
model: {{rho: 1}}
spectrum: {{energies: true}}
waves: {{n: [1], t_end: 10, dt: 0.05}}
---
output: {out}b.h5
cache: off
packing: {{n: 64, phi: 0.9}}
model: {{rho: 1}}
spectrum: {{method: kpm, probes: 4}}
modes: {{omega: [1.0]}}
transport: {{eta: 0.2}}
waves: {{n: [1], method: spectral, t_end: 10}}
"""
EXPECTED = {  # stage -> events that must be counted inside it
    "packings": ["rsPackingFIRE"],
    "assembly": ["rsAssemble"],
    "spectrum": ["rsInertia", "rsWindowSolve"],
    "kpm": ["rsKPMMoments"],
    "modes": ["rsModeShapes"],
    "transport": ["rsAFModes", "rsAFSum"],
    "waves": ["rsOmegaMax", "rsVerletStep", "rsLanczosWave"],
    "analysis": ["rsAnalyse"],
    "output": ["rsWriteResults"],
}


def event_counts(text: str) -> dict[str, dict[str, int]]:
    """stage -> {event: count} from the per-stage event tables of a -log_view file."""
    counts: dict[str, dict[str, int]] = {}
    stage = None
    for line in re.split(r"^Object Type\s+Creations", text, flags=re.M)[0].splitlines():
        header = re.match(r"--- Event Stage \d+: (.+)$", line)
        if header:
            stage = header.group(1).strip()
            counts[stage] = {}
        elif stage is not None and (row := re.match(r"^(\S+)\s+(\d+)\s+\d", line)):
            counts[stage][row.group(1)] = int(row.group(2))
    return counts


def test_log_view_splits_the_time_by_stage(tmp_path):
    path = tmp_path / "scene.yaml"
    path.write_text(SCENE.format(out=tmp_path / "r"))
    log = tmp_path / "log.txt"
    proc = run_cli(["run", str(path), "-log_view", f":{log}"], timeout=300)
    assert proc.returncode == 0, proc.stderr
    text = log.read_text()
    summary = text.split("Summary of Stages:")[1].split("\n\n")[0]
    counts = event_counts(text)
    assert set(EXPECTED) == set(profiling.STAGES)
    for stage, events in EXPECTED.items():
        assert re.search(rf"^\s*\d+:\s+{stage}: ", summary, re.M), f"stage {stage} missing:\n{summary}"
        for event in events:
            assert counts.get(stage, {}).get(event, 0) > 0, (stage, event, counts.get(stage))
    # the time went to the stages: the Verlet steps are in waves (10 / 0.05 steps per block: 200
    # per mode, 3 modes), none of them in the main stage
    assert counts["waves"]["rsVerletStep"] == 600, counts["waves"]
    assert "rsVerletStep" not in counts.get("Main Stage", {}), counts.get("Main Stage")
