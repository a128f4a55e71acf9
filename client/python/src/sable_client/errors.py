"""Exceptions: every error body of the service (``{"code", "message", "details"}``) becomes one
of these, with the field paths of a rejected scene kept in :attr:`SableError.violations`."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class Violation:
    """A rule broken by a field of a scene or request.

    Attributes:
        field: Dotted path of the field (``particles[0].count``), or ``""`` for the whole document.
        rule: The rule, stated so that it says what to change.
    """

    field: str
    rule: str

    def __str__(self) -> str:
        return f"{self.field}: {self.rule}" if self.field else self.rule


class SableError(Exception):
    """An error answer of the service.

    Attributes:
        status: HTTP status.
        code: The service's stable code (``malformed``, ``invalid_argument``, ``too_large``,
            ``resource_exhausted``, ``not_found``, ``conflict``, ``internal``).
        message: The service's one-line message.
        violations: Every broken rule with its field path (empty when the error is not about fields).
    """

    def __init__(self, status: int, code: str, message: str, violations: list[Violation] | None = None) -> None:
        self.status = status
        self.code = code
        self.message = message
        self.violations = list(violations or [])
        lines = [f"{message} (HTTP {status}, {code})"]
        lines += [f"  - {v}" for v in self.violations]
        super().__init__("\n".join(lines))

    @property
    def fields(self) -> list[str]:
        """The field paths of :attr:`violations`, in order."""
        return [v.field for v in self.violations]


class RejectedScene(SableError):
    """The scene or a request field breaks a rule (HTTP 422, with the field paths), the body is
    not JSON or a parameter cannot be read (400), or the body is over the server's limit (413)."""


class NotFound(SableError):
    """No such job, study, snapshot or route (HTTP 404)."""


class Conflict(SableError):
    """The request conflicts with the resource's state (HTTP 409), e.g. cancelling an ended job."""


class Unauthorized(SableError):
    """The service needs a user's token and got none, or one it does not accept (HTTP 401), or
    a worker's token (403). Give ``Client(url, token=...)`` or set ``SABLE_TOKEN``."""


class ServiceBusy(SableError):
    """The service refuses for now; retry later: HTTP 429 (e.g. too many open event streams),
    503 (its database cannot be reached) or 507 (its database's disk is full). Nothing was
    written."""


class JobFailed(Exception):
    """A job that was waited for ended without succeeding.

    Attributes:
        job: The job as the service last showed it (its ``state`` and ``error``).
    """

    def __init__(self, job: Any) -> None:
        self.job = job
        error = getattr(job, "error", None) or {}
        why = f": {error.get('code')}: {error.get('message')}" if error else ""
        super().__init__(f"job {job.id} {job.state}{why}")


def from_response(status: int, body: Any) -> SableError:
    """The exception for an error answer (``body``: its decoded JSON, or its text)."""
    if isinstance(body, dict):
        code = str(body.get("code", "unknown"))
        message = str(body.get("message", ""))
        details = body.get("details") or []
        violations = [Violation(str(d.get("field", "")), str(d.get("rule", ""))) for d in details if isinstance(d, dict)]
    else:
        code, message, violations = "unknown", str(body)[:500], []
    kind: type[SableError] = SableError
    if status in (400, 413, 422):
        kind = RejectedScene
    elif status == 404:
        kind = NotFound
    elif status == 409:
        kind = Conflict
    elif status in (401, 403):
        kind = Unauthorized
    elif status in (429, 503, 507):
        kind = ServiceBusy
    return kind(status, code, message, violations)
