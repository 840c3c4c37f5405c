"""quality(): the measures of every triangle and tet of a mesh, through the library's quality
functions (the one implementation `packmesh quality` and --stats use)."""
import os

from . import _packmesh

MEASURES = ("radius_ratio", "aspect_ratio", "min_angle_deg", "max_angle_deg")


class Quality:
    """The measures of a mesh's elements.

    triangles, tets  dicts of per-element float64 arrays in element order, keyed by measure:
                     "radius_ratio" (2 r_in / R for triangles, 3 r_in / R for tets; 1 is best),
                     "aspect_ratio" (R / l_min; 0.577 for an equilateral triangle),
                     "min_angle_deg", "max_angle_deg" (for tets the dihedral angles) -- the
                     columns of `packmesh quality --csv`
    summary          {"tri": {...}, "tet": {...}}: per measure a dict n, min, p25, median, p75,
                     max, mean (percentiles as NumPy's default); "eps_t" and "eps_g"
                     (papers/003 eq. 8-9); "size_ratio", the summary of edge length / d at the
                     edge midpoints, or None without a size field
    valid, problems  the checker's verdict (against the geometry when given) and its lines
    """

    def __init__(self, raw):
        self.triangles = raw["triangles"]["values"]
        self.tets = raw["tets"]["values"]
        self.summary = {"tri": raw["triangles"]["summary"], "tet": raw["tets"]["summary"]}
        self.valid = raw["valid"]
        self.problems = raw["problems"]

    def __repr__(self):
        tri = self.summary["tri"]["radius_ratio"]
        return (f"<packmesh.Quality {tri['n']} triangles (radius ratio median "
                f"{tri['median']:.4f}), {self.summary['tet']['radius_ratio']['n']} tets, "
                f"{'valid' if self.valid else 'invalid'}>")


def quality(mesh_or_path, geometry=None, size=None):
    """Measure a mesh: a Mesh, or the path of a mesh file (.msh .vtk .vtu .stl .mesh .obj).

    geometry  the model the mesh discretizes (a CAD file, "case:NAME" or a case file), as
              `packmesh quality --geometry`: the checker then checks the mesh against it, and its
              own size field (a built-in case's, a case file's) gives the size conformity
    size      the size field for the size conformity (as mesh()'s size; it wins over the
              geometry's)
    """
    from ._mesh import Mesh
    if isinstance(mesh_or_path, Mesh):
        target = mesh_or_path._handle
    elif isinstance(mesh_or_path, (str, bytes, os.PathLike)):
        target = os.fspath(mesh_or_path)
    else:
        raise TypeError(f"quality() takes a packmesh.Mesh or a path, not "
                        f"{type(mesh_or_path).__name__}")
    geometry = None if geometry is None else os.fspath(geometry)
    return Quality(_packmesh._quality(target, size=size, geometry=geometry))
