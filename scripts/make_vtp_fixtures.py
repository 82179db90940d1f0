#!/usr/bin/python3
"""Writes tests/io/vtp/*.vtp with VTK's own vtkXMLPolyDataWriter, in every encoding it has.

Run with Debian's python3 and python3-vtk9 (apt-get install python3-vtk9); the files are
committed, so the tests need no VTK. Each file holds the same surface: a sheet in the plane
x = 30 mm spanning y, z in [-250, 250] mm (9 x 7 points, 96 triangles), so a
resection along it equals `--plane 30,0,0:1,0,0`. `strips.vtp` holds it as triangle strips.
"""
import os
import sys

import vtk

out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..",
                                                          "tests", "io", "vtp")
os.makedirs(out, exist_ok=True)

sheet = vtk.vtkPlaneSource()
sheet.SetOrigin(30, -250, -250)
sheet.SetPoint1(30, 250, -250)
sheet.SetPoint2(30, -250, 250)
sheet.SetResolution(8, 6)
triangles = vtk.vtkTriangleFilter()
triangles.SetInputConnection(sheet.GetOutputPort())
triangles.Update()
strips = vtk.vtkStripper()
strips.SetInputConnection(triangles.GetOutputPort())
strips.Update()


def write(name, data, mode, compress=False, header64=False, float64=False, big=False,
          id32=False):
    poly = vtk.vtkPolyData()
    poly.DeepCopy(data)
    if float64:
        points = vtk.vtkPoints()
        points.SetDataTypeToDouble()
        points.DeepCopy(poly.GetPoints())
        poly.SetPoints(points)
    w = vtk.vtkXMLPolyDataWriter()
    w.SetInputData(poly)
    w.SetFileName(os.path.join(out, name + ".vtp"))
    {"ascii": w.SetDataModeToAscii, "binary": w.SetDataModeToBinary,
     "appended": w.SetDataModeToAppended, "raw": w.SetDataModeToAppended}[mode]()
    if mode == "raw":
        w.EncodeAppendedDataOff()
    if compress:
        w.SetCompressorTypeToZLib()
    else:
        w.SetCompressorTypeToNone()
    if header64:
        w.SetHeaderTypeToUInt64()
    if big:
        w.SetByteOrderToBigEndian()
    if id32:
        w.SetIdTypeToInt32()
    assert w.Write() == 1, name


write("ascii", triangles.GetOutput(), "ascii")
write("binary", triangles.GetOutput(), "binary")
write("binary_zlib", triangles.GetOutput(), "binary", compress=True)
write("appended_zlib_uint64", triangles.GetOutput(), "appended", compress=True, header64=True)
write("appended", triangles.GetOutput(), "appended", float64=True, id32=True)
write("raw", triangles.GetOutput(), "raw", header64=True)
write("raw_zlib", triangles.GetOutput(), "raw", compress=True, float64=True)
write("raw_big_endian", triangles.GetOutput(), "raw", big=True, compress=True)
write("strips", strips.GetOutput(), "binary", compress=True)
# VTK's writer as it comes (appended, base64, zlib): what 3D Slicer's model storage writes
write("default", triangles.GetOutput(), "appended", compress=True)
