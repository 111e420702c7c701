// XDMF sidecars of a trajectory, so that ParaView opens it as a time series: a temporal collection
// with, per written step, a spatial collection of the object surfaces (triangles or
// quadrilaterals, /connectivity) and the frames and samples as point clouds, each with its
// per-particle fields (layout.fields) as node attributes: scalars, vectors and 3 x 3 tensors.
//
// Every array reads row k of a [T][n][...] dataset. XDMF has two ways to say so, and ParaView 5.11
// reads each with one reader only:
//  * `run.xmf` (Xdmf3 dialect): the selection inside the HDF item, `file.h5:/path|start:stride:
//    count:dims` (the Xdmf3 library's heavy-data description). ParaView's default reader for .xmf
//    (Xdmf3ReaderS) and Xdmf3ReaderT read it; the Xdmf3 readers return 0 points for HyperSlab
//    DataItems.
//  * `run.xmf2` (XDMF 2 dialect): standard HyperSlab DataItems. ParaView opens .xmf2 with the
//    legacy "XDMF Reader" (vtkXdmfReader), which does not understand the Xdmf3 description.
#pragma once

#include "io/trajectory.hpp"

#include <string>
#include <vector>

namespace fascia {

enum class XdmfDialect { xdmf3, xdmf2 };

// The XDMF text for the complete steps at `times`; `h5_name` is the HDF5 file as seen from the
// sidecar's folder (its file name: they sit side by side); `rows` is the datasets' current length
// in time (preallocated rows while a run writes; 0 = times.size()).
std::string xdmf_text(const std::string& h5_name, const TrajectoryLayout& layout, const std::vector<double>& times,
                      std::size_t rows = 0, XdmfDialect dialect = XdmfDialect::xdmf3);

// Writes both sidecars (xmf_path in the Xdmf3 dialect, xmf_path + "2" in the XDMF 2 dialect)
// atomically (temporary file, then rename), so that each is valid at any moment. Throws
// TrajectoryError on I/O failure.
void write_xdmf(const std::string& xmf_path, const std::string& h5_name, const TrajectoryLayout& layout,
                const std::vector<double>& times, std::size_t rows = 0);

// "run.h5" -> "run.xmf" (the XDMF 2 sidecar is that name + "2").
std::string xdmf_path_for(const std::string& h5_path);

}  // namespace fascia
