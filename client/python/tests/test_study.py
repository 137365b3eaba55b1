"""client.study: the same study as `cleave study --server`."""
from __future__ import annotations

import csv
import io
import math
import subprocess

import numpy as np
import pytest

import cleave_client as cc
from cleave_client.study import Metric, error, pareto, set_key
from conftest import SCENES, binary


def short_bar(tmp_path):
    # the wave bar, short and coarse: the momentum the pushed end has put in
    # at 50 us is rho A c v t = 8000 · 1e-4 · 5000 · 1 · 5e-5 = 0.2
    text = ((SCENES / "wave_bar.toml").read_text()
            .replace("cell_size = 0.005", "cell_size = 0.01")
            .replace("end = 2.5e-4", "end = 5.0e-5"))
    path = tmp_path / "bar.toml"
    path.write_text(text)
    return path


def test_a_study_through_the_server_matches_the_cli(client, server, tmp_path):
    scene = short_bar(tmp_path)
    out = tmp_path / "py"
    r = client.study(scene, {"time.cfl": [0.2, 0.5], "transfer.scheme": ["pic", "flip"]},
                     metric="final:momentum_x", reference="analytic:0.2", out=out)
    assert [run.settings for run in r.runs] == [
        {"time.cfl": 0.2, "transfer.scheme": "pic"}, {"time.cfl": 0.2, "transfer.scheme": "flip"},
        {"time.cfl": 0.5, "transfer.scheme": "pic"}, {"time.cfl": 0.5, "transfer.scheme": "flip"}]
    for run in r.runs:
        assert run.status == "ok" and run.state == "succeeded"
        assert abs(run.metric / 0.2 - 1) < 0.1
        assert run.error == pytest.approx(abs(run.metric / 0.2 - 1), abs=1e-12)
    assert r.runs[0].steps > r.runs[2].steps  # the smaller CFL factor takes more steps
    assert any(run.pareto for run in r.runs)
    t = r.table()
    assert t.shape == (4,) and list(t["run"]) == [0, 1, 2, 3]
    # study.png as the command line draws it: a point per run (the
    # reference is analytic, so every run has an error), the front joined
    fig = r.plot(out / "study.png")
    assert (out / "study.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    ax = fig.axes[0]
    np.testing.assert_array_equal(ax.collections[0].get_offsets(),
                                  [[run.wall_seconds, run.error] for run in r.runs])
    front = sorted((run.wall_seconds, run.error) for run in r.runs if run.pareto)
    np.testing.assert_array_equal(np.column_stack(ax.lines[0].get_data()), front)
    assert ax.get_title() == "final:momentum_x against 0.2"
    # the same study by the command line against the same server
    cli = tmp_path / "cli"
    subprocess.run([str(binary("cleave")), "--server", server.url, "study", str(scene),
                    "--vary", "time.cfl=0.2,0.5", "--vary", "transfer.scheme=pic,flip",
                    "--metric", "final:momentum_x", "--reference", "analytic:0.2",
                    "--out", str(cli)], check=True, capture_output=True)
    ours = list(csv.DictReader(io.StringIO((out / "study.csv").read_text())))
    theirs = list(csv.DictReader(io.StringIO((cli / "study.csv").read_text())))
    assert list(ours[0]) == list(theirs[0])  # the same columns
    for a, b in zip(ours, theirs, strict=True):
        for col in ("run", "time.cfl", "transfer.scheme", "status", "steps", "particles",
                    "metric", "error", "reference"):
            assert a[col] == b[col], (col, a, b)
    # each run's scene and series are kept, as the command line keeps them
    assert (out / "runs" / "003" / "scene.json").is_file()
    def numbers(path):
        head, *rows = path.read_text().splitlines()
        return head, np.array([[float(x) for x in row.split(",")] for row in rows])

    for k in range(4):
        a, b = (numbers(d / "runs" / f"{k:03}" / "series.csv") for d in (out, cli))
        assert a[0] == b[0]
        np.testing.assert_array_equal(a[1], b[1])


def test_a_study_refuses_bad_settings_before_submitting(client, tmp_path):
    before = sum(1 for _ in client.jobs())
    with pytest.raises(cc.InvalidScene) as e:
        client.study(short_bar(tmp_path), ["time.cfl=0.2,-1"], metric="final:momentum_x")
    assert any(f.path == "time.cfl" and "(with time.cfl=-1)" in f.reason for f in e.value.fields), e.value.fields
    assert sum(1 for _ in client.jobs()) == before


def test_settings_metrics_and_the_front():
    doc = {"bodies": [{"particles_per_cell": 2}], "dfg": {"a": 1}}
    set_key(doc, "bodies[0].particles_per_cell", "3")
    set_key(doc, "time.cfl", 0.4)
    set_key(doc, "transfer.scheme", "quadratic_bspline")
    set_key(doc, "dfg", "off")
    set_key(doc, "contact", "on")
    assert doc == {"bodies": [{"particles_per_cell": 3}], "time": {"cfl": 0.4},
                   "transfer": {"scheme": "quadratic_bspline"}, "contact": {}}
    with pytest.raises(cc.InvalidScene) as e:
        set_key(doc, "bodies[4].x", 1)
    assert e.value.fields[0].path == "bodies[4].x" and "out of range" in e.value.fields[0].reason

    s = np.array([(0.0, 0.0, 1.0, 0.0, 0.0), (1.0, 0.5, 0.5, 0.2, 0.1), (2.0, 1.5, 0.0, 0.5, 0.3)],
                 dtype=[("time", "f8"), ("x", "f8"), ("kinetic_energy", "f8"), ("strain_energy", "f8"),
                        ("external_work", "f8")])
    assert Metric.parse("x").measure(s) == 1.5
    assert Metric.parse("max:kinetic_energy").measure(s) == 1.0
    assert Metric.parse("min:x").measure(s) == 0.0
    assert Metric.parse("arrival:x=1.0").measure(s) == pytest.approx(1.5)
    assert Metric.parse("energy_loss").measure(s) == pytest.approx(1.0 - (0.5 - 0.3))
    for bad in ("arrival:x", "crack_angle:1", "propagation_energyX", "mean:x", "final:"):
        with pytest.raises(ValueError):
            Metric.parse(bad)
    with pytest.raises(ValueError, match="no column 'y'"):
        Metric.parse("y").measure(s)
    assert error(1.1, 1.0) == pytest.approx(0.1) and error(0.5, 0.0) == 0.5
    assert pareto([(1, 0.5), (2, 0.1), (3, 0.2), (math.nan, 0.0)]) == [True, True, False, False]


def test_a_study_goes_on_with_the_jobs_an_earlier_one_submitted(client, tmp_path):
    scene = short_bar(tmp_path)
    out = tmp_path / "study"
    vary = {"time.cfl": [0.3, 0.5]}
    first = client.study(scene, vary, metric="final:momentum_x", out=out)
    before = sum(1 for _ in client.jobs())
    # the same out again without resume: refused, nothing submitted or lost
    with pytest.raises(FileExistsError, match="resume=True"):
        client.study(scene, vary, metric="final:momentum_x", out=out)
    # other settings into the same out: refused before anything is submitted
    with pytest.raises(ValueError, match="not this study's run 1"):
        client.study(scene, {"time.cfl": [0.3, 0.4]}, metric="final:momentum_x", out=out, resume=True)
    assert sum(1 for _ in client.jobs()) == before
    # resumed: the earlier jobs are followed, none submitted again
    again = client.study(scene, vary, metric="final:momentum_x", out=out, resume=True)
    assert sum(1 for _ in client.jobs()) == before
    assert [r.job_id for r in again.runs] == [r.job_id for r in first.runs]
    assert [r.metric for r in again.runs] == [r.metric for r in first.runs]
    # a job the server no longer knows is submitted again
    (out / "runs" / "001" / "job").write_text("no-such-job\n")
    third = client.study(scene, vary, metric="final:momentum_x", out=out, resume=True)
    assert sum(1 for _ in client.jobs()) == before + 1
    assert third.runs[0].job_id == first.runs[0].job_id
    assert third.runs[1].job_id != first.runs[1].job_id
    assert (out / "runs" / "001" / "job").read_text().strip() == third.runs[1].job_id
    assert third.runs[1].metric == first.runs[1].metric
