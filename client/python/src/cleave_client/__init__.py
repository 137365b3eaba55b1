"""cleave-client: the Python client of the cleave dynamic-fracture service.

    from cleave_client import Client
    with Client("localhost:50051") as c:
        job = c.submit("scenes/two_disks.toml")
        job.wait()
        f = job.fields("latest", names=["position", "velocity"])
        s = job.series()

The gRPC stubs under ``cleave_client._proto`` are generated from
``proto/cleave.proto`` when the package is built.
"""
from ._client import (
    FINAL_STATES,
    Client,
    Event,
    FieldInfo,
    Fields,
    Finished,
    GridInfo,
    Job,
    JobInfo,
    LinesInfo,
    Progress,
    Progressed,
    SnapshotInfo,
    StateChanged,
    Summary,
    Validation,
)
from .errors import (
    CleaveError,
    FailedPrecondition,
    FieldError,
    InvalidArgument,
    InvalidScene,
    JobFailed,
    NotFound,
    ResourceExhausted,
    Unauthenticated,
    Unavailable,
)
from .study import Metric, StudyResult, StudyRun

__version__ = "0.1.0"

__all__ = [
    "FINAL_STATES", "Client", "Event", "FieldInfo", "Fields", "Finished", "GridInfo", "Job",
    "JobInfo", "LinesInfo", "Progress", "Progressed", "SnapshotInfo", "StateChanged", "Summary",
    "Validation", "CleaveError", "FailedPrecondition", "FieldError", "InvalidArgument",
    "InvalidScene", "JobFailed", "NotFound", "ResourceExhausted", "Unauthenticated",
    "Unavailable", "Metric", "StudyResult", "StudyRun",
]
