"""The client against a real ``sable serve`` (conftest.py): submit, watch, samples, results,
final state, snapshots, cancel, lists, advice, studies, and errors with their field paths."""

from __future__ import annotations

import copy
import time

import httpx
import numpy as np
import pytest

from sable_client import Client, Conflict, Job, JobFailed, NotFound, RejectedScene, Unauthorized, load_scene


def quickstart(**changes: object) -> dict:
    scene = copy.deepcopy(load_scene("quickstart"))
    scene.update(changes)
    return scene


def test_a_job_is_submitted_watched_and_read_back_as_a_dataframe(sable: Client, capsys: pytest.CaptureFixture[str]) -> None:
    job = sable.submit("quickstart", name="py quickstart")
    assert job.name == "py quickstart" and job.state in ("queued", "running")
    live: list[dict] = []
    done = sable.watch(job, on_sample=live.append)
    assert done.state == "succeeded" and done.progress == 1.0
    assert "job" in capsys.readouterr().err  # the tqdm bar went to stderr

    df = sable.samples(job)
    assert len(df) == done.sample_count > 10
    for column in ("step", "time", "phi", "z", "p", "stress.xx", "stress.xy", "walls.y_min.normal_stress", "walls.y_min.force.y"):
        assert column in df.columns, column
    assert df["step"].is_monotonic_increasing and df["step"].iloc[-1] == done.steps
    # Every sample seen live is a stored one, with the same values.
    assert live, "no sample arrived while watching"
    stored = df.set_index("step")
    for s in live:
        assert stored.loc[s["step"], "phi"] == pytest.approx(s["phi"], rel=1e-12)
    # The walls carry the settled pile's weight: 250 glass disks (2500 kg/m³), N per metre.
    # One sample's sum swings by ±5% as the contacts ring; the mean of the last 20 does not.
    # (The floor alone carries 4% less: the side walls hold some by friction, as in a silo.)
    state = sable.state(job)
    weight = 2500.0 * np.pi * np.sum(state.radius**2) * 9.81
    walls = sum(df[f"walls.{w}.force.y"].iloc[-20:].mean() for w in ("x_min", "x_max", "y_min", "y_max"))
    assert -walls == pytest.approx(weight, rel=0.01)

    # The final state: arrays of the right shapes, and the samples' Φ from its radii.
    assert len(state) == 250 and state.position.shape == (250, 2) and state.velocity.shape == (250, 2)
    assert state.angular_velocity.shape == (250, 1) and state.materials == ["glass"]
    assert np.all((state.position >= state.box_min) & (state.position <= state.box_max))
    assert state.packing_fraction() == pytest.approx(df["phi"].iloc[-1], rel=1e-9)

    # The server downsamples on request, keeping the last sample.
    few = sable.samples(job, max_points=5)
    assert len(few) <= 5 and few["step"].iloc[-1] == done.steps
    part = sable.samples(job, from_step=int(df["step"].iloc[10]), to_step=int(df["step"].iloc[20]))
    assert part["step"].tolist() == df["step"].iloc[10:21].tolist()


def test_an_experiment_gives_its_derived_results(sable: Client) -> None:
    scene = load_scene("biaxial_test_2d")
    scene["experiment"]["axial_strain"] = 0.02
    job = sable.wait(sable.submit(scene))
    result = sable.result(job)
    assert result["experiment"] == "biaxial"
    assert result["prepared"]["p"] == pytest.approx(100.0, rel=0.02)  # prepared at 100 Pa
    df = sable.samples(job)
    loading = df[df["stage"] != df["stage"].iloc[0]]
    assert result["peak"]["zeta"] == pytest.approx(loading["zeta"].max(), rel=1e-9)
    assert 0.2 < result["peak"]["zeta"] < 0.6  # μ = 0.5 disks (docs/scene-format.md: 0.41)


