"""The client of Sable's REST API (``sable serve``; the routes are in :mod:`.routes`)."""

from __future__ import annotations

import os
import ssl
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, Union

import httpx
import pandas as pd

from . import errors, frames, sse, vtk
from .models import TERMINAL_STATES, Job, Snapshot, State, Study
from .routes import ROUTES
from .scenes import SceneLike, load_scene

#: A job given by its id or as returned by the client.
JobRef = Union[int, Job]
#: A study given by its id or as returned by the client.
StudyRef = Union[int, Study]

#: The sample fields shown beside the progress bar while a job runs.
LIVE_FIELDS = ("phi", "z", "p", "zeta", "mu")


@contextmanager
def _scene_paths() -> Iterator[None]:
    """Field paths of a rejected scene made relative to the scene the user gave: the client
    wraps it as ``{"scene": ...}``, so the service names its fields ``scene.materials...``."""
    try:
        yield
    except errors.RejectedScene as e:
        e.violations = [errors.Violation(v.field.removeprefix("scene."), v.rule) if v.field != "scene" else errors.Violation("", v.rule) for v in e.violations]
        e.args = (str(e).replace("  - scene.", "  - "),)
        raise


def _raise_for(response: httpx.Response) -> None:
    """Raises the exception for an error answer (its body read as JSON, else as text)."""
    if response.status_code < 400:
        return
    response.read()
    try:
        detail = response.json()
    except ValueError:
        detail = response.text
    raise errors.from_response(response.status_code, detail)


def _id(ref: JobRef | StudyRef) -> int:
    return ref.id if isinstance(ref, (Job, Study)) else int(ref)


