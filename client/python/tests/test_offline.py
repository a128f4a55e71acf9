"""The pieces that need no service: sample flattening, the event-stream parser, scene loading,
error mapping and the VTK reader."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from sable_client import RejectedScene, flatten, load_scene, read_polydata, samples_frame
from sable_client.errors import Conflict, NotFound, ServiceBusy, from_response
from sable_client.sse import events


def test_a_sample_flattens_to_dotted_columns() -> None:
    sample = {
        "step": 3,
        "stress": {"xx": 1.0, "yy": 2.0, "xy": 0.5},
        "walls": [{"name": "y_max", "position": 0.03, "force": [0.1, -2.0], "normal_stress": 66.0}],
        "strain": {"axes": [0.01, -0.02], "volumetric": -0.01},
        "drum": {"profile": [{"depth": 0.0, "velocity": 1.0}]},
        "inertial_number": None,
    }
    flat = flatten(sample)
    assert flat == {
        "step": 3,
        "stress.xx": 1.0,
        "stress.yy": 2.0,
        "stress.xy": 0.5,
        "walls.y_max.position": 0.03,
        "walls.y_max.force.x": 0.1,
        "walls.y_max.force.y": -2.0,
        "walls.y_max.normal_stress": 66.0,
        "strain.axes.x": 0.01,
        "strain.axes.y": -0.02,
        "strain.volumetric": -0.01,
        "drum.profile": [{"depth": 0.0, "velocity": 1.0}],
        "inertial_number": None,
    }
    frame = samples_frame([sample, {**sample, "step": 4}])
    assert list(frame["step"]) == [3, 4]
    assert samples_frame([]).columns.tolist() == ["step", "time"]


def test_the_event_stream_parser_reads_ids_kinds_and_json() -> None:
    lines = [
        ": a comment",
        "id: 7",
        "event: sample",
        'data: {"fraction": 0.5,',
        'data:  "sample": {"step": 10}}',
        "",
        "event: heartbeat",
        "data: {}",
        "",
        "id: 8",
        "event: state",
        'data: {"state":"succeeded"}',
        "",
    ]
    got = list(events(lines))
    assert [(e.id, e.kind) for e in got] == [(7, "sample"), (None, "heartbeat"), (8, "state")]
    assert got[0].data == {"fraction": 0.5, "sample": {"step": 10}}
    assert got[2].data["state"] == "succeeded"


def test_scenes_load_from_a_dict_a_file_or_a_name(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "a.json").write_text(json.dumps({"name": "a"}))
    monkeypatch.setenv("SABLE_SCENES", str(tmp_path))
    assert load_scene({"name": "x"}) == {"name": "x"}
    assert load_scene(tmp_path / "a.json") == {"name": "a"}
    assert load_scene("a") == {"name": "a"}
    with pytest.raises(FileNotFoundError, match="no scene 'nothing'"):
        load_scene("nothing")
    (tmp_path / "list.json").write_text("[1]")
    with pytest.raises(ValueError, match="JSON object"):
        load_scene(tmp_path / "list.json")


def test_error_bodies_become_typed_exceptions_with_field_paths() -> None:
    body = {"code": "invalid_argument", "message": "the scene breaks 2 rules", "details": [
        {"field": "particles[0].count", "rule": "must be at least 1, got 0"},
        {"field": "materials.glass.friction", "rule": "must be >= 0, got -0.2"},
    ]}
    e = from_response(422, body)
    assert isinstance(e, RejectedScene)
    assert e.fields == ["particles[0].count", "materials.glass.friction"]
    assert "materials.glass.friction: must be >= 0, got -0.2" in str(e)
    assert isinstance(from_response(404, {"code": "not_found", "message": "no job 9", "details": []}), NotFound)
    assert isinstance(from_response(409, "plain text"), Conflict)
    full = {"code": "insufficient_storage", "message": "the job store's disk is full", "details": []}
    assert isinstance(from_response(507, full), ServiceBusy)
    assert isinstance(from_response(503, {"code": "unavailable", "message": "x", "details": []}), ServiceBusy)


def test_the_vtk_reader_reads_points_arrays_and_cells() -> None:
    text = """<?xml version="1.0"?>
