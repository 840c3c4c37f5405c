"""mesh() against the packmesh command: the same run gives the same mesh and the same stats keys;
the same seed gives the same arrays whatever the threads; the library's errors arrive as Python
exceptions carrying its message."""
import json
import threading

import numpy
import pytest

import packmesh
from conftest import cli_counts


def flat_keys(d, prefix=""):
    keys = set()
    for k, v in d.items():
        keys |= flat_keys(v, f"{prefix}{k}.") if isinstance(v, dict) else {prefix + k}
    return keys


def test_qi3_bubble_gives_the_commands_node_count(cli, tmp_path):
    line = cli("mesh", "case:qi3", "--method", "bubble", "-o", tmp_path / "qi3.msh").stdout
    nodes, segments, triangles, tets = cli_counts(line)
    m = packmesh.mesh("case:qi3", method="bubble")
    assert len(m.nodes) == nodes
    assert (len(m.segments), len(m.triangles), len(m.tets)) == (segments, triangles, tets)
    assert m.nodes.shape == (nodes, 3) and m.nodes.dtype == numpy.float64
    assert m.triangles.shape == (triangles, 3) and m.segments.shape == (segments, 2)
    assert m.tets.shape == (0, 4)
    assert m.triangles.min() >= 0 and m.triangles.max() < nodes, "indices are not 0-based"
    assert numpy.all(m.nodes[:, 2] == 0)


def test_stats_are_the_commands_stats(cli, tmp_path):
    cli("mesh", "case:qi3", "--method", "bubble", "--threads", "1", "-o", tmp_path / "m.msh",
        "--stats", tmp_path / "s.json")
    want = json.loads((tmp_path / "s.json").read_text())
    got = packmesh.mesh("case:qi3", method="bubble").stats
    not_times = lambda keys: {k for k in keys if not k.startswith("time_s.")}
    assert not_times(flat_keys(got)) == not_times(flat_keys(want))
    for key in ("method", "input", "nodes", "segments", "triangles", "tets", "valid",
                "iterations", "stop_reason", "size", "seed", "threads", "params"):
        assert got[key] == want[key], key
    assert got["tri"]["radius_ratio"] == want["tri"]["radius_ratio"]
    assert got["time_s"]["total"] > 0


@pytest.mark.parametrize("method", ["bubble", "psys"])
def test_same_seed_same_arrays_over_threads(method):
    one = packmesh.mesh("case:qi3", method=method, seed=3, threads=1)
    two = packmesh.mesh("case:qi3", method=method, seed=3, threads=2)
    for name in ("nodes", "segments", "triangles", "tets", "node_dims", "node_cells"):
        assert numpy.array_equal(getattr(one, name), getattr(two, name)), name
    for kind in one.cell_tags:
        assert numpy.array_equal(one.cell_tags[kind], two.cell_tags[kind]), kind


def test_cell_tags_and_volumes():
    m = packmesh.mesh("case:boxhole", volume=True)
    assert len(m.tets) > 0 and m.tets.shape[1] == 4
    for kind in ("segments", "triangles", "tets"):
        tags = m.cell_tags[kind]
        assert tags.shape == (len(getattr(m, kind)),) and tags.dtype == numpy.int32
        assert tags.min() >= 0
    assert set(numpy.unique(m.cell_tags["tets"])) == {0}, "boxhole has one volume"
    assert len(numpy.unique(m.cell_tags["triangles"])) > 6, "boxhole has more than 6 faces"
    assert m.stats["tets"] == len(m.tets) and m.stats["valid"] is True


