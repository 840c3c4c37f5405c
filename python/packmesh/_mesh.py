"""Meshes: mesh() runs a method as `packmesh mesh --stats` does, read() reads a mesh file; both
give a Mesh of NumPy arrays."""
import json
import numbers
import os

from . import _packmesh

# The element kinds: the attribute of their connectivity, meshio's name for them.
KINDS = (("segments", "line"), ("triangles", "triangle"), ("tets", "tetra"))


class Mesh:
    """A mesh: nodes, segments on curves, triangles on faces and tets in volumes.

    Attributes (NumPy arrays, copies owned by the Mesh):
      nodes        (n, 3) float64, x y z (z = 0 for planar domains)
      segments     (k, 2) int32, 0-based node indices; triangles (k, 3); tets (k, 4)
      cell_tags    dict by kind, {"segments": ..., "triangles": ..., "tets": ...}: per element the
                   index of the model cell it lies on (0-based curve, face or volume; -1 unknown;
                   a .msh file's entity tag is this + 1)
      node_dims    (n,) int8, the dimension of the cell each node lies on (0..3, -1 unknown)
      node_cells   (n,) int32, that cell's index
    and, for a mesh made by mesh():
      stats        dict, the --stats JSON of `packmesh mesh` for the same run
      result       dict, what the run did: iterations, stop_reason, runs, size_scale,
                   target_met, seconds
      input, method the input and method it was made from
    A mesh read from a file has stats and result None and method "external".
    """

    def __init__(self, handle, arrays, input, method, stats=None, result=None):
        self._handle = handle  # the library's pm_mesh, for write() and quality()
        self.nodes = arrays["nodes"]
        self.node_dims = arrays["node_dims"]
        self.node_cells = arrays["node_cells"]
        self.segments = arrays["segments"]
        self.triangles = arrays["triangles"]
        self.tets = arrays["tets"]
        self.cell_tags = {"segments": arrays["segment_cells"],
                          "triangles": arrays["triangle_cells"],
                          "tets": arrays["tet_cells"]}
        self.input = input
        self.method = method
        self.stats = stats
        self.result = result

    def __repr__(self):
        return (f"<packmesh.Mesh {self.method} {self.input}: {len(self.nodes)} nodes, "
                f"{len(self.segments)} segments, {len(self.triangles)} triangles, "
                f"{len(self.tets)} tets>")

    def write(self, path, msh_parametric=False):
        """Write the mesh as `packmesh mesh -o PATH` does; the format follows the extension (.msh,
        .vtk, .vtu, .stl, .obj, .mesh). msh_parametric: .msh nodes carry their parameters on
        curves and faces. Written under a temporary name and renamed: on failure nothing is left
        at path."""
        _packmesh._write(self._handle, os.fspath(path), msh_parametric=bool(msh_parametric))

    def quality(self, geometry=None, size=None):
        """packmesh.quality(self, geometry, size)."""
        from ._quality import quality
        return quality(self, geometry=geometry, size=size)

    def to_meshio(self):
        """The mesh as a meshio.Mesh: one cell block per kind present (line, triangle, tetra) and
        the cell tags as the cell data "cell". ImportError when meshio is not installed
        (Debian's python3-meshio)."""
        try:
            import meshio
        except ImportError as e:
            raise ImportError("Mesh.to_meshio needs meshio (Debian: python3-meshio)") from e
        blocks, tags = [], []
        for kind, name in KINDS:
            cells = getattr(self, kind)
            if len(cells):
                blocks.append((name, cells))
                tags.append(self.cell_tags[kind])
        return meshio.Mesh(self.nodes, blocks, cell_data={"cell": tags} if blocks else {})


def _param_text(key, value):
    """A parameter value as --set takes it: on/off for booleans, the shortest exact text of a
    number."""
    if isinstance(value, bool):
        return "on" if value else "off"
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        return repr(float(value))
    if isinstance(value, str):
        return value
    raise TypeError(f"params[{key!r}]: a number, a bool or a string, not {type(value).__name__}")


def _whole(name, value, least, allow_none=False, most=2**63 - 1):
    """A whole-number argument, range-checked as the command checks its option."""
    if value is None and allow_none:
        return 0
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be a whole number, not {type(value).__name__}")
    if not least <= value <= most:
        raise ValueError(f"{name} must be a whole number from {least} to {most}, got {value}")
    return int(value)


def mesh(input, method="bubble", size=None, params=None, seed=1, volume=False, threads=1,
         target_nodes=None, max_nodes=None):
    """Mesh `input` with `method`, as `packmesh mesh INPUT --stats` does, and return a Mesh.

    input        a CAD file (.step .stp .iges .igs .brep), "case:NAME" (packmesh.cases()) or a case
                 file (.json); a str or a path
    method       one of packmesh.methods(): "bubble", "psys", "gmsh-frontal", "gmsh-delaunay",
                 "gmsh-meshadapt", "cgal"
    size         the desired edge length: None (the input's own field, else the method's
                 default), a number, a string as --size takes it (a number, an expression in x,
                 y, z, r such as "0.2*abs(r-2)+0.15", or "inferred": psys's field), or a callable
                 f(x, y, z) -> float. A callable may be called from the run's threads; packmesh
                 holds the GIL for each call. An exception it raises ends the run and is raised
                 here.
    params       {KEY: value} of the method's parameters (packmesh.method_params(method)), as
                 --set KEY=VALUE; booleans are on/off
    seed         fixes every random choice; the mesh does not depend on threads
    volume       also mesh the volumes with tets
    threads      threads of the run (OpenMP)
    target_nodes scale the size field until the node count is within 3% of this (at most 8
                 runs); mesh.result["target_met"] says whether it was reached
    max_nodes    the node cap (default 20000000)

    The GIL is released while the library works. Errors raise ValueError, OSError or
    RuntimeError with the library's message (see the module's help).
    """
    input_text = os.fspath(input)
    if not isinstance(method, str):
        raise TypeError(f"method must be a str, not {type(method).__name__}")
    pairs = [(str(k), _param_text(k, v)) for k, v in (params or {}).items()]
    handle, arrays, stats_json, result = _packmesh._generate(
        input_text, method, size, pairs, _whole("seed", seed, 0), bool(volume),
        _whole("threads", threads, 1, most=1024), _whole("target_nodes", target_nodes, 3, True),
        _whole("max_nodes", max_nodes, 3, True))
    return Mesh(handle, arrays, input_text, method, json.loads(stats_json), result)


def read(path):
    """Read a mesh file (.msh MSH 2 / 4.1, .vtk, .vtu, .stl, .mesh, .obj) with packmesh's readers,
    as `packmesh quality` does. OSError for a file that cannot be read, RuntimeError for one
    that is malformed."""
    path = os.fspath(path)
    handle, arrays = _packmesh._read(path)
    return Mesh(handle, arrays, path, "external")
