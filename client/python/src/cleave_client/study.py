"""Accuracy against cost through a server: ``cleave study`` in Python.

The same study as the ``cleave study --server`` command (and the same
``study.csv``): one scene at every combination of a few settings (the first
setting varies slowest), one number of each run's series (the metric)
against a reference, and the Pareto front of wall time against error. Every
variant is validated before any is submitted; all are submitted at once,
so the server runs them up to its own limit in parallel.

Settings are dotted keys into the scene, with array indices
(``bodies[0].particles_per_cell``). A value is set as given; a string value
is read as ``cleave study --vary`` reads it: a JSON literal (a number,
``true``, an array) or else a bare string (``quadratic_bspline``), and
``"on"``/``"off"`` keep/add or remove a whole table (``dfg=off``).
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Optional, Union

import numpy as np

from . import errors
from ._scene import SceneLike, scene_document

__all__ = ["Metric", "StudyResult", "StudyRun", "error", "pareto", "set_key", "run"]


# -- settings ------------------------------------------------------------
def _segments(key: str) -> list[tuple[str, list[int]]]:
    out = []
    for seg in key.split("."):
        name, _, rest = seg.partition("[")
        if not name:
            raise ValueError(f"{key}: empty segment")
        idx = []
        if rest:
            for part in ("[" + rest).split("[")[1:]:
                if not part.endswith("]") or not part[:-1].isdigit():
                    raise ValueError(f"{key}: bad index in {seg!r} (write name[0])")
                idx.append(int(part[:-1]))
        out.append((name, idx))
    return out


def _literal(raw: Any) -> Any:
    """A command-line value: a JSON number, bool, string or array, else the
    bare string. Values that are not strings are kept as they are."""
    if not isinstance(raw, str):
        return raw
    try:
        v = json.loads(raw)
    except ValueError:
        return raw
    return v if isinstance(v, (int, float, bool, str, list)) else raw


def set_key(doc: dict, key: str, value: Any) -> None:
    """Sets dotted ``key`` in the scene document ``doc`` (tables on the way
    are made); ``"on"``/``"off"`` switch a whole table. Raises
    :class:`~cleave_client.InvalidScene` naming the key."""
    def bad(reason: str) -> errors.InvalidScene:
        return errors.InvalidScene.of([errors.FieldError(key, reason)])

    try:
        segs = _segments(key)
    except ValueError as e:
        raise bad(str(e)) from None
    at: Any = doc
    for k, (name, idx) in enumerate(segs):
        last = k + 1 == len(segs)
        if not isinstance(at, dict):
            raise bad(f"{name!r} is inside something that is not a table")
        if last and not idx:
            if value == "off":
                at.pop(name, None)
            elif value == "on":
                slot = at.setdefault(name, {})
                if not isinstance(slot, dict):
                    raise bad("`on`/`off` switch a table; this key is a value (use true/false or a number)")
            else:
                at[name] = _literal(value)
            return
        here = at.setdefault(name, {})
        for j, i in enumerate(idx):
            if not isinstance(here, list):
                raise bad(f"{name} is not an array")
            if i >= len(here):
                raise bad(f"index {i} out of range: {name} has {len(here)} entries")
            if last and j + 1 == len(idx):
                here[i] = _literal(value)
                return
            here = here[i]
        at = here


def _axes(vary) -> list[tuple[str, list[Any]]]:
    """``{"key": [v1, v2]}`` or ``["key=v1,v2", ...]`` (the command line's
    form) as (key, values) pairs, in order."""
    if isinstance(vary, dict):
        axes = [(k, list(v) if isinstance(v, (list, tuple)) else [v]) for k, v in vary.items()]
    else:
        axes = []
        for spec in vary:
            key, eq, text = spec.partition("=")
            if not eq or not key.strip():
                raise ValueError(f"vary {spec!r}: expected KEY=V1,V2,… (e.g. grid.cell_size=1e-3,5e-4)")
            values, depth, cur = [], 0, ""
            for ch in text:
                if ch in "[{":
                    depth += 1
                elif ch in "]}":
                    depth -= 1
                elif ch == "," and depth == 0:
                    values.append(cur.strip())
                    cur = ""
                    continue
                cur += ch
            values.append(cur.strip())
            if any(not v for v in values):
                raise ValueError(f"vary {spec!r}: an empty value")
            axes.append((key.strip(), values))
    if any(not values for _, values in axes):
        raise ValueError("vary: a setting with no values")
    return axes


def _text(v: Any) -> str:
    """A setting's value as the study's table writes it."""
    return v if isinstance(v, str) else json.dumps(v)


# -- the metric ----------------------------------------------------------
@dataclass(frozen=True)
class Metric:
    """The number measured in each run's series, as ``cleave study
    --metric`` takes it: ``COLUMN`` or ``final:COLUMN`` (the last value),
    ``max:COLUMN``, ``min:COLUMN``, ``arrival:COLUMN=VALUE`` (the first
    time the column reaches VALUE, interpolated, s), ``energy_loss``
    (kinetic + strain − external work, first row minus last, J),
    ``crack_angle:X0,Y0`` (the crack tip's angle seen from (X0, Y0),
    degrees) or ``propagation_energy[:ENERGY[,LENGTH]]`` (the ENERGY
    column's increase while the crack grows from 10 % to 99 % of its
    greatest LENGTH)."""

    kind: str
    column: str = ""
    value: float = math.nan
    origin: tuple[float, float] = (0.0, 0.0)
    length: str = ""

    @classmethod
    def parse(cls, spec: str) -> "Metric":
        if spec == "energy_loss":
            return cls("energy_loss", "kinetic_energy")
        if spec.startswith("propagation_energy"):
            rest = spec[len("propagation_energy"):]
            if rest and not rest.startswith(":"):
                cols = [""]
            else:
                cols = [c.strip() for c in rest[1:].split(",")] if rest else []
            if len(cols) > 2 or any(not c for c in cols):
                raise ValueError(f"metric {spec!r}: write propagation_energy[:ENERGY_COLUMN[,LENGTH_COLUMN]]")
            return cls("propagation_energy", cols[0] if cols else "fracture_energy",
                       length=cols[1] if len(cols) > 1 else "crack_length")
        if spec.startswith("crack_angle:"):
            try:
                x, y = (float(v) for v in spec[len("crack_angle:"):].split(","))
            except ValueError:
                x = y = math.nan
            if not (math.isfinite(x) and math.isfinite(y)):
                raise ValueError(f"metric {spec!r}: write crack_angle:X0,Y0 (the point the angle is seen from, m)")
            return cls("crack_angle", "crack_tip_x", origin=(x, y))
        kind, sep, rest = spec.partition(":")
        if not sep:
            kind, rest = "final", spec
        if not rest.strip() and kind in ("final", "max", "min"):
            raise ValueError(f"metric {spec!r}: no column")
        if kind in ("final", "max", "min"):
            return cls(kind, rest.strip())
        if kind == "arrival":
            col, eq, v = rest.partition("=")
            if not eq:
                raise ValueError(f"metric {spec!r}: write arrival:COLUMN=VALUE")
            if not col.strip():
                raise ValueError(f"metric {spec!r}: no column")
            try:
                return cls("arrival", col.strip(), float(v))
            except ValueError:
                raise ValueError(f"metric {spec!r}: {v.strip()!r} is not a number") from None
        raise ValueError(f"metric {spec!r}: unknown kind {kind!r} (final, max, min, arrival, "
                         "crack_angle, propagation_energy or energy_loss)")

    def measure(self, series: np.ndarray) -> float:
        """The metric of a run's series (a structured array, as
        :meth:`Job.series` gives); ValueError says why there is none."""
        names = series.dtype.names or ()

        def col(name: str) -> tuple[np.ndarray, np.ndarray]:
            if name not in names:
                raise ValueError(f"the series has no column {name!r} (it has: {', '.join(names)})")
            v = series[name]
            ok = np.isfinite(v)
            if not ok.any():
                raise ValueError(f"no finite values of {name!r}")
            return series["time"][ok], v[ok]

        if self.kind == "final":
            return float(col(self.column)[1][-1])
        if self.kind == "max":
            return float(col(self.column)[1].max())
        if self.kind == "min":
            return float(col(self.column)[1].min())
        if self.kind == "energy_loss":
            if len(series) == 0:
                raise ValueError("no rows")
            e = series["kinetic_energy"] + series["strain_energy"] - series["external_work"]
            loss = float(e[0] - e[-1])
            if not math.isfinite(loss):
                raise ValueError("the energies are not finite")
            return loss
        if self.kind == "crack_angle":
            x, y = col("crack_tip_x")[1][-1], col("crack_tip_y")[1][-1]
            return math.degrees(math.atan2(y - self.origin[1], x - self.origin[0]))
        if self.kind == "propagation_energy":
            t, length = col(self.length)
            longest = max(float(length.max()), 0.0)
            if longest <= 0.0:
                raise ValueError(f"no crack formed ({self.length} stays 0)")
            at = np.nonzero(length >= 0.99 * longest)[0]
            through = int(at[0]) if at.size else len(length) - 1
            before = np.nonzero(length[:through] <= 0.1 * longest)[0]
            start = int(before[-1]) if before.size else 0
            te, e = col(self.column)

            def value(tt: float) -> float:
                hit = np.nonzero(te == tt)[0]
                if not hit.size:
                    raise ValueError(f"{self.column} has no value at t = {tt:e} s")
                return float(e[hit[0]])

            return value(t[through]) - value(t[start])
        if self.kind == "arrival":
            t, v = col(self.column)
            target = self.value
            above = v[0] >= target
            if v[0] == target:
                return float(t[0])
            for k in range(len(v) - 1):
                a, b = v[k], v[k + 1]
                if (b >= target) != above or b == target:
                    s = 1.0 if b == a else (target - a) / (b - a)
                    return float(t[k] + min(max(s, 0.0), 1.0) * (t[k + 1] - t[k]))
            raise ValueError(f"{self.column} never reached {target:g}")
        raise ValueError(f"unknown metric kind {self.kind!r}")


def error(metric: float, reference: float) -> float:
    """Relative error |m − r| / |r| (absolute when r = 0)."""
    return abs(metric) if reference == 0 else abs((metric - reference) / reference)


def pareto(points: list[tuple[float, float]]) -> list[bool]:
    """Which (cost, error) points no other point beats in both (non-finite
    points are never on the front and do not dominate)."""
    def ok(p):
        return math.isfinite(p[0]) and math.isfinite(p[1])

    return [ok(p) and not any(ok(q) and q[0] <= p[0] and q[1] <= p[1] and (q[0] < p[0] or q[1] < p[1])
                              for q in points) for p in points]


# -- running it ------------------------------------------------------------
@dataclass
class StudyRun:
    """One variant: its settings, job and outcome."""

    index: int
    settings: dict[str, Any]
    scene: dict
    job_id: str
    state: str
    failure: Optional[str]
    wall_seconds: float
    steps: int
    particles: int
    series: Optional[np.ndarray]
    metric: float = math.nan
    error: float = math.nan
    status: str = ""
    reference: bool = False
    pareto: bool = False


@dataclass
class StudyResult:
    """Every run of a study with its metric, error and place on the Pareto
    front; ``reference_value`` is what the errors are against."""

    keys: list[str]
    metric: str
    reference: str
    reference_value: float
    runs: list[StudyRun]

    def table(self) -> np.ndarray:
        """The study as a structured array, one row per run (the columns of
        ``study.csv`` but the settings)."""
        dt = [("run", "i8"), ("wall_seconds", "f8"), ("steps", "i8"), ("particles", "i8"),
              ("metric", "f8"), ("error", "f8"), ("reference", "?"), ("pareto", "?")]
        return np.array([(r.index, r.wall_seconds, r.steps, r.particles, r.metric, r.error,
                          r.reference, r.pareto) for r in self.runs], dtype=dt)

    def plot(self, path: Union[str, Path, None] = None):
        """Error against wall time, as ``cleave study``'s ``study.png``: a
        point per run with a finite error (the reference run has none),
        labelled with its number and settings, the Pareto front joined, log
        axes where the values allow. Returns the matplotlib ``Figure``
        (made without pyplot, so no backend is chosen for the caller);
        with ``path``, saves it there. Needs matplotlib (the ``plot``
        extra: ``pip install 'cleave-client[plot]'``)."""
        try:
            from matplotlib.figure import Figure
        except ImportError as e:
            raise ImportError("StudyResult.plot needs matplotlib: pip install 'cleave-client[plot]'") from e
        shown = [r for r in self.runs if math.isfinite(r.error) and math.isfinite(r.wall_seconds)]
        fig = Figure(figsize=(7.0, 4.5))
        ax = fig.subplots()
        ax.scatter([r.wall_seconds for r in shown], [r.error for r in shown], s=18, label="runs")
        for r in shown:
            tag = " ".join(_text(r.settings[k]) for k in self.keys)
            ax.annotate(f"{r.index:03} {tag}", (r.wall_seconds, r.error), fontsize=7,
                        xytext=(4, 3), textcoords="offset points")
        front = sorted((r for r in shown if r.pareto), key=lambda r: r.wall_seconds)
        ax.plot([r.wall_seconds for r in front], [r.error for r in front], "r-", lw=1,
                label="Pareto front")
        if shown and min(r.wall_seconds for r in shown) > 0:
            ax.set_xscale("log")
        if shown and min(r.error for r in shown) > 0:
            ax.set_yscale("log")
        ref = (f"{self.reference_value:g}" if self.reference != "finest"
               else next((f"run {r.index:03}" for r in self.runs if r.reference), "none"))
        ax.set_title(f"{self.metric} against {ref}")
        ax.set_xlabel("wall time (s)")
        ax.set_ylabel("relative error")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        if path is not None:
            fig.savefig(path, dpi=110)
        return fig

    def csv(self) -> str:
        """``study.csv`` as ``cleave study`` writes it."""
        def cell(s: str) -> str:
            return '"' + s.replace('"', '""') + '"' if any(c in s for c in ',"\n') else s

        def num(v: float) -> str:
            return repr(float(v)) if math.isfinite(v) else ""

        lines = [",".join(["run", *self.keys, "status", "wall_seconds", "steps", "particles",
                           "metric", "error", "reference", "pareto"])]
        for r in self.runs:
            lines.append(",".join([str(r.index), *(cell(_text(r.settings[k])) for k in self.keys),
                                   cell(r.status), repr(float(r.wall_seconds)), str(r.steps),
                                   str(r.particles), num(r.metric), num(r.error),
                                   str(r.reference).lower(), str(r.pareto).lower()]))
        return "\n".join(lines) + "\n"


def _earlier_jobs(client, out_dir: Optional[Path], docs: list, resume: bool) -> list:
    """The jobs an earlier study into ``out_dir`` submitted, per variant
    (None: submit it), checked as :func:`run` says."""
    found: list = [None] * len(docs)
    if out_dir is None:
        return found
    runs = out_dir / "runs"
    held = [k for k in range(len(docs)) if (runs / f"{k:03}" / "job").is_file()]
    if held and not resume:
        raise FileExistsError(f"{out_dir} holds the runs of an earlier study: resume=True goes on "
                              "with it (its jobs are followed), or give another out")
    if not resume:
        return found
    for k, d in enumerate(docs):
        scene_file = runs / f"{k:03}" / "scene.json"
        if scene_file.is_file() and json.loads(scene_file.read_text()) != json.loads(json.dumps(d)):
            raise ValueError(f"resume: {scene_file} is not this study's run {k}: the scene or the "
                             "settings changed; resume with the ones it was started with, or give another out")
    for k in held:
        job = client.job(((runs / f"{k:03}" / "job").read_text()).strip())
        try:
            job.info()
        except errors.NotFound:
            continue  # the server no longer has it: submitted again
        found[k] = job
    return found


def run(client, scene: SceneLike, vary, metric: str, reference: str = "finest",
        out: Union[str, Path, None] = None, *, label: str = "study",
        resume: bool = False) -> StudyResult:
    """Runs a study on ``client``'s server and returns it; with ``out``,
    writes ``out/study.csv`` and, per run, ``out/runs/NNN/scene.json``,
    ``series.csv`` and ``job`` (its id), as ``cleave study`` does.

    A study outlives its process as ``cleave study --server --resume``'s
    does: an ``out`` that holds an earlier study's runs is refused
    (FileExistsError: nothing stored is overwritten) unless ``resume``; then
    each run whose ``job`` the server still knows is followed rather than
    submitted again (a finished one is fetched), the others are submitted,
    and a run whose ``scene.json`` is not this study's (the scene or the
    settings changed) raises ValueError before anything is submitted.

    ``vary`` is ``{"time.cfl": [0.2, 0.4], ...}`` or the command line's
    ``["time.cfl=0.2,0.4", ...]``; ``metric`` as :class:`Metric` parses it;
    ``reference`` is ``"finest"`` (the run with the most particle-steps) or
    ``"analytic:VALUE"``. A scene any variant makes invalid raises
    :class:`~cleave_client.InvalidScene` with every problem of every
    variant, before anything is submitted.
    """
    m = Metric.parse(metric)
    if reference == "finest":
        ref_value = None
    elif reference.startswith("analytic:"):
        try:
            ref_value = float(reference[len("analytic:"):])
        except ValueError:
            ref_value = math.nan
        if not math.isfinite(ref_value):
            raise ValueError(f"reference {reference!r}: not a finite number")
    else:
        raise ValueError(f"reference {reference!r}: write finest or analytic:VALUE")
    axes = _axes(vary)
    doc = scene_document(scene)
    # every combination, the first axis slowest, each validated
    total = math.prod(len(v) for _, v in axes)
    variants, problems = [], []
    for n in range(total):
        rest, pick = n, [0] * len(axes)
        for a in range(len(axes) - 1, -1, -1):
            pick[a] = rest % len(axes[a][1])
            rest //= len(axes[a][1])
        settings = {key: values[pick[a]] for a, (key, values) in enumerate(axes)}
        d = json.loads(json.dumps(doc))
        tag = " ".join(f"{k}={_text(v)}" for k, v in settings.items())
        try:
            for k, v in settings.items():
                set_key(d, k, v)
        except errors.InvalidScene as e:
            problems.extend(errors.FieldError(f.path, f"{f.reason} (with {tag})") for f in e.fields)
            continue
        check = client.validate(d)
        problems.extend(errors.FieldError(f.path, f"{f.reason} (with {tag})") for f in check.errors)
        variants.append((settings, d))
    if problems:
        raise errors.InvalidScene.of(problems)
    out_dir = Path(out) if out is not None else None
    earlier = _earlier_jobs(client, out_dir, [d for _, d in variants], resume)
    jobs = []
    for k, (_, d) in enumerate(variants):
        job = earlier[k] or client.submit(d, label=f"{label} {k:03}")
        jobs.append(job)
        if out_dir is not None and earlier[k] is None:
            rd = out_dir / "runs" / f"{k:03}"
            rd.mkdir(parents=True, exist_ok=True)
            (rd / "scene.json").write_text(json.dumps(d, indent=2) + "\n")
            (rd / "job").write_text(job.id + "\n")
    runs = []
    for k, ((settings, d), job) in enumerate(zip(variants, jobs, strict=True)):
        info = job.wait(raise_on_failure=False)
        s = info.summary
        try:
            series = job.series()
        except errors.FailedPrecondition:
            series = None  # a run that failed before its first row
        failure = None if info.state == "succeeded" else (info.error or info.state)
        runs.append(StudyRun(k, settings, d, job.id, info.state, failure,
                             s.wall_seconds if s else math.nan, s.steps if s else 0,
                             info.particles, series))
        if out_dir is not None and series is not None:
            names = series.dtype.names
            rows = [",".join(names)] + [",".join(repr(float(x)) for x in row) for row in series.tolist()]
            (out_dir / "runs" / f"{k:03}" / "series.csv").write_text("\n".join(rows) + "\n")
    for r in runs:
        if r.failure is not None:
            r.status = f"failed: {r.failure}"
            continue
        try:
            r.metric = m.measure(r.series)
            r.status = "ok"
        except ValueError as e:
            r.status = str(e)
    measured = [r for r in runs if r.status == "ok"]
    ref_run = None
    if ref_value is None and measured:
        ref_run = max(measured, key=lambda r: (r.particles * r.steps, r.wall_seconds))
        ref_run.reference = True
        ref_value = ref_run.metric
    for r in runs:
        if r.status == "ok" and r is not ref_run and ref_value is not None:
            r.error = error(r.metric, ref_value)
    for r, front in zip(runs, pareto([(r.wall_seconds, r.error) for r in runs]), strict=True):
        r.pareto = front
    result = StudyResult([k for k, _ in axes], metric, reference,
                         math.nan if ref_value is None else ref_value, runs)
    if out_dir is not None:
        out_dir.mkdir(parents=True, exist_ok=True)
        (out_dir / "study.csv").write_text(result.csv())
    return result
