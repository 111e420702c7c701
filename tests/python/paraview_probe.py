"""Run by ParaView's pvbatch (tests/python/test_paraview.py): opens an XDMF sidecar the way a user
does, with the reader ParaView picks for its extension (OpenDataFile) or with a named reader, and
writes what ParaView sees at every time step as JSON: the reader, the time values and, per leaf
block in order, the point and cell counts and every point array's values.

    pvbatch paraview_probe.py RUN.xmf OUT.json [READER]
"""
import json
import sys

from paraview import servermanager
from paraview import simple
from vtk.numpy_interface import dataset_adapter as dsa

path, out = sys.argv[1], sys.argv[2]
reader = simple.OpenDataFile(path) if len(sys.argv) < 4 else getattr(simple, sys.argv[3])(FileName=path)
result = {"reader": reader.GetXMLName(), "times": list(reader.TimestepValues), "steps": []}
for t in result["times"]:
    reader.UpdatePipeline(t)
    data = servermanager.Fetch(reader)
    blocks = []
    it = data.NewIterator()
    it.InitTraversal()
    while not it.IsDoneWithTraversal():
        block = it.GetCurrentDataObject()
        wrapped = dsa.WrapDataObject(block)
        arrays = {}
        for i in range(block.GetPointData().GetNumberOfArrays()):
            name = block.GetPointData().GetArrayName(i)
            arrays[name] = wrapped.PointData[name].tolist()
        blocks.append({"points": block.GetNumberOfPoints(), "cells": block.GetNumberOfCells(),
                       "coordinates": wrapped.Points.tolist() if block.GetNumberOfPoints() else [],
                       "arrays": arrays})
        it.GoToNextItem()
    result["steps"].append(blocks)
with open(out, "w") as f:
    json.dump(result, f)
