"""The package's type hints hold: mypy --strict over the installed package."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import sable_client


def test_the_package_is_clean_under_mypy_strict() -> None:
    package = Path(sable_client.__file__).parent
    assert (package / "py.typed").is_file()
    done = subprocess.run([sys.executable, "-m", "mypy", "--strict", "--no-incremental", "-p", "sable_client"], capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr
