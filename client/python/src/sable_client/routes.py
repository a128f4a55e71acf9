"""The service's REST routes this client calls: one table, so that a test can hold every call
against the server's OpenAPI document (``GET /v1/openapi.json``) and the two cannot drift apart.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Route:
    """One operation of the REST API.

    Attributes:
        method: HTTP method (``GET``, ``POST``).
        path: Path template with ``{name}`` parameters, as in the OpenAPI document.
        query: Names of the query parameters the client may send.
        headers: Names of the request headers the client may send (beyond the standard ones).
    """

    method: str
    path: str
    query: tuple[str, ...] = ()
    headers: tuple[str, ...] = ()


#: Every route the client calls, by the name its code uses.
ROUTES: dict[str, Route] = {
    "submit": Route("POST", "/v1/jobs", headers=("Idempotency-Key",)),
    "list_jobs": Route(
        "GET",
        "/v1/jobs",
        query=("state", "name", "method", "created_after", "created_before", "page_size", "page_token"),
    ),
    "get_job": Route("GET", "/v1/jobs/{id}"),
    "cancel": Route("POST", "/v1/jobs/{id}:cancel"),
    "samples": Route("GET", "/v1/jobs/{id}/samples", query=("from_step", "to_step", "max_points", "format")),
    "events": Route("GET", "/v1/jobs/{id}/events", query=("after_seq",)),
    "snapshots": Route("GET", "/v1/jobs/{id}/snapshots"),
    "snapshot_file": Route("GET", "/v1/jobs/{id}/snapshots/{index}/{part}"),
    "state": Route("GET", "/v1/jobs/{id}/state"),
    "job_chart": Route("GET", "/v1/jobs/{id}/chart.svg", query=("y", "x", "x_unit", "with", "stage")),
    "advice": Route("POST", "/v1/advice"),
    "create_study": Route("POST", "/v1/studies"),
    "list_studies": Route("GET", "/v1/studies"),
    "get_study": Route("GET", "/v1/studies/{id}"),
    "study_chart": Route("GET", "/v1/studies/{id}/chart.svg"),
    "openapi": Route("GET", "/v1/openapi.json"),
    "health": Route("GET", "/healthz"),
}
