"""Shared helpers for the tetradrill Python tests: the repository's folders, and the
`tetradrill` command line (the oracle for replays), found through TETRADRILL_BIN or the
repository's build folder."""

import json
import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
MESHES = ROOT / "tests" / "data" / "meshes"


def _find_bin():
    env = os.environ.get("TETRADRILL_BIN")
    if env:
        return Path(env)
    for profile in ("release", "debug"):
        p = ROOT / "target" / profile / "tetradrill"
        if p.is_file():
            return p
    return None


@pytest.fixture(scope="session")
def cli():
    """Runs `tetradrill replay ARGS --json OUT --quiet` and gives the JSON as a dict.

    TETRADRILL_BIN names the binary (a test fails when it names none); otherwise the
    repository's target/release or target/debug build is used, and the tests that need it
    are skipped when there is none."""
    exe = _find_bin()
    if exe is None:
        pytest.skip("no tetradrill binary (set TETRADRILL_BIN or build it with cargo)")
    if not exe.is_file():
        pytest.fail(f"TETRADRILL_BIN={exe} is not a file")

    def replay(args, tmp_path):
        out = tmp_path / f"replay-{len(list(tmp_path.iterdir()))}.json"
        r = subprocess.run(
            [str(exe), "replay", *args, "--json", str(out), "--quiet"],
            capture_output=True,
            text=True,
        )
        assert r.returncode == 0, f"tetradrill replay {args}: {r.stderr}"
        return json.loads(out.read_text())

    return replay
