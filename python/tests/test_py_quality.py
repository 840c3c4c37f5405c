"""quality() against `packmesh quality --csv`: the per-element measures of a mesh written to .msh
are the command's, element by element; the summaries are the --stats ones."""
import csv
import io
import json

import numpy
import pytest

import packmesh

MEASURES = ("radius_ratio", "aspect_ratio", "min_angle_deg", "max_angle_deg")


def commands_csv(cli, path):
    """The command's rows by kind: {"tri": {measure: array}, "tet": {...}}, and the cells."""
    rows = list(csv.DictReader(io.StringIO(cli("quality", path, "--csv").stdout)))
    out = {}
    for kind in ("tri", "tet"):
        mine = [r for r in rows if r["kind"] == kind]
        assert [int(r["index"]) for r in mine] == list(range(len(mine)))
        out[kind] = {m: numpy.array([float(r[m]) for r in mine]) for m in MEASURES}
        out[kind]["cell"] = numpy.array([int(r["cell"]) for r in mine])
    return out


@pytest.mark.parametrize("case, volume", [("case:qi3", False), ("case:boxhole", True)])
def test_quality_is_the_commands(cli, tmp_path, case, volume):
    m = packmesh.mesh(case, volume=volume)
    path = tmp_path / "m.msh"
    m.write(path)
    want = commands_csv(cli, path)
    from_mesh, from_file = packmesh.quality(m), m.quality()
    read_back = packmesh.quality(path)
    assert len(want["tri"]["radius_ratio"]) == len(m.triangles) > 0
    assert len(want["tet"]["radius_ratio"]) == len(m.tets)
    for kind, attr in (("tri", "triangles"), ("tet", "tets")):
        for name in MEASURES:
            # The file holds every digit (%.17g): the same numbers, to the last bit or two.
            numpy.testing.assert_allclose(getattr(read_back, attr)[name], want[kind][name],
                                          rtol=1e-13, atol=0)
            numpy.testing.assert_allclose(getattr(from_mesh, attr)[name], want[kind][name],
                                          rtol=1e-12, atol=0)
            assert numpy.array_equal(getattr(from_file, attr)[name],
                                     getattr(from_mesh, attr)[name])
    # The command's cell column is the mesh's cell tags.
    assert numpy.array_equal(want["tri"]["cell"], m.cell_tags["triangles"])
    assert from_mesh.valid and from_mesh.problems == []


def test_summary_is_the_stats():
    m = packmesh.mesh("case:qi3")
    q = packmesh.quality(m)
    for name in MEASURES:
        s, t = q.summary["tri"][name], m.stats["tri"][name]
        for key in ("min", "p25", "median", "p75", "max", "mean"):
            assert s[key] == pytest.approx(t[key], rel=1e-12), (name, key)
        assert s["n"] == len(m.triangles)
        # The summary is the values' five numbers, percentiles as NumPy's default.
        assert s["median"] == pytest.approx(numpy.median(q.triangles[name]), rel=1e-12)
        assert s["p25"] == pytest.approx(numpy.percentile(q.triangles[name], 25), rel=1e-12)
    assert q.summary["tri"]["eps_t"] == pytest.approx(m.stats["tri"]["eps_t"], rel=1e-12)
    assert q.summary["tet"]["radius_ratio"]["n"] == 0 and len(q.tets["radius_ratio"]) == 0
    assert q.summary["tri"]["size_ratio"] is None, "no size field was given"


def test_geometry_gives_its_size_field_and_the_model_checks(cli, tmp_path):
    m = packmesh.mesh("case:qi3")
    path = tmp_path / "m.msh"
    m.write(path)
    q = packmesh.quality(path, geometry="case:qi3")
    ratio = q.summary["tri"]["size_ratio"]
    assert ratio is not None and 0.8 < ratio["median"] < 1.25
    assert ratio["mean"] == pytest.approx(m.stats["tri"]["size_ratio"]["mean"], rel=1e-9)
    assert q.valid
    # Against another model the checker finds the problems the command's --geometry finds.
    other = packmesh.quality(path, geometry="case:sphere")
    stats = json.loads(cli("quality", path, "--geometry", "case:sphere", "--json").stdout)
    assert other.valid is False and stats["valid"] is False
    assert other.problems == stats["problems"] and len(other.problems) >= 2


def test_untagged_file_is_classified_like_the_command(cli, tmp_path):
    """A .stl names no cells: with geometry= its nodes are put on the model first, so eps_t is
    the tagged .msh's, as `packmesh quality --geometry` gives it."""
    m = packmesh.mesh("case:boxhole", method="gmsh-frontal")
    m.write(tmp_path / "m.msh")
    m.write(tmp_path / "m.stl")
    tagged = packmesh.quality(tmp_path / "m.msh", geometry="case:boxhole")
    untagged = packmesh.quality(tmp_path / "m.stl", geometry="case:boxhole")
    bare = packmesh.quality(tmp_path / "m.stl")
    stats = json.loads(cli("quality", tmp_path / "m.stl", "--geometry", "case:boxhole",
                           "--json").stdout)
    assert untagged.summary["tri"]["eps_t"] == tagged.summary["tri"]["eps_t"]
    assert untagged.summary["tri"]["eps_t"] == stats["tri"]["eps_t"]
    assert bare.summary["tri"]["eps_t"] != tagged.summary["tri"]["eps_t"]


def test_bad_geometry_and_size():
    m = packmesh.mesh("case:qi1", size=0.5)
    with pytest.raises(ValueError, match="geometry: unknown case 'nosuch'"):
        packmesh.quality(m, geometry="case:nosuch")
    with pytest.raises(ValueError, match="size expression"):
        packmesh.quality(m, size="0.1*(")
    with pytest.raises(ValueError, match="inferred"):
        packmesh.quality(m, size="inferred")
