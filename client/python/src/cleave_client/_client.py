"""The client: a thin, typed layer over the generated gRPC stubs."""
from __future__ import annotations

import logging
import time
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Optional, Sequence, Union

import grpc
import numpy as np

from . import errors
from ._proto import cleave_pb2 as pb
from ._proto import cleave_pb2_grpc as pb_grpc
from ._scene import SceneLike, scene_text

_log = logging.getLogger("cleave_client")

# The largest message this client takes: a series of a long run is one
# FetchSeries message (rows × columns doubles); field data come in chunks
# of at most 1 MiB.
MAX_MESSAGE_BYTES = 512 << 20

_STATES = {
    pb.JOB_STATE_UNSPECIFIED: "unspecified",
    pb.JOB_STATE_QUEUED: "queued",
    pb.JOB_STATE_RUNNING: "running",
    pb.JOB_STATE_SUCCEEDED: "succeeded",
    pb.JOB_STATE_FAILED: "failed",
    pb.JOB_STATE_CANCELLED: "cancelled",
}
_STATE_VALUES = {v: k for k, v in _STATES.items()}
FINAL_STATES = frozenset({"succeeded", "failed", "cancelled"})

# Codes after which a watch connects again: the server or the path to it
# went away (a restart, a dropped connection, a proxy's idle cut).
_RECONNECT = frozenset({grpc.StatusCode.UNAVAILABLE, grpc.StatusCode.ABORTED})

_LOCATIONS = {
    "particles": pb.LOCATION_PARTICLES,
    "grid": pb.LOCATION_GRID,
    "lines": pb.LOCATION_LINES,
}
_DTYPES = {pb.DATA_TYPE_FLOAT64: np.dtype("<f8"), pb.DATA_TYPE_UINT32: np.dtype("<u4")}


def _time(t: float) -> Optional[float]:
    return t if t > 0 else None


@dataclass(frozen=True)
class Progress:
    """Where a running job is (or where it ended)."""

    step: int
    time: float
    end_time: float
    fraction: float
    eta_seconds: float
    kinetic_energy: float
    strain_energy: float
    wall_seconds: float

    @classmethod
    def _of(cls, p: pb.Progress) -> "Progress":
        return cls(p.step, p.time, p.end_time, p.fraction, p.eta_seconds,
                   p.kinetic_energy, p.strain_energy, p.wall_seconds)


@dataclass(frozen=True)
class Summary:
    """How a job ended: steps, simulated and wall time, final energies (J)."""

    steps: int
    time: float
    wall_seconds: float
    kinetic_energy: float
    strain_energy: float
    external_work: float
    energy_error: float
    snapshots: int
    series_rows: int

    @classmethod
    def _of(cls, s: pb.Summary) -> "Summary":
        return cls(s.steps, s.time, s.wall_seconds, s.kinetic_energy, s.strain_energy,
                   s.external_work, s.energy_error, s.snapshots, s.series_rows)


@dataclass(frozen=True)
class JobInfo:
    """A job as the server describes it. Times are seconds since the Unix
    epoch (None until they happen); ``scene`` is None unless asked for."""

    id: str
    label: str
    state: str
    created_at: Optional[float]
    started_at: Optional[float]
    finished_at: Optional[float]
    error: str
    particles: int
    stages: tuple[str, ...]
    progress: Optional[Progress]
    summary: Optional[Summary]
    scene: Optional[str]
    scene_name: str
    #: The server (``host-pid``) that runs or ran the job, where servers
    #: share a queue (``cleave-server --store postgres://...``); else "".
    worker: str = ""

    @property
    def finished(self) -> bool:
        return self.state in FINAL_STATES

    @classmethod
    def _of(cls, j: pb.Job, full: bool = False) -> "JobInfo":
        return cls(
            id=j.id,
            label=j.label,
            state=_STATES.get(j.state, "unspecified"),
            created_at=_time(j.created_at),
            started_at=_time(j.started_at),
            finished_at=_time(j.finished_at),
            error=j.error,
            particles=j.particles,
            stages=tuple(j.stages),
            progress=Progress._of(j.progress) if j.HasField("progress") else None,
            summary=Summary._of(j.summary) if j.HasField("summary") else None,
            scene=j.scene if full else None,
            scene_name=j.scene_name,
            worker=j.worker,
        )


@dataclass(frozen=True)
class Event:
    """One event of a job; ``sequence`` counts 0, 1, 2, … per job."""

    sequence: int


