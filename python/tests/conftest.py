"""Shared helpers of the Python tests: the command line built beside the
extension (``$SONARNET_CLI``), the repository (``$SONARNET_ROOT``), and
reading the command line's results exactly."""

import os
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

ROOT = Path(os.environ.get("SONARNET_ROOT", Path(__file__).resolve().parents[2]))
CLI = Path(os.environ.get("SONARNET_CLI", ROOT / "target" / "release" / "sonarnet"))


def scenario(name: str) -> Path:
    """A scenario shipped in ``scenarios/``."""
    return ROOT / "scenarios" / name


def cli(*args: str, expect: int = 0, timeout: float = 600) -> subprocess.CompletedProcess:
    """Run the command line; assert its exit status."""
    p = subprocess.run(
        [str(CLI), *map(str, args)],
        capture_output=True,
        text=True,
        timeout=timeout,
        cwd=ROOT,
    )
    assert p.returncode == expect, f"sonarnet {' '.join(map(str, args))}: exit {p.returncode}\n{p.stderr}"
    return p


def read(path: Path) -> pd.DataFrame:
    """A results CSV, read as the package reads it (exact floats)."""
    from sonarnet import _read_csv

    return _read_csv(path)


def python(code: str, timeout: float = 300, **popen) -> subprocess.Popen:
    """Start ``code`` in a new interpreter with this one's path."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(sys.path)
    return subprocess.Popen(
        [sys.executable, "-c", code],
        env=env,
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        **popen,
    )


@pytest.fixture
def out(tmp_path: Path) -> Path:
    """A results directory for one test."""
    return tmp_path / "out"
