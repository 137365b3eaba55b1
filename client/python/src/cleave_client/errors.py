"""Errors of the cleave service as Python exceptions.

Every call that the server refuses raises a :class:`CleaveError` (or one of
its subclasses, by gRPC status code) that keeps the gRPC code, the server's
message and the fields it named: an ``INVALID_ARGUMENT`` carries a
``google.rpc.BadRequest`` in its status details, one violation per bad
field (for a scene, the dotted path into the scene, e.g.
``materials.steel.youngs_modulus``; for a request, the request's field).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import grpc


@dataclass(frozen=True)
class FieldError:
    """One bad field: its path and why (empty path: the input as a whole)."""

    path: str
    reason: str

    def __str__(self) -> str:
        return f"{self.path}: {self.reason}" if self.path else self.reason


class CleaveError(Exception):
    """A call the server refused or could not serve.

    ``code`` is the ``grpc.StatusCode`` (None for errors found on this side,
    such as a job that failed), ``message`` the server's text and ``fields``
    the fields it named.
    """

    def __init__(self, message: str, code: Optional[grpc.StatusCode] = None,
                 fields: tuple[FieldError, ...] = ()):
        super().__init__(message)
        self.message = message
        self.code = code
        self.fields = tuple(fields)

    def __str__(self) -> str:
        name = self.code.name if self.code is not None else ""
        return f"{name}: {self.message}" if name else self.message


class InvalidArgument(CleaveError):
    """``INVALID_ARGUMENT``: a bad request field (``fields`` names it)."""


class InvalidScene(InvalidArgument):
    """``INVALID_ARGUMENT`` for a scene: ``fields`` holds every problem with
    its path into the scene."""

    @classmethod
    def of(cls, fields) -> "InvalidScene":
        """The refusal of a scene with these problems, worded as the server
        words it: ``invalid scene:`` and a line per problem."""
        fields = tuple(fields)
        return cls("invalid scene: " + "\n".join(str(f) for f in fields),
                   grpc.StatusCode.INVALID_ARGUMENT, fields)


class NotFound(CleaveError):
    """``NOT_FOUND``: no such job or snapshot."""


class FailedPrecondition(CleaveError):
    """``FAILED_PRECONDITION``: results the job does not have (yet)."""


class Unauthenticated(CleaveError):
    """``UNAUTHENTICATED``: the server wants its bearer token."""


class ResourceExhausted(CleaveError):
    """``RESOURCE_EXHAUSTED``: over one of the server's limits."""


class Unavailable(CleaveError):
    """``UNAVAILABLE``: the server cannot be reached (a watch retried
    until its ``reconnect_timeout`` before raising this)."""


class JobFailed(CleaveError):
    """A job that ended FAILED or CANCELLED, from :meth:`Job.wait`.
    ``job`` is its final :class:`~cleave_client.JobInfo`."""

    def __init__(self, job):
        state = job.state
        why = job.error or state
        super().__init__(f"job {job.id} {state}: {why}")
        self.job = job


_BY_CODE = {
    grpc.StatusCode.INVALID_ARGUMENT: InvalidArgument,
    grpc.StatusCode.NOT_FOUND: NotFound,
    grpc.StatusCode.FAILED_PRECONDITION: FailedPrecondition,
    grpc.StatusCode.UNAUTHENTICATED: Unauthenticated,
    grpc.StatusCode.RESOURCE_EXHAUSTED: ResourceExhausted,
    grpc.StatusCode.UNAVAILABLE: Unavailable,
}

_DETAILS_KEY = "grpc-status-details-bin"


def _violations(err: grpc.RpcError) -> tuple[FieldError, ...]:
    """The google.rpc.BadRequest field violations in an error's trailers."""
    try:
        trailers = err.trailing_metadata() or ()
    except Exception:  # an error raised before any response has none
        return ()
    raw = next((v for k, v in trailers if k == _DETAILS_KEY), None)
    if raw is None:
        return ()
    from google.rpc import error_details_pb2, status_pb2

    status = status_pb2.Status()
    try:
        status.ParseFromString(raw)
    except Exception:
        return ()
    out = []
    for any_ in status.details:
        if any_.Is(error_details_pb2.BadRequest.DESCRIPTOR):
            bad = error_details_pb2.BadRequest()
            any_.Unpack(bad)
            out.extend(FieldError(v.field, v.description) for v in bad.field_violations)
    return tuple(out)


def from_rpc(err: grpc.RpcError) -> CleaveError:
    """The exception for a failed call."""
    code = err.code() if hasattr(err, "code") else None
    message = (err.details() if hasattr(err, "details") else None) or str(err)
    fields = _violations(err)
    cls = _BY_CODE.get(code, CleaveError)
    if cls is InvalidArgument and message.startswith("invalid scene"):
        cls = InvalidScene
    return cls(message, code, fields)