class Client:
    """A connection to one Sable service.

    Args:
        url: The service's REST address (``sable serve --http``).
        timeout: Seconds to wait for an answer (event streams wait longer: see :meth:`events`).
        transport: An httpx transport (tests).
        token: A user's bearer token, for a service started with ``--user-tokens``; by default
            the ``SABLE_TOKEN`` environment variable, if set.
        ca_cert: A CA certificate file (PEM) to trust besides the system's, for an ``https://``
            service whose certificate is a lab's own or self-signed (``sable serve
            --tls-cert``); by default the ``SABLE_CA_CERT`` environment variable, for
            ``https://`` addresses only.

    Every method raises :class:`~sable_client.errors.SableError` (or a subclass) when the
    service answers with an error: :class:`~sable_client.errors.RejectedScene` carries the field
    path of every rule a scene breaks.

    Use as a context manager, or call :meth:`close`::

        with Client("http://127.0.0.1:8080") as sable:
            job = sable.submit("quickstart")
            sable.watch(job)
            df = sable.samples(job)
    """

    def __init__(
        self,
        url: str = "http://127.0.0.1:8080",
        timeout: float = 30.0,
        transport: httpx.BaseTransport | None = None,
        token: str | None = None,
        ca_cert: str | os.PathLike[str] | None = None,
    ) -> None:
        self.url = url.rstrip("/")
        token = token if token is not None else os.environ.get("SABLE_TOKEN")
        headers = {"Authorization": f"Bearer {token.strip()}"} if token and token.strip() else {}
        https = self.url.startswith("https://")
        if ca_cert is not None and not https:
            raise ValueError(f"ca_cert: {self.url} is not an https:// address; a CA certificate is for https only")
        ca = ca_cert if ca_cert is not None else (os.environ.get("SABLE_CA_CERT") if https else None)
        verify: ssl.SSLContext | bool = True
        if ca:
            try:
                verify = ssl.create_default_context(cafile=os.fspath(ca))
            except (OSError, ssl.SSLError) as e:
                raise ValueError(f"ca_cert: cannot use {os.fspath(ca)} as a CA certificate: {e}") from e
        self._http = httpx.Client(base_url=self.url, timeout=timeout, transport=transport, headers=headers, verify=verify)

    def close(self) -> None:
        """Closes the connections."""
        self._http.close()

    def __enter__(self) -> Client:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- plumbing ---------------------------------------------------------------------------

    def _request(
        self,
        route: str,
        path: dict[str, Any] | None = None,
        query: dict[str, Any] | None = None,
        body: Any = None,
        headers: dict[str, str] | None = None,
    ) -> httpx.Response:
        r = ROUTES[route]
        params = {k: v for k, v in (query or {}).items() if v is not None}
        unknown = set(params) - set(r.query)
        if unknown:  # a programming error of this package, caught by its tests
            raise ValueError(f"{route}: query parameters {sorted(unknown)} are not in the route table")
        url = r.path.format(**(path or {}))
        response = self._http.request(r.method, url, params=params, json=body, headers=headers)
        _raise_for(response)
        return response

    def _json(self, route: str, **kw: Any) -> Any:
        return self._request(route, **kw).json()

    # -- jobs -------------------------------------------------------------------------------

    def submit(
        self,
        scene: SceneLike,
        *,
        name: str | None = None,
        priority: int | None = None,
        max_attempts: int | None = None,
        idempotency_key: str | None = None,
    ) -> Job:
        """Validates and queues a scene.

        Args:
            scene: The scene: a dict, a JSON file, or the name of a file in ``scenes/``
                (:func:`~sable_client.scenes.load_scene`).
            name: Job name (default: the scene's).
            priority: Higher runs first (−1000..1000); FIFO within a priority.
            max_attempts: Leases allowed before the job fails (1..20, default 3).
            idempotency_key: The same key returns the first job instead of queueing another.

        Raises:
            RejectedScene: The scene breaks rules; ``.violations`` lists each with its field path.
        """
        body: dict[str, Any] = {"scene": load_scene(scene)}
        for key, value in (("name", name), ("priority", priority), ("max_attempts", max_attempts)):
            if value is not None:
                body[key] = value
        headers = {"Idempotency-Key": idempotency_key} if idempotency_key else None
        with _scene_paths():
            return Job.from_json(self._json("submit", body=body, headers=headers))

    def job(self, job: JobRef) -> Job:
        """The job as it is now."""
        return Job.from_json(self._json("get_job", path={"id": _id(job)}))

    def iter_jobs(
        self,
        *,
        state: str | None = None,
        name: str | None = None,
        method: str | None = None,
        created_after: str | None = None,
        created_before: str | None = None,
        page_size: int = 100,
    ) -> Iterator[Job]:
        """Every job that matches the filters, newest first, page by page.

        Args:
            state: ``queued``, ``running``, ``succeeded``, ``failed`` or ``cancelled``.
            name: Jobs of exactly this name.
            method: ``dem``, ``cd``, ``mpm``, ``fem``.
            created_after: RFC 3339 time.
            created_before: RFC 3339 time.
            page_size: Jobs fetched per request (1..500).
        """
        token: str | None = None
        while True:
            query = {
                "state": state,
                "name": name,
                "method": method,
                "created_after": created_after,
                "created_before": created_before,
                "page_size": page_size,
                "page_token": token,
            }
            page = self._json("list_jobs", query=query)
            for j in page.get("jobs", []):
                yield Job.from_json(j)
            token = page.get("next_page_token") or None
            if not token:
                return

    def jobs(self, *, limit: int | None = None, **filters: Any) -> list[Job]:
        """Jobs that match the filters of :meth:`iter_jobs`, newest first, at most ``limit``."""
        out: list[Job] = []
        if limit is not None:
            if limit <= 0:
                return out
            filters["page_size"] = min(int(filters.get("page_size", 100)), limit)
        for j in self.iter_jobs(**filters):
            out.append(j)
            if limit is not None and len(out) >= limit:
                break  # before the generator asks for another page
        return out

    def jobs_frame(self, *, limit: int | None = None, **filters: Any) -> pd.DataFrame:
        """:meth:`jobs` as a DataFrame (id, name, state, method, progress, steps, samples,
        CPU and wall seconds, created and finished times, error code)."""
        rows = [
            {
                "id": j.id,
                "name": j.name,
                "state": j.state,
                "method": j.method,
                "progress": j.progress,
                "steps": j.steps,
                "sample_count": j.sample_count,
                "cpu_seconds": j.cpu_seconds,
                "wall_seconds": j.wall_seconds,
                "created_at": j.raw.get("created_at"),
                "finished_at": j.raw.get("finished_at"),
                "error": (j.error or {}).get("code"),
            }
            for j in self.jobs(limit=limit, **filters)
        ]
        return pd.DataFrame.from_records(rows, columns=None if rows else ["id", "name", "state", "method"])

    def cancel(self, job: JobRef) -> Job:
        """Cancels a queued or running job (a running one stops within a second).

        Raises:
            Conflict: The job has already ended.
        """
        return Job.from_json(self._json("cancel", path={"id": _id(job)}))

    def events(
        self,
        job: JobRef,
        *,
        after: int | None = None,
        read_timeout: float = 120.0,
        reconnect_for: float = 120.0,
    ) -> Iterator[sse.Event]:
        """The job's events as they come (``state``, ``sample`` and ``heartbeat``), from the
        first (or after sequence number ``after``) until the job ends.

        A stream that drops, or that the service ends without the job's final state (a server
        stopping), is resumed after the last event seen, for as long as ``reconnect_for``
        seconds pass without a connection; so is one the service refuses for now
        (:class:`~sable_client.errors.ServiceBusy`: its database unreachable, its disk full).

        Raises:
            SableError: The service reports an error in the stream, or an error answer.
            ServiceBusy: Still refused after ``reconnect_for`` seconds.
            httpx.TransportError: No connection for ``reconnect_for`` seconds.
        """
        jid = _id(job)
        last = after
        r = ROUTES["events"]
        timeout = httpx.Timeout(self._http.timeout.connect or 30.0, read=read_timeout)
        down_since: float | None = None
        while True:
            params = {"after_seq": last} if last is not None else {}
            try:
                with self._http.stream(r.method, r.path.format(id=jid), params=params, timeout=timeout) as response:
                    _raise_for(response)
                    down_since = None
                    for event in sse.events(response.iter_lines()):
                        if event.kind == "error":
                            raise errors.from_response(500, event.data)
                        if event.id is not None:
                            last = event.id
                        yield event
                        if event.kind == "state" and event.data.get("state") in TERMINAL_STATES:
                            return
            except (httpx.TransportError, errors.ServiceBusy):
                now = time.monotonic()
                down_since = now if down_since is None else down_since
                if now - down_since > reconnect_for:
                    raise
            time.sleep(0.5)  # then resume after `last`

    def watch(
        self,
        job: JobRef,
        *,
        progress: bool = True,
        live: tuple[str, ...] = LIVE_FIELDS,
        on_sample: Callable[[dict[str, Any]], None] | None = None,
        raise_on_failure: bool = True,
    ) -> Job:
        """Follows a job until it ends, with a progress bar (tqdm) showing the latest values of
        ``live`` fields, and returns it as it ended.

        Args:
            job: The job.
            progress: Show the bar.
            live: Sample fields shown beside the bar (dotted paths, as in :mod:`.frames`).
            on_sample: Called with each new sample (its nested dict) as it arrives.
            raise_on_failure: Raise :class:`~sable_client.errors.JobFailed` if the job fails
                or is cancelled.
        """
        bar = None
        if progress:
            from tqdm.auto import tqdm  # type: ignore[import-untyped]

            bar = tqdm(total=1.0, desc=f"job {_id(job)}", bar_format="{l_bar}{bar}| {n:.0%} [{elapsed}<{remaining}{postfix}]")
        try:
            for event in self.events(job):
                if event.kind == "sample":
                    sample = event.data.get("sample") or {}
                    if on_sample is not None:
                        on_sample(sample)
                    if bar is not None:
                        flat = frames.flatten(sample)
                        bar.n = min(max(float(event.data.get("fraction", bar.n)), 0.0), 1.0)
                        bar.set_postfix({k: f"{flat[k]:.4g}" for k in live if isinstance(flat.get(k), (int, float))}, refresh=False)
                        bar.refresh()
                elif event.kind == "state" and bar is not None:
                    bar.set_description(f"job {_id(job)} {event.data.get('state')}")
            done = self._through_outage(lambda: self.job(job))
            if bar is not None and done.state == "succeeded":
                bar.n = 1.0
                bar.refresh()
        finally:
            if bar is not None:
                bar.close()
        if raise_on_failure and done.state != "succeeded":
            raise errors.JobFailed(done)
        return done

    @staticmethod
    def _through_outage(call: Callable[[], Job], *, retry_for: float = 120.0) -> Job:
        """``call()``, tried again every half second while the service is busy or unreachable,
        for at most ``retry_for`` seconds."""
        since = time.monotonic()
        while True:
            try:
                return call()
            except (httpx.TransportError, errors.ServiceBusy):
                if time.monotonic() - since > retry_for:
                    raise
            time.sleep(0.5)

    def wait(self, job: JobRef, *, raise_on_failure: bool = True) -> Job:
        """:meth:`watch` without the progress bar."""
        return self.watch(job, progress=False, raise_on_failure=raise_on_failure)

    def samples(
        self,
        job: JobRef,
        *,
        from_step: int | None = None,
        to_step: int | None = None,
        max_points: int | None = None,
    ) -> pd.DataFrame:
        """The job's samples so far as a DataFrame, one row per sample in step order (columns
        and units: :mod:`sable_client.frames`).

        Args:
            from_step: First step (inclusive).
            to_step: Last step (inclusive).
            max_points: At most this many rows (up to 10,000), evenly spread, the last sample
                kept (the server downsamples). Without it every sample in the range is read,
                page by page.
        """
        rows: list[dict[str, Any]] = []
        start = from_step
        while True:
            query = {"from_step": start, "to_step": to_step, "max_points": max_points, "format": "json"}
            page = self._json("samples", path={"id": _id(job)}, query=query)
            rows.extend(page.get("samples", []))
            # The service reads at most 10,000 samples a call; a page ends where the next starts.
            after = page.get("next_from_step")
            if after is None or (start is not None and after <= start):
                return frames.samples_frame(rows)
            start = after

    def result(self, job: JobRef) -> dict[str, Any]:
        """The derived results of a succeeded job's experiment (docs/scene-format.md §13:
        peak and steady stress ratio, dilatancy, prepared state, ...).

        Raises:
            JobFailed: The job failed or was cancelled.
            ValueError: The job has not ended, or its scene has no experiment.
        """
        j = self.job(job)
        if j.state in ("failed", "cancelled"):
            raise errors.JobFailed(j)
        if j.state != "succeeded":
            raise ValueError(f"job {j.id} is {j.state}: its results come when it has succeeded")
        if j.result is None:
            raise ValueError(f"job {j.id}'s scene has no experiment, so it has no derived results")
        return j.result

    def state(self, job: JobRef) -> State:
        """The final state of a succeeded job: positions, radii, velocities as numpy arrays.

        Raises:
            NotFound: No such job, or it has not succeeded.
        """
        return State.from_json(self._json("state", path={"id": _id(job)}))

    def snapshots(self, job: JobRef) -> list[Snapshot]:
        """The job's stored snapshots (a scene's ``snapshots`` section), in the order taken."""
        return [Snapshot.from_json(s) for s in self._json("snapshots", path={"id": _id(job)}).get("snapshots", [])]

    def snapshot_file(self, job: JobRef, index: int, part: str = "particles") -> bytes:
        """One snapshot file as stored (VTK XML PolyData, for ParaView).

        Args:
            part: ``particles``, ``contacts`` or ``walls``.
        """
        return self._request("snapshot_file", path={"id": _id(job), "index": index, "part": part}).content

    def snapshot(self, job: JobRef, index: int = -1, part: str = "particles") -> vtk.PolyData:
        """One snapshot part read into numpy arrays; ``index`` −1 is the latest."""
        if index < 0:
            taken = self.snapshots(job)
            if not taken:
                raise errors.NotFound(404, "not_found", f"job {_id(job)} has no snapshots")
            index = taken[index].index
        return vtk.read_polydata(self.snapshot_file(job, index, part))

    def chart_svg(
        self,
        job: JobRef,
        y: str = "phi",
        x: str = "time",
        *,
        x_unit: str | None = None,
        with_: str | None = None,
        stage: str | None = None,
    ) -> str:
        """The service's SVG chart of a job's samples: ``y`` against ``x`` (sample paths, or
        ``time``, ``step``, ``strain``), ``with_`` other jobs drawn alongside (the API's
        ``with``: comma-separated ids), ``x_unit`` one divisor of x per job (comma-separated),
        ``stage`` one stage of an experiment."""
        query = {"y": y, "x": x, "x_unit": x_unit, "with": with_, "stage": stage}
        return self._request("job_chart", path={"id": _id(job)}, query=query).text

    # -- the advisor --------------------------------------------------------------------------

    def advise(self, scene: SceneLike) -> dict[str, Any]:
        """The method advisor's answer for a scene (``method``, ``reasons``, ``numbers``,
        ``regime``, ``suggestions``, ``dropped``, ``expected_cost``). The scene is validated
        first.

        Raises:
            RejectedScene: The scene breaks rules (every one, with its field path).
        """
        with _scene_paths():
            return dict(self._json("advice", body={"scene": load_scene(scene)}))

    def validate(self, scene: SceneLike) -> list[errors.Violation]:
        """Every rule the scene breaks, with its field path; an empty list for a valid scene.
        Nothing is stored."""
        try:
            self.advise(scene)
        except errors.RejectedScene as e:
            return e.violations or [errors.Violation("", e.message)]
        return []

    # -- studies ------------------------------------------------------------------------------

    def submit_study(self, study: SceneLike) -> Study:
        """Queues a study (docs/studies.md): a dict, a JSON file or a name under ``scenes/``
        (``"studies/restitution_dem"``)."""
        return Study.from_json(self._json("create_study", body=load_scene(study)))

    def study(self, study: StudyRef) -> Study:
        """The study as it is now, with its report."""
        return Study.from_json(self._json("get_study", path={"id": _id(study)}))

    def studies(self) -> list[Study]:
        """Every study, newest first."""
        answer = self._json("list_studies")
        items = answer.get("studies", []) if isinstance(answer, dict) else answer
        return [Study.from_json(s) for s in items]

    def study_runs(self, study: StudyRef) -> pd.DataFrame:
        """The study's runs as a DataFrame (:func:`sable_client.frames.study_frame`)."""
        return frames.study_frame(self.study(study).report)

    def wait_study(self, study: StudyRef, *, poll: float = 1.0, timeout: float | None = None) -> Study:
        """Polls the study until every run has ended; returns it with its final report.

        Raises:
            TimeoutError: ``timeout`` seconds passed first.
        """
        start = time.monotonic()
        while True:
            s = self.study(study)
            if s.done:
                return s
            if timeout is not None and time.monotonic() - start > timeout:
                raise TimeoutError(f"study {s.id}: {s.runs_done} of {s.runs} runs ended after {timeout} s")
            time.sleep(poll)

    def study_chart_svg(self, study: StudyRef) -> str:
        """The study's speed-against-accuracy chart (SVG)."""
        return self._request("study_chart", path={"id": _id(study)}).text

    # -- the service --------------------------------------------------------------------------

    def openapi(self) -> dict[str, Any]:
        """The service's OpenAPI document."""
        return dict(self._json("openapi"))

    def healthy(self) -> bool:
        """Whether the service answers its health check."""
        try:
            self._request("health")
        except (errors.SableError, httpx.HTTPError):
            return False
        return True
