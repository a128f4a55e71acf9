"""Scenes given as a dict, a JSON file, or the name of a scene shipped in the repository's
``scenes/`` folder."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any, Union

#: What the client accepts as a scene: a dict (the scene itself), a path to a JSON file, or the
#: name of a file in ``scenes/`` (``"quickstart"``, ``"studies/restitution_dem"``).
SceneLike = Union[dict[str, Any], str, "os.PathLike[str]"]


def scene_dirs() -> list[Path]:
    """Where named scenes are looked for, in order: ``$SABLE_SCENES``, then a ``scenes`` folder
    in the working directory or any of its parents (a checkout of the repository)."""
    dirs = []
    if os.environ.get("SABLE_SCENES"):
        dirs.append(Path(os.environ["SABLE_SCENES"]))
    here = Path.cwd().resolve()
    for d in (here, *here.parents):
        if (d / "scenes").is_dir():
            dirs.append(d / "scenes")
    return dirs


def load_scene(scene: SceneLike) -> dict[str, Any]:
    """The scene as a dict.

    Raises:
        FileNotFoundError: A path or name that matches no file (the message lists where it looked).
        ValueError: A file that is not a JSON object.
    """
    if isinstance(scene, dict):
        return scene
    path = Path(scene)
    candidates = [path]
    if not path.suffix and not path.is_absolute():
        candidates += [d / f"{path}.json" for d in scene_dirs()]
    for c in candidates:
        if c.is_file():
            try:
                value = json.loads(c.read_text(encoding="utf-8"))
            except json.JSONDecodeError as e:
                raise ValueError(f"{c}: not JSON: {e}") from e
            if not isinstance(value, dict):
                raise ValueError(f"{c}: a scene must be a JSON object")
            return value
    looked = ", ".join(str(c) for c in candidates)
    raise FileNotFoundError(f"no scene {str(scene)!r}: looked at {looked} (set SABLE_SCENES to a scenes folder)")
