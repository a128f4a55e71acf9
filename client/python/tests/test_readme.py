"""The README's notebook example, run as written against the test service (the biaxial test
at full length, about 7 s), with matplotlib drawing off screen."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


def test_the_readme_example_runs_and_draws_its_figure(server: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), re.S)
    assert blocks, "the README has no python example"
    code = blocks[0].replace("http://127.0.0.1:8080", server)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("SABLE_SCENES", str(README.parents[2] / "scenes"))
    scope: dict[str, object] = {}
    exec(compile(code, str(README), "exec"), scope)
    assert (tmp_path / "biaxial.png").stat().st_size > 10_000
    peak = scope["sable"].result(scope["job"])["peak"]  # type: ignore[attr-defined]
    assert 0.3 < peak["zeta"] < 0.5  # docs/scene-format.md: peak ζ = 0.41 at 0.7%
