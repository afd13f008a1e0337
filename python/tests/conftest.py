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


@pytest.fixture(scope="session")
def kuhn_strip():
    """`kuhn_strip(n)`: a strip of `n` unit cubes along x, Kuhn's six tets a cube along its
    0-7 diagonal, each positively oriented; `(nodes N x 3, tets T x 4)`."""
    import numpy as np

    def make(n):
        nodes = np.array(
            [[x, y, z] for x in range(n + 1) for y in range(2) for z in range(2)], dtype=float
        )
        tets = []
        for x in range(n):
            c = [((x + (k >> 2 & 1)) * 2 + (k >> 1 & 1)) * 2 + (k & 1) for k in range(8)]
            for a, b in [(4, 6), (6, 2), (2, 3), (3, 1), (1, 5), (5, 4)]:
                t = [c[0], c[a], c[b], c[7]]
                p = nodes[t]
                if np.linalg.det((p[1:] - p[0]).T) < 0:
                    t[1], t[2] = t[2], t[1]
                tets.append(t)
        return nodes, np.array(tets)

    return make
