"""The module alone: its version, the tables it answers from the library (methods, parameters,
cases), and bad arguments that must raise, not crash."""
import re

import pytest

import packmesh


def test_version_is_the_library_version():
    assert re.fullmatch(r"\d+\.\d+\.\d+", packmesh.__version__)


def test_methods_in_the_library_order():
    names = packmesh.methods()
    assert names[:2] == ["bubble", "psys"]
    assert {"gmsh-frontal", "gmsh-delaunay", "gmsh-meshadapt", "cgal"} <= set(names)


def test_method_params_is_the_help_table():
    table = packmesh.method_params("bubble")
    by_key = {p["key"]: p for p in table}
    assert len(by_key) == len(table), "a key listed twice"
    k0 = by_key["k0"]
    assert (k0["default"], k0["range"]) == ("30", "(0, 1e+06]")
    assert "003 eq. 11" in k0["source"] and k0["doc"]
    assert by_key["population"]["range"] == "on|off"
    for p in table:
        assert set(p) == {"key", "default", "range", "unit", "source", "doc"}
    assert any(p["key"] == "L" for p in packmesh.method_params("psys"))


def test_method_params_of_an_unknown_method():
    with pytest.raises(ValueError, match=r"unknown method 'nosuch' \(known: bubble, psys"):
        packmesh.method_params("nosuch")


def test_cases():
    by_name = {c["name"]: c for c in packmesh.cases()}
    assert {"qi1", "qi2", "qi3", "qi4", "shimada", "sphere", "boxhole"} <= set(by_name)
    assert by_name["qi3"]["dimension"] == 2 and by_name["sphere"]["dimension"] == 3
    assert by_name["qi3"]["default_size"] == "0.2*abs(r-2)+0.15"
    assert "papers/004" in by_name["qi3"]["source"]


@pytest.mark.parametrize("kwargs, error, text", [
    ({"size": True}, TypeError, "size must be None, a number"),
    ({"size": [0.1]}, TypeError, "size must be None, a number"),
    ({"params": {"k0": [1]}}, TypeError, r"params\['k0'\]"),
    ({"seed": -1}, ValueError, "seed must be a whole number from 0"),
    ({"threads": 0}, ValueError, "threads must be a whole number from 1 to 1024"),
    ({"threads": 1.5}, TypeError, "threads must be a whole number"),
    ({"target_nodes": 2}, ValueError, "target_nodes must be a whole number from 3"),
    ({"method": None}, TypeError, "method must be a str"),
])
def test_bad_arguments_raise(kwargs, error, text):
    with pytest.raises(error, match=text):
        packmesh.mesh("case:qi1", **kwargs)


def test_input_of_the_wrong_type():
    with pytest.raises(TypeError):
        packmesh.mesh(3)


def test_files_that_cannot_be_read(tmp_path):
    with pytest.raises(OSError, match="nosuch.msh"):
        packmesh.read(tmp_path / "nosuch.msh")
    garbage = tmp_path / "garbage.msh"
    garbage.write_text("$MeshFormat\nnot a mesh\n")
    with pytest.raises(RuntimeError) as e:
        packmesh.read(garbage)
    assert "garbage.msh" in str(e.value) and e.value.status != "bad argument"
    with pytest.raises(TypeError, match="packmesh.Mesh or a path"):
        packmesh.quality(42)


def test_files_that_cannot_be_written(tmp_path):
    m = packmesh.mesh("case:qi1", size=0.5)
    with pytest.raises(ValueError, match="xyz"):
        m.write(tmp_path / "m.xyz")
    with pytest.raises(OSError):
        m.write(tmp_path / "no" / "such" / "folder" / "m.msh")
    with pytest.raises(ValueError, match="msh_parametric"):
        m.write(tmp_path / "m.vtu", msh_parametric=True)
    assert list(tmp_path.iterdir()) == [], "a failed write left a file behind"
