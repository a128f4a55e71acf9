"""The client's calls against the service's own OpenAPI document: every route the client uses
exists with its method, every query parameter and header it sends is declared, and the
package's version is the service's."""

from __future__ import annotations

import re
from pathlib import Path

import sable_client
from sable_client import ROUTES, Client

REPO = Path(__file__).resolve().parents[3]


def _declared(operation: dict, where: str) -> set[str]:
    return {p["name"] for p in operation.get("parameters", []) if p.get("in") == where}


def test_every_route_of_the_client_is_in_the_openapi_document(sable: Client) -> None:
    doc = sable.openapi()
    paths = doc["paths"]
    for name, route in ROUTES.items():
        assert route.path in paths, f"{name}: {route.path} is not a path of the service"
        operation = paths[route.path].get(route.method.lower())
        assert operation is not None, f"{name}: {route.method} {route.path} is not an operation of the service"
        assert set(route.query) <= _declared(operation, "query"), f"{name}: query {set(route.query) - _declared(operation, 'query')} undeclared"
        assert set(route.headers) <= _declared(operation, "header"), f"{name}: header {set(route.headers) - _declared(operation, 'header')} undeclared"
        assert set(re.findall(r"\{(\w+)\}", route.path)) == _declared(operation, "path"), f"{name}: path parameters differ"


def test_every_job_operation_of_the_service_is_reachable_from_the_client(sable: Client) -> None:
    """The other way round: the jobs, studies and advice operations all have a client route (the
    PNG charts and the Prometheus text excepted: the SVG chart and the health check stand for them)."""
    doc = sable.openapi()
    used = {(r.method.lower(), r.path) for r in ROUTES.values()}
    left = {(m, p) for p, ops in doc["paths"].items() for m in ops if (m, p) not in used}
    assert left == {("get", "/v1/jobs/{id}/chart.png"), ("get", "/v1/studies/{id}/chart.png"), ("get", "/metrics")}


def test_the_package_version_is_the_service_version(sable: Client) -> None:
    version = sable.openapi()["info"]["version"]
    assert sable_client.__version__ == version
    cargo = (REPO / "Cargo.toml").read_text()
    workspace = re.search(r'\[workspace\.package\][^\[]*?version\s*=\s*"([^"]+)"', cargo)
    assert workspace is not None and workspace.group(1) == version