@dataclass(frozen=True)
class StateChanged(Event):
    state: str
    error: str = ""

    @property
    def final(self) -> bool:
        return self.state in FINAL_STATES


@dataclass(frozen=True)
class Progressed(Event):
    progress: Progress


@dataclass(frozen=True)
class Finished(Event):
    summary: Summary


def _event(ev: pb.JobEvent) -> Event:
    kind = ev.WhichOneof("event")
    if kind == "state":
        return StateChanged(ev.sequence, _STATES.get(ev.state.state, "unspecified"), ev.state.error)
    if kind == "progress":
        return Progressed(ev.sequence, Progress._of(ev.progress))
    if kind == "summary":
        return Finished(ev.sequence, Summary._of(ev.summary))
    return Event(ev.sequence)


@dataclass(frozen=True)
class FieldInfo:
    """A field of a snapshot: its name, numpy dtype and numbers per point."""

    name: str
    dtype: np.dtype
    components: int

    @classmethod
    def _of(cls, f: pb.FieldInfo) -> "FieldInfo":
        return cls(f.name, _DTYPES.get(f.dtype, np.dtype("<f8")), f.components)


@dataclass(frozen=True)
class GridInfo:
    """The background grid of a snapshot: node (i, j, k) sits at
    ``origin + spacing * (i, j, k)`` and is point ``i + nx * (j + ny * k)``
    of a grid field."""

    origin: tuple[float, float, float]
    spacing: float
    shape: tuple[int, int, int]  # (nx, ny, nz); nz = 1 in 2D
    fields: tuple[FieldInfo, ...]

    @property
    def nodes(self) -> int:
        nx, ny, nz = self.shape
        return nx * ny * nz

    def coordinates(self) -> np.ndarray:
        """Every node's position, nodes × 3, in the order of a grid field."""
        nx, ny, nz = self.shape
        k, j, i = np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij")
        ijk = np.stack([i.ravel(), j.ravel(), k.ravel()], axis=1)
        return np.asarray(self.origin) + self.spacing * ijk

    def reshape(self, values: np.ndarray) -> np.ndarray:
        """A grid field (nodes × components) as an array indexed
        ``[k, j, i]`` (``[k, j, i, c]`` with components)."""
        nx, ny, nz = self.shape
        return values.reshape((nz, ny, nx) + values.shape[1:])

    @classmethod
    def _of(cls, g: pb.GridInfo) -> "GridInfo":
        return cls((g.origin_x, g.origin_y, g.origin_z), g.spacing,
                   (g.nx, g.ny, g.nz or 1), tuple(FieldInfo._of(f) for f in g.fields))


@dataclass(frozen=True)
class LinesInfo:
    """A snapshot's polylines (explicit cracks): points per line, fields."""

    counts: tuple[int, ...]
    fields: tuple[FieldInfo, ...]


@dataclass(frozen=True)
class SnapshotInfo:
    index: int
    step: int
    time: float
    particles: int
    dimension: int
    particle_fields: tuple[FieldInfo, ...]
    grid: Optional[GridInfo]
    lines: Optional[LinesInfo]

    @classmethod
    def _of(cls, s: pb.SnapshotInfo) -> "SnapshotInfo":
        return cls(
            index=s.index,
            step=s.step,
            time=s.time,
            particles=s.particles,
            dimension=s.dimension or 2,
            particle_fields=tuple(FieldInfo._of(f) for f in s.particle_fields),
            grid=GridInfo._of(s.grid) if s.HasField("grid") else None,
            lines=LinesInfo(tuple(s.lines.counts), tuple(FieldInfo._of(f) for f in s.lines.fields))
            if s.HasField("lines") else None,
        )


class Fields(Mapping):
    """The fields of one snapshot at one location, by name: numpy arrays of
    points × components (a scalar field is one-dimensional). ``snapshot``
    says which snapshot they are (index, step, time, the grid's geometry)."""

    def __init__(self, snapshot: SnapshotInfo, location: str, arrays: dict[str, np.ndarray]):
        self.snapshot = snapshot
        self.location = location
        self._arrays = arrays

    @property
    def grid(self) -> Optional[GridInfo]:
        return self.snapshot.grid

    def __getitem__(self, name: str) -> np.ndarray:
        return self._arrays[name]

    def __iter__(self):
        return iter(self._arrays)

    def __len__(self) -> int:
        return len(self._arrays)

    def __repr__(self) -> str:
        shapes = ", ".join(f"{k}{tuple(v.shape)}" for k, v in self._arrays.items())
        return f"Fields(snapshot={self.snapshot.index}, t={self.snapshot.time:g} s, {self.location}: {shapes})"


