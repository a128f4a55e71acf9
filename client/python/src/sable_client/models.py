"""What the service returns, as typed Python objects. Each keeps the JSON it was read from in
``raw``, so that a field added to the service is never out of reach."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

#: The states a job ends in.
TERMINAL_STATES = frozenset({"succeeded", "failed", "cancelled"})


@dataclass
class Job:
    """A simulation job (``JobView`` of the OpenAPI document).

    Attributes:
        id: Job id.
        name: Name.
        state: ``queued``, ``running``, ``succeeded``, ``failed`` or ``cancelled``.
        method: The method that runs it (``dem``, ``cd``, ``mpm``, ``fem``).
        method_reason: Why that method (the advisor's reason when the scene asked for ``auto``).
        progress: Fraction done, 0..1.
        steps: Steps done.
        sample_count: Samples stored.
        wall_seconds: Wall-clock seconds of the run.
        cpu_seconds: CPU seconds of the job's threads.
        error: ``{"code", "message"}`` of a failed job, else ``None``.
        result: The experiment's derived results (docs/scene-format.md §13) of a succeeded job.
        scene: The scene as stored (canonical JSON); empty in lists of jobs (``jobs()``),
            which are summaries: ``job(id)`` has it.
        raw: The whole JSON object.
    """

    id: int
    name: str
    state: str
    method: str
    method_reason: str
    progress: float
    steps: int
    sample_count: int
    wall_seconds: float
    cpu_seconds: float
    error: dict[str, Any] | None
    result: dict[str, Any] | None
    scene: dict[str, Any]
    raw: dict[str, Any] = field(repr=False)

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Job:
        """Reads a ``JobView``."""
        return cls(
            id=int(d["id"]),
            name=str(d["name"]),
            state=str(d["state"]),
            method=str(d["method"]),
            method_reason=str(d.get("method_reason", "")),
            progress=float(d.get("progress", 0.0)),
            steps=int(d.get("steps", 0)),
            sample_count=int(d.get("sample_count", 0)),
            wall_seconds=float(d.get("wall_seconds", 0.0)),
            cpu_seconds=float(d.get("cpu_seconds", 0.0)),
            error=d.get("error"),
            result=d.get("result"),
            scene=d.get("scene") or {},
            raw=d,
        )

    @property
    def done(self) -> bool:
        """Whether the job has ended (succeeded, failed or cancelled)."""
        return self.state in TERMINAL_STATES


@dataclass
class Study:
    """A study: runs of one scene swept over parameters, or a stability search (docs/studies.md).

    Attributes:
        id: Study id.
        name: Name.
        kind: ``sweep`` or ``search``.
        state: ``running``, ``succeeded`` (every run ended; some may have failed, which is data)
            or ``failed``.
        runs_done: Runs ended so far.
        runs: Runs so far.
        error: Why the study failed, else ``None``.
        report: The report: each run's cost and error, the Pareto front; a search's limit.
        raw: The whole JSON object.
    """

    id: int
    name: str
    kind: str
    state: str
    runs_done: int
    runs: int
    error: str | None
    report: dict[str, Any]
    raw: dict[str, Any] = field(repr=False)

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Study:
        """Reads a ``StudyView``."""
        return cls(
            id=int(d["id"]),
            name=str(d["name"]),
            kind=str(d["kind"]),
            state=str(d["state"]),
            runs_done=int(d.get("runs_done", 0)),
            runs=int(d.get("runs", 0)),
            error=d.get("error"),
            report=d.get("report") or {},
            raw=d,
        )

    @property
    def done(self) -> bool:
        """Whether every run has ended (or the study failed)."""
        return self.state != "running"


@dataclass
class Snapshot:
    """One stored snapshot of a job (VTK XML PolyData files).

    Attributes:
        index: Number of the snapshot in the job, from 0.
        step: Step it was taken at.
        time: Simulated time, s.
        parts: The parts it has: ``particles``, ``contacts``, ``walls``.
    """

    index: int
    step: int
    time: float
    parts: list[str]

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Snapshot:
        """Reads a ``SnapshotView`` (its file URLs end in ``/<part>``)."""
        parts = [str(f).rstrip("/").rsplit("/", 1)[-1].removesuffix(".vtp") for f in d.get("files", [])]
        return cls(index=int(d["index"]), step=int(d["step"]), time=float(d["time"]), parts=parts)


@dataclass
class State:
    """The final state of a succeeded job (``GET /v1/jobs/{id}/state``, format ``sable-state``),
    with the particles' fields as numpy arrays. SI units.

    Attributes:
        dimension: 2 or 3.
        time: Simulated time, s.
        steps: Steps done.
        box_min: Lower corner of the container, m, shape ``(dimension,)``.
        box_max: Upper corner, m.
        position: Centres, m, shape ``(n, dimension)``.
        radius: Radii, m, shape ``(n,)``.
        velocity: Velocities, m/s, shape ``(n, dimension)``.
        angular_velocity: Angular velocities, rad/s, shape ``(n, 1)`` in 2D, ``(n, 3)`` in 3D.
        material: Index of each particle's material in :attr:`materials`, shape ``(n,)``.
        materials: Material names.
        raw: The whole JSON object (a scene's ``start_from.state``).
    """

    dimension: int
    time: float
    steps: int
    box_min: np.ndarray
    box_max: np.ndarray
    position: np.ndarray
    radius: np.ndarray
    velocity: np.ndarray
    angular_velocity: np.ndarray
    material: np.ndarray
    materials: list[str]
    raw: dict[str, Any] = field(repr=False)

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> State:
        """Reads a ``sable-state`` document."""
        dim = int(d["dimension"])
        p = d.get("particles") or {}
        n = len(p.get("radius", []))
        rot = 1 if dim == 2 else 3

        def matrix(name: str, width: int) -> np.ndarray:
            return np.asarray(p.get(name) or np.zeros((n, width)), dtype=float).reshape(n, width)

        return cls(
            dimension=dim,
            time=float(d.get("time", 0.0)),
            steps=int(d.get("steps", 0)),
            box_min=np.asarray(d.get("min", [0.0] * dim), dtype=float),
            box_max=np.asarray(d.get("max", [0.0] * dim), dtype=float),
            position=matrix("position", dim),
            radius=np.asarray(p.get("radius", []), dtype=float),
            velocity=matrix("velocity", dim),
            angular_velocity=matrix("angular_velocity", rot),
            material=np.asarray(p.get("material", []), dtype=int),
            materials=[str(m) for m in d.get("materials", [])],
            raw=d,
        )

    def __len__(self) -> int:
        return int(self.radius.shape[0])

    def packing_fraction(self) -> float:
        """The particles' area (2D) or volume (3D) over the box's, ignoring overlaps."""
        extent = np.prod(self.box_max - self.box_min)
        if self.dimension == 2:
            solid = np.pi * np.sum(self.radius**2)
        else:
            solid = 4.0 / 3.0 * np.pi * np.sum(self.radius**3)
        return float(solid / extent) if extent > 0 else float("nan")