<VTKFile type="PolyData" version="1.0"><PolyData>
<Piece NumberOfPoints="2" NumberOfVerts="0" NumberOfLines="1">
<Points><DataArray type="Float64" Name="points" NumberOfComponents="3" format="ascii">0 0 0 1 2 0</DataArray></Points>
<PointData><DataArray type="Float64" Name="radius" format="ascii">0.5 0.25</DataArray></PointData>
<CellData><DataArray type="Float64" Name="normal_force" format="ascii">3.5</DataArray></CellData>
<Lines><DataArray type="Int64" Name="connectivity" format="ascii">0 1</DataArray>
<DataArray type="Int64" Name="offsets" format="ascii">2</DataArray></Lines>
</Piece></PolyData></VTKFile>"""
    d = read_polydata(text)
    assert d.points.shape == (2, 3) and d.points[1, 1] == 2.0
    assert np.allclose(d.point_data["radius"], [0.5, 0.25])
    assert d.cell_data["normal_force"].tolist() == [3.5]
    assert [c.tolist() for c in d.cells["lines"]] == [[0, 1]]
    with pytest.raises(ValueError, match="not a VTK"):
        read_polydata("<html/>")


def test_a_stream_ended_without_the_final_state_is_resumed_after_the_last_event() -> None:
    """A server stopping ends the stream early; the client resumes after the last id it saw,
    and an `error` event becomes an exception."""
    import httpx

    from sable_client import Client, SableError

    asked: list[str | None] = []

    def answer(request: httpx.Request) -> httpx.Response:
        after = request.url.params.get("after_seq")
        asked.append(after)
        if after is None:  # the first stream: two events, then the server goes away
            body = 'id: 1\nevent: state\ndata: {"state":"running"}\n\nid: 2\nevent: sample\ndata: {"fraction":0.5,"sample":{"step":5}}\n\n'
        else:
            body = 'id: 3\nevent: state\ndata: {"state":"succeeded"}\n\nid: 4\nevent: sample\ndata: {}\n\n'
        return httpx.Response(200, text=body, headers={"content-type": "text/event-stream"})

    with Client("http://sable.test", transport=httpx.MockTransport(answer)) as c:
        got = [(e.id, e.kind) for e in c.events(7)]
    assert got == [(1, "state"), (2, "sample"), (3, "state")]  # nothing after the final state
    assert asked == [None, "2"]

    def failing(request: httpx.Request) -> httpx.Response:
        body = 'id: 1\nevent: error\ndata: {"code":"internal","message":"the store is closing"}\n\n'
        return httpx.Response(200, text=body, headers={"content-type": "text/event-stream"})

    with Client("http://sable.test", transport=httpx.MockTransport(failing)) as c:
        with pytest.raises(SableError, match="the store is closing"):
            list(c.events(7))


def test_waiting_goes_on_through_an_outage(monkeypatch: pytest.MonkeyPatch) -> None:
    """Issue 71, finding 6: while the service's database is away it answers 503; ``wait()``
    keeps waiting (the job goes on) instead of raising, and returns the job as it ended."""
    import httpx

    from sable_client import Client, client as client_module

    monkeypatch.setattr(client_module.time, "sleep", lambda _s: None)
    calls = {"events": 0, "job": 0}
    busy = {"code": "unavailable", "message": "the job store cannot be reached"}

    def answer(request: httpx.Request) -> httpx.Response:
        if request.url.path.endswith("/events"):
            calls["events"] += 1
            if calls["events"] <= 2:
                return httpx.Response(503, json=busy)
            body = 'id: 5\nevent: state\ndata: {"state":"succeeded"}\n\n'
            return httpx.Response(200, text=body, headers={"content-type": "text/event-stream"})
        calls["job"] += 1
        if calls["job"] == 1:
            return httpx.Response(503, json=busy)
        return httpx.Response(200, json={"id": 7, "name": "settle", "state": "succeeded", "method": "dem"})

    with Client("http://sable.test", transport=httpx.MockTransport(answer)) as c:
        done = c.wait(7)
    assert done.state == "succeeded"
    assert calls == {"events": 3, "job": 2}