def test_size_forms_and_params(cli, tmp_path):
    line = cli("mesh", "case:qi1", "--size", "0.2", "--set", "w2=0.6", "--set", "population=off",
               "-o", tmp_path / "m.msh").stdout
    m = packmesh.mesh("case:qi1", size=0.2, params={"w2": 0.6, "population": False})
    assert len(m.nodes) == cli_counts(line)[0]
    assert (m.stats["params"]["w2"], m.stats["params"]["population"]) == ("0.6", "off")
    assert m.stats["size"] == "0.2"
    assert numpy.array_equal(packmesh.mesh("case:qi1", size="0.2", params={"w2": "0.6",
                                           "population": "off"}).nodes, m.nodes)
    e = packmesh.mesh("case:qi3", size="0.3*abs(r-2)+0.2")
    assert e.stats["size"] == "0.3*abs(r-2)+0.2"
    assert len(e.nodes) < 651


@pytest.mark.parametrize("method", ["gmsh-frontal", "bubble"])
def test_inferred_size_is_the_commands(cli, tmp_path, method):
    line = cli("mesh", "case:qi1", "--method", method, "--size", "inferred", "--threads", "1",
               "-o", tmp_path / "m.msh").stdout
    assert len(packmesh.mesh("case:qi1", method=method, size="inferred").nodes) == \
        cli_counts(line)[0]


def test_the_gil_is_released_during_the_run():
    """Another Python thread runs while the library meshes (it would stand still were the GIL
    held)."""
    ticks, stop = [0], threading.Event()

    def ticker():
        while not stop.is_set():
            ticks[0] += 1

    t = threading.Thread(target=ticker)
    t.start()
    try:
        before = ticks[0]
        m = packmesh.mesh("case:qi1", size=0.04)
        during = ticks[0] - before
    finally:
        stop.set()
        t.join()
    assert m.result["seconds"] > 0.2, "the run was too short to tell"
    assert during > 10000, during


def test_target_nodes():
    m = packmesh.mesh("case:qi3", method="gmsh-frontal", target_nodes=500)
    assert m.result["target_met"] and abs(len(m.nodes) / 500 - 1) <= 0.03
    assert m.stats["target_nodes"] == 500


def commands_error(cli, *args):
    proc = cli("mesh", *args, check=False)
    assert proc.returncode != 0
    return proc.stderr.strip()


@pytest.mark.parametrize("kwargs, args, error", [
    ({"method": "nosuch"}, ["--method", "nosuch"], ValueError),
    ({"params": {"nosuch": 1}}, ["--set", "nosuch=1"], ValueError),
    ({"params": {"k0": -1}}, ["--set", "k0=-1"], ValueError),
    ({"size": "0.1*(x"}, ["--size", "0.1*(x"], ValueError),
    ({"size": "-0.5"}, ["--size", "-0.5"], ValueError),
    ({"size": "0.5-x"}, ["--size", "0.5-x"], ValueError),
    ({"volume": True}, ["--volume"], ValueError),
])
def test_errors_carry_the_librarys_message(cli, tmp_path, kwargs, args, error):
    with pytest.raises(error) as e:
        packmesh.mesh("case:qi1", **kwargs)
    message = str(e.value)
    assert message and "\n" not in message
    # The command prints the same message, prefixed and perhaps with a hint after it.
    stderr = commands_error(cli, "case:qi1", *args, "-o", tmp_path / "m.msh")
    core = message.split(": ", 1)[-1] if message.startswith("volume=True") else message
    assert core in stderr, (message, stderr)


def test_size_numbers_are_checked():
    for bad in (-0.5, 0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="size must be a finite number > 0"):
            packmesh.mesh("case:qi1", size=bad)


def test_missing_file_is_oserror(tmp_path):
    with pytest.raises(OSError, match="nosuch.step"):
        packmesh.mesh(tmp_path / "nosuch.step")


def test_unknown_case_is_valueerror():
    with pytest.raises(ValueError, match="unknown case 'nosuch'"):
        packmesh.mesh("case:nosuch")


def test_node_cap_is_runtimeerror():
    with pytest.raises(RuntimeError) as e:
        packmesh.mesh("case:qi1", size=0.001, max_nodes=1000)
    assert e.value.status == "limit exceeded" or "cap" in str(e.value)
