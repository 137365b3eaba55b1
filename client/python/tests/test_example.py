"""The Snakemake example runs end to end against the test server."""
from __future__ import annotations

import csv
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import SCENES

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "Snakefile"


def test_the_snakemake_study_runs_end_to_end(server, tmp_path):
    if sys.version_info < (3, 11):
        pytest.skip("Snakemake 8 and newer need Python 3.11; the client itself runs on 3.10")
    snakemake = shutil.which("snakemake", path=str(Path(sys.executable).parent)) or shutil.which("snakemake")
    if snakemake is None:
        pytest.fail("snakemake not installed: pip install './client/python[test]'")
    work = tmp_path / "wf"
    r = subprocess.run([snakemake, "--cores", "1", "--snakefile", str(EXAMPLE), "--directory", str(work),
                        "--config", f"server={server.address}", f"scene={SCENES / 'wave_bar.toml'}"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-3000:]
    rows = list(csv.DictReader((work / "study" / "study.csv").open()))
    assert len(rows) == 6 and all(row["status"] == "ok" for row in rows)
    # the momentum the pushed end put in is within 5 % of rho A c v t
    assert all(float(row["error"]) < 0.05 for row in rows), rows
    front = list(csv.DictReader((work / "front.csv").open()))
    assert 1 <= len(front) <= 6 and all(row["pareto"] == "true" for row in front)
    assert (work / "study" / "runs" / "005" / "series.csv").is_file()
