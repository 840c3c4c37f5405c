"""Mesh.to_meshio: a meshio.Mesh with the same nodes and elements, the cell tags as cell data,
that meshio itself writes and reads back. Skipped without meshio (python3-meshio)."""
import numpy
import pytest

import packmesh

meshio = pytest.importorskip("meshio")


def blocks_of(mm):
    return {b.type: b.data for b in mm.cells}


@pytest.mark.parametrize("case, volume", [("case:qi3", False), ("case:boxhole", True)])
def test_to_meshio_has_the_same_counts(case, volume, tmp_path):
    m = packmesh.mesh(case, volume=volume)
    mm = m.to_meshio()
    assert isinstance(mm, meshio.Mesh)
    assert numpy.array_equal(mm.points, m.nodes)
    blocks = blocks_of(mm)
    want = {"line": m.segments, "triangle": m.triangles, "tetra": m.tets}
    assert set(blocks) == {k for k, v in want.items() if len(v)}
    for name, cells in blocks.items():
        assert numpy.array_equal(cells, want[name])
    tags = dict(zip((b.type for b in mm.cells), mm.cell_data["cell"]))
    for name, kind in (("line", "segments"), ("triangle", "triangles"), ("tetra", "tets")):
        if name in tags:
            assert numpy.array_equal(tags[name], m.cell_tags[kind])
    # meshio writes it and reads it back with the same counts.
    path = tmp_path / "m.vtu"
    mm.write(path)
    back = meshio.read(path)
    assert len(back.points) == len(m.nodes)
    counts = {}
    for b in back.cells:
        counts[b.type] = counts.get(b.type, 0) + len(b.data)
    assert counts == {k: len(v) for k, v in want.items() if len(v)}


def test_packmesh_reads_what_it_wrote(tmp_path):
    m = packmesh.mesh("case:boxhole", volume=True)
    m.write(tmp_path / "m.vtu")
    back = packmesh.read(tmp_path / "m.vtu")
    assert back.method == "external" and back.stats is None
    assert (len(back.nodes), len(back.triangles), len(back.tets)) == \
        (len(m.nodes), len(m.triangles), len(m.tets))
    numpy.testing.assert_allclose(back.nodes, m.nodes, rtol=0, atol=1e-12)
