"""packmesh from Python: mesh with packmesh's meshers, measure meshes and run comparison studies.

    import packmesh
    m = packmesh.mesh("case:qi3", method="bubble")        # a Mesh: NumPy arrays and the stats
    m.nodes, m.triangles, m.cell_tags["triangles"], m.stats["tri"]["radius_ratio"]["median"]
    q = packmesh.quality(m)                               # per-element measures and summaries
    s = packmesh.compare({"cases": ["case:qi1"], "methods": ["bubble", "psys"]}, "study")

The meshing and measuring run in libpackmesh through its public C API (packmesh.h and
packmesh_extended.h), exactly as the packmesh command runs them: the same node counts, the same
--stats keys. compare() runs the packmesh command itself. python/README.md documents the API.

Errors of the library raise ValueError (a bad argument: an unknown method or parameter, a value
out of range, a size that is no number or expression), OSError (a file that cannot be read or
written) or RuntimeError (anything else: a geometry the method cannot mesh, a node cap, a
backend's failure), with the library's one-line message; the exception's `status` attribute
names the library's code ("bad argument", "limit exceeded", ...).
"""
from . import _packmesh
from ._compare import Study, cli_path, compare
from ._mesh import Mesh, mesh, read
from ._quality import Quality, quality

__version__ = _packmesh._version()

__all__ = ["__version__", "methods", "method_params", "cases", "mesh", "read", "Mesh",
           "quality", "Quality", "compare", "Study", "cli_path"]


def methods():
    """The names of the methods, in the library's order: bubble, psys, gmsh-frontal, ..."""
    return [m["name"] for m in _packmesh._methods()]


def method_params(name):
    """The parameters of method `name`, as `packmesh mesh --method NAME --help` lists them: a list
    of dicts with "key" (what mesh(params={KEY: ...}) takes), "default", "range", "unit",
    "source" (the paper and equation) and "doc". ValueError for an unknown method."""
    return _packmesh._method_params(name)


def cases():
    """The built-in cases (`packmesh cases`): a list of dicts with "name" (mesh("case:NAME")),
    "dimension" (2 planar, 3 solid), "description", "default_size" and "source"."""
    return _packmesh._cases()
