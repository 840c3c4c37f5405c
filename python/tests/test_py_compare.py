"""compare(): a small study run by the packmesh command, its rows and per-element table as
Python values; the command's refusals as exceptions."""
import os

import pytest

import packmesh

SUITE = {
    "name": "py-tiny",
    "description": "bubble and psys on qi1, node counts matched",
    "cases": ["case:qi1"],
    "methods": ["bubble", "psys"],
    "options": {"match_nodes": True, "trace": False},
}


def test_two_methods_matched(tmp_path):
    study = packmesh.compare(SUITE, tmp_path / "study", jobs=2)
    assert [r["status"] for r in study.rows] == ["ok", "ok"], [r["error"] for r in study.rows]
    by_method = {r["method"]: r for r in study.rows}
    assert set(by_method) == {"bubble", "psys"}
    ref, other = by_method["bubble"]["nodes"], by_method["psys"]["nodes"]
    assert isinstance(ref, int) and abs(other / ref - 1) <= 0.03
    assert by_method["bubble"]["valid"] is True
    assert 0.5 < by_method["psys"]["tri.radius_ratio.median"] <= 1
    assert os.path.isfile(study.report) and study.report.endswith("report.html")
    # elements.csv: one row per triangle of each run.
    tri = study.elements(kind="tri")
    for r in study.rows:
        mine = tri["row"] == r["row"]
        assert mine.sum() == r["triangles"]
    assert tri["radius_ratio"].dtype.kind == "f" and set(tri["kind"]) == {"tri"}
    assert len(study.elements(kind="tet")["radius_ratio"]) == 0
    # The same study again resumes: nothing is rerun, the rows are the same.
    again = packmesh.compare(SUITE, tmp_path / "study")
    assert [r["nodes"] for r in again.rows] == [r["nodes"] for r in study.rows]
    assert [r["wall_s"] for r in again.rows] == [r["wall_s"] for r in study.rows]


def test_a_failed_run_is_a_row(tmp_path):
    suite = dict(SUITE, methods=["bubble", {"method": "bubble", "label": "bad",
                                            "set": {"k0": -1}}],
                 options={"trace": False})
    rows = {r["label"]: r for r in packmesh.compare(suite, tmp_path / "s").rows}
    assert rows["bubble"]["status"] == "ok"
    assert rows["bad"]["status"] == "failed" and "k0" in rows["bad"]["error"]


def test_relative_inputs_are_relative_to_the_current_folder(tmp_path, monkeypatch):
    (tmp_path / "case.json").write_text(
        '{"domain": {"loops": [[{"line": [0, 0]}, {"line": [2, 0]}, {"line": [2, 1]},'
        ' {"line": [0, 1]}]]}, "size": 0.25}')
    monkeypatch.chdir(tmp_path)
    study = packmesh.compare({"cases": ["case.json"], "methods": ["bubble"],
                              "options": {"trace": False}}, "out")
    assert study.rows[0]["input"] == str(tmp_path / "case.json")
    assert study.rows[0]["status"] == "ok", study.rows[0]["error"]


def test_the_commands_refusals(tmp_path, monkeypatch):
    with pytest.raises(RuntimeError, match='unknown key "bogus"'):
        packmesh.compare(dict(SUITE, bogus=1), tmp_path / "a")
    with pytest.raises(ValueError):
        packmesh.compare(SUITE, tmp_path / "b", jobs=0)
    monkeypatch.setenv("PACKMESH_CLI", str(tmp_path / "no-packmesh"))
    assert packmesh.cli_path() == str(tmp_path / "no-packmesh")
    with pytest.raises(FileNotFoundError, match="PACKMESH_CLI"):
        packmesh.compare(SUITE, tmp_path / "c")