def test_snapshots_are_listed_and_read_as_arrays(sable: Client) -> None:
    job = sable.wait(sable.submit(quickstart(snapshots={"every_steps": 20000})))
    snaps = sable.snapshots(job)
    assert [s.step for s in snaps][0] == 0 and snaps[-1].step == job.steps
    assert all(s.parts == ["particles", "contacts", "walls"] for s in snaps)
    particles = sable.snapshot(job)  # the latest
    state = sable.state(job)
    assert particles.points.shape == (250, 3)
    assert np.allclose(particles.point_data["radius"], state.radius, rtol=1e-9)
    assert np.allclose(particles.points[:, :2], state.position, rtol=1e-9, atol=1e-12)
    contacts = sable.snapshot(job, part="contacts")
    n = len(contacts.cells["lines"])
    assert n > 250 and contacts.cell_data["normal_force"].shape == (n,)
    assert sable.snapshot_file(job, 0, "walls").startswith(b"<?xml")


def test_a_rejected_scene_raises_with_every_field_path_and_stores_nothing(sable: Client) -> None:
    before = len(sable.jobs())
    bad = quickstart()
    bad["materials"]["glass"]["friction"] = -0.2
    bad["particles"][0]["count"] = 0
    with pytest.raises(RejectedScene) as caught:
        sable.submit(bad)
    assert {"materials.glass.friction", "particles[0].count"} <= set(caught.value.fields)
    assert caught.value.status == 422 and caught.value.code == "invalid_argument"
    assert len(sable.jobs()) == before
    assert {v.field for v in sable.validate(bad)} == set(caught.value.fields)
    assert sable.validate("quickstart") == []


def test_the_advisor_answers_with_a_method_and_its_reasons(sable: Client) -> None:
    advice = sable.advise(quickstart(method="auto"))
    assert advice["requested"] == "auto" and advice["method"] in ("dem", "cd")
    assert advice["reasons"] and all(isinstance(r, str) for r in advice["reasons"])


def test_a_running_job_is_cancelled(sable: Client) -> None:
    job = sable.submit(quickstart(stop={"time": 1000.0}, name="long"))
    deadline = time.monotonic() + 60
    while sable.job(job).state != "running":
        assert time.monotonic() < deadline, "the job never started"
        time.sleep(0.05)
    sable.cancel(job)
    with pytest.raises(JobFailed) as caught:
        sable.wait(job)
    assert caught.value.job.state == "cancelled"
    assert sable.wait(job, raise_on_failure=False).state == "cancelled"
    with pytest.raises(Conflict):
        sable.cancel(job)
    with pytest.raises(NotFound):
        sable.state(job)  # no final state for a cancelled job


def test_jobs_are_listed_filtered_and_paged(sable: Client) -> None:
    a = sable.wait(sable.submit(quickstart(stop={"time": 0.01}), name="listed"))
    b = sable.wait(sable.submit(quickstart(stop={"time": 0.01}), name="listed"))
    named = sable.jobs(name="listed")
    assert [j.id for j in named] == [b.id, a.id]  # newest first
    everything = [j.id for j in sable.iter_jobs(page_size=1)]
    assert everything == sorted(everything, reverse=True) and {a.id, b.id} <= set(everything)
    assert all(j.state == "succeeded" for j in sable.jobs(state="succeeded"))
    frame = sable.jobs_frame(name="listed")
    assert frame["id"].tolist() == [b.id, a.id] and set(frame["state"]) == {"succeeded"}
    assert sable.jobs(limit=1)[0].id == everything[0]
    with pytest.raises(RejectedScene) as caught:
        sable.jobs(state="sleeping")
    assert caught.value.fields == ["state"]


def test_unknown_jobs_and_failed_jobs_raise(sable: Client) -> None:
    with pytest.raises(NotFound):
        sable.job(10**9)
    assert isinstance(sable.job(sable.jobs(limit=1)[0]), Job)