@dataclass(frozen=True)
class Validation:
    """What the server says of a scene without running it."""

    valid: bool
    errors: tuple[errors.FieldError, ...]
    particles: int = 0
    stages: tuple[str, ...] = ()
    cells: tuple[int, ...] = ()
    memory_bytes: int = 0
    memory: str = ""
    time_step: float = 0.0
    steps: float = 0.0

    def raise_for_errors(self) -> None:
        """Raises :class:`~cleave_client.InvalidScene` naming every field."""
        if not self.valid:
            raise errors.InvalidScene.of(self.errors)


def _target(url: str) -> tuple[str, bool]:
    """(host:port, TLS) of ``host:port``, ``http://host:port`` or
    ``https://host:port``."""
    if "://" not in url:
        return url, False
    scheme, rest = url.split("://", 1)
    rest = rest.rstrip("/")
    if scheme == "http":
        return rest, False
    if scheme == "https":
        return rest, True
    raise ValueError(f"url: unknown scheme {scheme!r} (write host:port, http://… or https://…)")


class Client:
    """A connection to a cleave server.

    ``url`` is ``host:port`` or ``http://host:port`` (plain), or
    ``https://host:port`` (TLS); ``ca_cert`` (a PEM file) is the authority
    that signed the server's certificate and implies TLS. ``token`` is the
    server's bearer token (``cleave-server --token``). ``timeout`` is the
    deadline, in seconds, of each unary call (None: none).
    """

    def __init__(self, url: str = "localhost:50051", token: Optional[str] = None,
                 ca_cert: Union[str, Path, bytes, None] = None, *,
                 timeout: Optional[float] = None):
        target, tls = _target(url)
        options = [
            ("grpc.max_receive_message_length", MAX_MESSAGE_BYTES),
            ("grpc.max_send_message_length", MAX_MESSAGE_BYTES),
        ]
        if tls or ca_cert is not None:
            root = ca_cert if isinstance(ca_cert, (bytes, type(None))) else Path(ca_cert).read_bytes()
            creds = grpc.ssl_channel_credentials(root_certificates=root)
            self._channel = grpc.secure_channel(target, creds, options)
        else:
            self._channel = grpc.insecure_channel(target, options)
        self._stub = pb_grpc.CleaveStub(self._channel)
        self._metadata = (("authorization", f"Bearer {token}"),) if token else ()
        self.url = url
        self.timeout = timeout

    # -- plumbing -------------------------------------------------------
    def _call(self, method: str, request: Any, timeout: Optional[float] = None):
        try:
            return getattr(self._stub, method)(
                request, metadata=self._metadata,
                timeout=self.timeout if timeout is None else timeout)
        except grpc.RpcError as e:
            raise errors.from_rpc(e) from None

    def close(self) -> None:
        self._channel.close()

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # -- jobs -----------------------------------------------------------
    def submit(self, scene: SceneLike, *, label: str = "") -> "Job":
        """Validates and queues a scene (a path, TOML or JSON text, or a
        dict). Raises :class:`~cleave_client.InvalidScene` naming every bad
        field."""
        text, fmt = scene_text(scene)
        j = self._call("SubmitJob", pb.SubmitJobRequest(scene=text, format=fmt, label=label))
        return Job(self, j.id, JobInfo._of(j))

    def validate(self, scene: SceneLike) -> Validation:
        """Checks a scene without running it (never raises for a bad scene:
        see ``Validation.valid`` and ``errors``)."""
        text, fmt = scene_text(scene)
        r = self._call("ValidateScene", pb.ValidateSceneRequest(scene=text, format=fmt))
        cells = (r.cells_x, r.cells_y) + ((r.cells_z,) if r.cells_z else ())
        return Validation(
            valid=r.valid,
            errors=tuple(errors.FieldError(e.path, e.reason) for e in r.errors),
            particles=r.particles, stages=tuple(r.stages), cells=cells,
            memory_bytes=r.memory_bytes, memory=r.memory,
            time_step=r.time_step, steps=r.steps,
        )

    def job(self, job_id: str) -> "Job":
        """A handle on a job the server has (no call is made)."""
        return Job(self, job_id)

    def jobs(self, state: Optional[str] = None, *, page_size: int = 100) -> Iterator[JobInfo]:
        """Every job, newest first (only those in ``state`` if given)."""
        want = pb.JOB_STATE_UNSPECIFIED
        if state is not None:
            if state not in _STATE_VALUES or state == "unspecified":
                raise ValueError(f"state: {state!r} is not one of {sorted(FINAL_STATES | {'queued', 'running'})}")
            want = _STATE_VALUES[state]
        token = ""
        while True:
            r = self._call("ListJobs", pb.ListJobsRequest(page_size=page_size, page_token=token, state=want))
            for j in r.jobs:
                yield JobInfo._of(j)
            token = r.next_page_token
            if not token:
                return

    def study(self, scene: SceneLike, vary, metric: str, reference: str = "finest",
              out: Union[str, Path, None] = None, *, label: str = "study", resume: bool = False):
        """``cleave study`` through this server: see :func:`cleave_client.study.run`."""
        from .study import run

        return run(self, scene, vary, metric, reference, out, label=label, resume=resume)


