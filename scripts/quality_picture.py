#!/usr/bin/env python3
"""A picture of a mesh coloured by one per-element quality measure, rendered off-screen.

    scripts/quality_picture.py MESH.vtu OUT.png [--array aspect_ratio] [--size 1200x900]

MESH is a .vtu or legacy .vtk that `packmesh mesh -o` wrote: its cell data carries radius_ratio,
aspect_ratio (R / l_min) and min_angle_deg for every triangle and tet (-1 on segments, which are
left out of the picture). The surface triangles are drawn coloured by the array on a blue-to-red
scale whose range is that of the triangles, with a colour bar, seen from an oblique direction.
Needs Debian's python3-vtk9; with no display it renders through xvfb-run (package xvfb):

    xvfb-run -a scripts/quality_picture.py m.vtu m.png
"""
import argparse
import sys


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("mesh")
    ap.add_argument("png")
    ap.add_argument("--array", default="aspect_ratio",
                    help="cell data to colour by (radius_ratio, aspect_ratio, min_angle_deg)")
    ap.add_argument("--size", default="1200x900", help="picture size WxH in pixels")
    a = ap.parse_args()
    try:
        w, h = (int(x) for x in a.size.split("x"))
    except ValueError:
        ap.error(f"--size {a.size}: expected WxH, e.g. 1200x900")
    try:
        import vtk
    except ImportError:
        sys.exit("quality_picture.py: python3-vtk9 is not installed (apt-get install python3-vtk9)")

    if a.mesh.endswith(".vtu"):
        reader = vtk.vtkXMLUnstructuredGridReader()
    elif a.mesh.endswith(".vtk"):
        reader = vtk.vtkUnstructuredGridReader()
        reader.ReadAllScalarsOn()  # the legacy reader keeps only the first SCALARS otherwise
    else:
        sys.exit(f"quality_picture.py: {a.mesh}: a .vtu or .vtk file is expected")
    reader.SetFileName(a.mesh)
    reader.Update()
    grid = reader.GetOutput()
    values = grid.GetCellData().GetArray(a.array)
    if grid.GetNumberOfCells() == 0 or values is None:
        sys.exit(f"quality_picture.py: {a.mesh}: no cells with the array '{a.array}'")

    # The triangles only: tets would hide them, segments have no value (-1).
    triangles = vtk.vtkIdTypeArray()
    for i in range(grid.GetNumberOfCells()):
        if grid.GetCellType(i) == vtk.VTK_TRIANGLE:
            triangles.InsertNextValue(i)
    if triangles.GetNumberOfTuples() == 0:
        sys.exit(f"quality_picture.py: {a.mesh}: no triangles to draw")
    selection_node = vtk.vtkSelectionNode()
    selection_node.SetFieldType(vtk.vtkSelectionNode.CELL)
    selection_node.SetContentType(vtk.vtkSelectionNode.INDICES)
    selection_node.SetSelectionList(triangles)
    selection = vtk.vtkSelection()
    selection.AddNode(selection_node)
    extract = vtk.vtkExtractSelection()
    extract.SetInputData(0, grid)
    extract.SetInputData(1, selection)
    extract.Update()
    surface = extract.GetOutput()
    lo, hi = surface.GetCellData().GetArray(a.array).GetRange()

    lut = vtk.vtkLookupTable()
    lut.SetHueRange(0.667, 0.0)  # blue (low) to red (high)
    lut.SetTableRange(lo, hi)
    lut.Build()
    mapper = vtk.vtkDataSetMapper()
    mapper.SetInputData(surface)
    mapper.SetScalarModeToUseCellFieldData()
    mapper.SelectColorArray(a.array)
    mapper.SetLookupTable(lut)
    mapper.SetScalarRange(lo, hi)
    actor = vtk.vtkActor()
    actor.SetMapper(mapper)
    actor.GetProperty().EdgeVisibilityOn()
    actor.GetProperty().SetEdgeColor(0.15, 0.15, 0.15)
    bar = vtk.vtkScalarBarActor()
    bar.SetLookupTable(lut)
    bar.SetTitle({"aspect_ratio": "R / l_min"}.get(a.array, a.array))
    bar.SetNumberOfLabels(5)
    bar.SetPosition(0.1, 0.1)
    bar.SetWidth(0.6)
    bar.SetHeight(0.8)

    renderer = vtk.vtkRenderer()
    renderer.AddActor(actor)
    renderer.SetBackground(1, 1, 1)
    renderer.SetViewport(0, 0, 0.86, 1)  # the mesh left of the colour bar
    bar.GetTitleTextProperty().SetColor(0, 0, 0)
    bar.GetLabelTextProperty().SetColor(0, 0, 0)
    camera = renderer.GetActiveCamera()
    camera.Elevation(35)
    camera.Azimuth(30)
    renderer.ResetCamera()
    window = vtk.vtkRenderWindow()
    window.SetOffScreenRendering(1)
    window.AddRenderer(renderer)
    legend = vtk.vtkRenderer()  # the colour bar in the right margin
    legend.SetViewport(0.86, 0, 1, 1)
    legend.SetBackground(1, 1, 1)
    legend.AddActor2D(bar)
    window.AddRenderer(legend)
    window.SetSize(w, h)
    window.Render()
    shot = vtk.vtkWindowToImageFilter()
    shot.SetInput(window)
    shot.Update()
    writer = vtk.vtkPNGWriter()
    writer.SetFileName(a.png)
    writer.SetInputConnection(shot.GetOutputPort())
    writer.Write()
    print(f"{a.png}: {triangles.GetNumberOfTuples()} triangles of {a.mesh} coloured by {a.array} "
          f"[{lo:.4g}, {hi:.4g}]")


if __name__ == "__main__":
    main()