def test_a_study_runs_and_reports_as_a_dataframe(sable: Client) -> None:
    study = sable.submit_study({
        "name": "py study",
        "scene": quickstart(stop={"time": 0.03}),
        "series": [{"label": "DEM", "sweep": [{"parameter": "method.time_step_fraction", "values": [0.02, 0.05]}]}],
        "measure": {"sample": "z"},
        "reference": {"finest": "DEM"},
    })
    done = sable.wait_study(study, poll=0.2, timeout=120)
    assert done.state == "succeeded" and done.runs == done.runs_done == 2
    runs = sable.study_runs(done)
    assert len(runs) == 2 and set(runs["state"]) == {"succeeded"}
    for _, run in runs.iterrows():  # the measure is each job's last sample
        assert run["measured"] == pytest.approx(sable.samples(int(run["job_id"]))["z"].iloc[-1], rel=1e-12)
    finest = runs.loc[runs["cost.cpu_seconds"].idxmax()]
    assert finest["error"] == 0.0
    assert done.id in [s.id for s in sable.studies()]
    assert sable.study_chart_svg(done).lstrip().startswith("<svg")


def test_a_service_with_tokens_admits_only_users_tokens(token_server: tuple[str, str, str], monkeypatch: pytest.MonkeyPatch) -> None:
    url, user, worker = token_server
    with Client(url, token="") as anonymous:
        assert anonymous.healthy(), "/healthz stays open"
        with pytest.raises(Unauthorized) as e:
            anonymous.jobs()
        assert (e.value.status, e.value.code) == (401, "unauthenticated")
    with Client(url, token="not-a-token-of-this-server") as stranger, pytest.raises(Unauthorized) as e:
        stranger.jobs()
    assert e.value.status == 401
    with Client(url, token=worker) as w, pytest.raises(Unauthorized) as e:
        w.submit(quickstart(stop={"steps": 200}))
    assert (e.value.status, e.value.code) == (403, "permission_denied"), "a worker's token cannot submit"
    # A user's token, given or from SABLE_TOKEN: submit, watch the event stream, read samples.
    monkeypatch.setenv("SABLE_TOKEN", user)
    with Client(url) as c:
        job = c.submit(quickstart(stop={"steps": 200}, sampling={"every_steps": 100}))
        events = [e.kind for e in c.events(job)]
        assert events[-1] == "state" and "sample" in events
        assert len(c.samples(c.wait(job))) == 3


def test_a_service_over_tls_is_reached_with_its_certificate_trusted(tls_server: tuple[str, str], monkeypatch: pytest.MonkeyPatch) -> None:
    url, cert = tls_server
    assert url.startswith("https://")
    with Client(url, ca_cert=cert) as c:
        job = c.submit(quickstart(stop={"steps": 200}, sampling={"every_steps": 100}))
        events = [e.kind for e in c.events(job)]
        assert events[-1] == "state" and "sample" in events
        assert len(c.samples(c.wait(job))) == 3
    # SABLE_CA_CERT does the same for https:// addresses only.
    monkeypatch.setenv("SABLE_CA_CERT", cert)
    with Client(url) as c:
        assert c.healthy()
    with Client(url.replace("https://", "http://")) as plain:
        assert not plain.healthy(), "plain HTTP was answered by the TLS listener"
    monkeypatch.delenv("SABLE_CA_CERT")
    # Without the certificate trusted, the client's own TLS refuses the service.
    with Client(url) as untrusting, pytest.raises(httpx.ConnectError, match="CERTIFICATE_VERIFY_FAILED"):
        untrusting.jobs()
    with pytest.raises(ValueError, match="ca_cert: http://127.0.0.1:1 is not an https:// address"):
        Client("http://127.0.0.1:1", ca_cert=cert)
    with pytest.raises(ValueError, match="ca_cert: cannot use /nonexistent.pem"):
        Client("https://127.0.0.1:1", ca_cert="/nonexistent.pem")