class Job:
    """A job on the server. Every method is a call (nothing is cached but
    the id)."""

    def __init__(self, client: Client, job_id: str, info: Optional[JobInfo] = None):
        self.client = client
        self.id = job_id
        self.submitted = info
        #: How many times :meth:`watch` has connected again after a drop.
        self.reconnects = 0

    def __repr__(self) -> str:
        return f"Job({self.id!r})"

    def info(self, *, full: bool = False) -> JobInfo:
        """The job now (with its scene's text if ``full``)."""
        view = pb.JOB_VIEW_FULL if full else pb.JOB_VIEW_BASIC
        return JobInfo._of(self.client._call("GetJob", pb.GetJobRequest(job_id=self.id, view=view)), full)

    @property
    def state(self) -> str:
        return self.info().state

    def cancel(self) -> JobInfo:
        """Cancels a queued or running job (within a second); a finished
        one is returned unchanged."""
        return JobInfo._of(self.client._call("CancelJob", pb.CancelJobRequest(job_id=self.id)))

    def watch(self, *, reconnect_timeout: float = 60.0,
              deadline: Optional[float] = None) -> Iterator[Event]:
        """Every event of the job, in order and each once, from its
        submission to its final state.

        A dropped stream (the server restarting, a connection cut) is
        connected again, with backoff, for up to ``reconnect_timeout``
        seconds of failing to reach the server; the server replays the
        job's events from the start and the ones already given are
        skipped by their sequence number. ``deadline`` is a
        ``time.monotonic()`` instant after which the watch stops with a
        :class:`~cleave_client.CleaveError` of code ``DEADLINE_EXCEEDED``.
        """
        last = -1
        down_since: Optional[float] = None
        delay = 0.05
        while True:
            timeout = None if deadline is None else max(0.0, deadline - time.monotonic())
            stream = None
            final = False
            try:
                stream = self.client._stub.WatchJob(
                    pb.WatchJobRequest(job_id=self.id), metadata=self.client._metadata, timeout=timeout)
                for ev in stream:
                    down_since, delay = None, 0.05
                    if ev.sequence <= last:
                        continue  # seen before the connection dropped
                    last = ev.sequence
                    e = _event(ev)
                    final = final or (isinstance(e, StateChanged) and e.final)
                    yield e
                if final:
                    return
                # the stream ended before the final state: the server went
                # away in an orderly way; ask again
            except grpc.RpcError as err:
                if err.code() not in _RECONNECT:
                    raise errors.from_rpc(err) from None
                if final:
                    return
                _log.info("watch %s: %s after event %d; connecting again", self.id, err.code().name, last)
            finally:
                if stream is not None:
                    stream.cancel()
            now = time.monotonic()
            if down_since is None:
                down_since = now
            elif now - down_since > reconnect_timeout:
                raise errors.Unavailable(
                    f"watching {self.id}: the server did not answer for {reconnect_timeout:g} s",
                    grpc.StatusCode.UNAVAILABLE)
            if deadline is not None and now >= deadline:
                raise errors.CleaveError(f"watching {self.id}: deadline passed",
                                         grpc.StatusCode.DEADLINE_EXCEEDED)
            time.sleep(delay)
            delay = min(2 * delay, 2.0)
            self.reconnects += 1

    def wait(self, timeout: Optional[float] = None, *, raise_on_failure: bool = True,
             reconnect_timeout: float = 60.0) -> JobInfo:
        """Follows the job to its end and returns it. A job that failed or
        was cancelled raises :class:`~cleave_client.JobFailed` (unless
        ``raise_on_failure`` is false); after ``timeout`` seconds,
        ``TimeoutError`` (the job goes on)."""
        deadline = None if timeout is None else time.monotonic() + timeout
        try:
            for _ in self.watch(reconnect_timeout=reconnect_timeout, deadline=deadline):
                pass
        except errors.CleaveError as e:
            if e.code == grpc.StatusCode.DEADLINE_EXCEEDED:
                raise TimeoutError(f"job {self.id} still running after {timeout:g} s") from None
            raise
        info = self.info()
        if raise_on_failure and info.state != "succeeded":
            raise errors.JobFailed(info)
        return info

    def snapshots(self) -> list[SnapshotInfo]:
        """The job's snapshots so far, in order."""
        r = self.client._call("ListSnapshots", pb.ListSnapshotsRequest(job_id=self.id))
        return [SnapshotInfo._of(s) for s in r.snapshots]

    def fields(self, snapshot: Union[int, str] = "latest", names: Optional[Sequence[str]] = None,
               location: str = "particles") -> Fields:
        """The fields of one snapshot (its index, or ``"latest"``) at
        ``location`` (``"particles"``, ``"grid"`` or ``"lines"``), as numpy
        arrays of points × components; ``names`` chooses fields (None:
        all)."""
        if location not in _LOCATIONS:
            raise ValueError(f"location: {location!r} is not one of {sorted(_LOCATIONS)}")
        latest = snapshot == "latest"
        if not latest and not isinstance(snapshot, int):
            raise ValueError(f"snapshot: an index or 'latest', not {snapshot!r}")
        req = pb.FetchFieldsRequest(job_id=self.id, snapshot=0 if latest else snapshot,
                                    location=_LOCATIONS[location], fields=list(names or ()),
                                    latest=latest)
        info: Optional[SnapshotInfo] = None
        arrays: dict[str, np.ndarray] = {}
        filled: dict[str, int] = {}
        shapes: dict[str, int] = {}
        try:
            for chunk in self.client._stub.FetchFields(req, metadata=self.client._metadata,
                                                       timeout=self.client.timeout):
                if chunk.HasField("snapshot"):
                    info = SnapshotInfo._of(chunk.snapshot)
                dtype = _DTYPES.get(chunk.dtype)
                if dtype is None:
                    raise errors.CleaveError(f"field {chunk.field}: unknown data type {chunk.dtype}")
                a = arrays.get(chunk.field)
                if a is None:
                    a = arrays[chunk.field] = np.empty(chunk.total, dtype)
                    filled[chunk.field] = 0
                    shapes[chunk.field] = max(chunk.components, 1)
                part = np.frombuffer(chunk.data, dtype)
                end = chunk.offset + part.size
                if end > a.size:
                    raise errors.CleaveError(
                        f"field {chunk.field}: values {chunk.offset}..{end} of {a.size}")
                a[chunk.offset:end] = part
                filled[chunk.field] += part.size
        except grpc.RpcError as e:
            raise errors.from_rpc(e) from None
        if info is None:
            raise errors.CleaveError(f"{self.id}: the server sent no snapshot")
        for name, a in arrays.items():
            if filled[name] != a.size:
                raise errors.CleaveError(f"field {name}: {filled[name]} of {a.size} values arrived")
            c = shapes[name]
            if c > 1:
                arrays[name] = a.reshape(-1, c)
        return Fields(info, location, arrays)

    def series(self, *, frame: bool = False):
        """The time series (``series.csv``): a numpy structured array with
        one float field per column, or with ``frame=True`` a pandas
        DataFrame."""
        r = self.client._call("FetchSeries", pb.FetchSeriesRequest(job_id=self.id))
        cols = list(r.columns)
        values = np.asarray(r.values, dtype=np.float64).reshape(r.rows, len(cols))
        if frame:
            try:
                import pandas as pd
            except ImportError as e:
                raise ImportError("series(frame=True) needs pandas: pip install 'cleave-client[pandas]'") from e
            return pd.DataFrame(values, columns=cols)
        out = np.empty(r.rows, dtype=[(c, np.float64) for c in cols])
        for k, c in enumerate(cols):
            out[c] = values[:, k]
        return out
