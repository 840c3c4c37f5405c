"""examples/boxplot_compare.py: the study of three methods on qi3 runs and its box plot is a real
picture (a PNG of the expected size with more than a blank background)."""
import os
import subprocess
import sys

import pytest

EXAMPLE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "examples",
                       "boxplot_compare.py")


def test_boxplot_example(tmp_path):
    pytest.importorskip("matplotlib")
    png = tmp_path / "box.png"
    proc = subprocess.run([sys.executable, EXAMPLE, str(png), "--jobs", "2"],
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.returncode == 0, proc.stderr
    assert png.is_file() and png.stat().st_size > 10000
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    import matplotlib.image
    pixels = matplotlib.image.imread(png)
    assert pixels.shape[0] >= 400 and pixels.shape[1] >= 600
    # Boxes, whiskers and labels: many pixels differ from the white background.
    ink = (pixels[:, :, :3].min(axis=2) < 0.5).mean()
    assert 0.005 < ink < 0.5, ink
    study = tmp_path / "boxplot-study"
    assert (study / "elements.csv").is_file() and (study / "report.html").is_file()
