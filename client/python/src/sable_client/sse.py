"""Server-Sent Events read from a stream of text lines (the service's ``/v1/jobs/{id}/events``)."""

from __future__ import annotations

import json
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class Event:
    """One event of a job's stream.

    Attributes:
        id: Sequence number (resume after it with ``after_seq``).
        kind: ``state``, ``sample`` or ``heartbeat``.
        data: The event's JSON data (``{}`` for a heartbeat).
    """

    id: int | None
    kind: str
    data: dict[str, Any]


def events(lines: Iterable[str]) -> Iterator[Event]:
    """The events of an SSE stream, given its lines without their line ends (the W3C format:
    ``id:``, ``event:``, ``data:`` fields, an empty line ending each event, ``:`` comments)."""
    ident: int | None = None
    kind = "message"
    data: list[str] = []
    for line in lines:
        if line == "":
            if data or kind != "message":
                text = "\n".join(data)
                try:
                    payload = json.loads(text) if text else {}
                except json.JSONDecodeError:
                    payload = {"text": text}
                yield Event(ident, kind, payload if isinstance(payload, dict) else {"value": payload})
            ident, kind, data = None, "message", []
            continue
        if line.startswith(":"):
            continue
        name, _, value = line.partition(":")
        value = value[1:] if value.startswith(" ") else value
        if name == "id":
            try:
                ident = int(value)
            except ValueError:
                ident = None
        elif name == "event":
            kind = value
        elif name == "data":
            data.append(value)
