"""What the Python module's tests share: the packmesh command the module was built with, run
the way a user runs it, to check the module against it."""
import re
import subprocess

import pytest

import packmesh


def run_cli(*args, check=True):
    """Run the packmesh command; its CompletedProcess (text)."""
    proc = subprocess.run([packmesh.cli_path(), *map(str, args)], stdout=subprocess.PIPE,
                          stderr=subprocess.PIPE, text=True)
    if check and proc.returncode != 0:
        raise AssertionError(f"packmesh {' '.join(map(str, args))} exited {proc.returncode}: "
                             f"{proc.stderr}")
    return proc


def cli_counts(line):
    """(nodes, segments, triangles, tets) from the summary line of `packmesh mesh`:
    'bubble case:qi3: 651 nodes, 56 segments, 1244 triangles, 0 tets in ...'."""
    m = re.search(r": (\d+) nodes, (\d+) segments, (\d+) triangles, (\d+) tets", line)
    assert m, f"no counts in the command's line: {line!r}"
    return tuple(int(g) for g in m.groups())


@pytest.fixture
def cli():
    return run_cli
