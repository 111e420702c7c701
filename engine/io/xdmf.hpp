// XDMF 3 sidecar of a trajectory, so that ParaView (5.11) opens it as a time series: a temporal
// collection with, per written step, a spatial collection of the object surfaces (triangles or
// quadrilaterals, /connectivity) and the frames and samples as point clouds, each reading its
// hyperslab of the HDF5 datasets.
#pragma once

#include "io/trajectory.hpp"

#include <string>
#include <vector>

namespace fascia {

// The XDMF text for the complete steps at `times`; `h5_name` is the HDF5 file as seen from the
// sidecar's folder (its file name: they sit side by side); `rows` is the datasets' current length
// in time (preallocated rows while a run writes; 0 = times.size()).
std::string xdmf_text(const std::string& h5_name, const TrajectoryLayout& layout, const std::vector<double>& times,
                      std::size_t rows = 0);

// Writes the sidecar atomically (temporary file, then rename), so that it is valid at any moment.
// Throws TrajectoryError on I/O failure.
void write_xdmf(const std::string& xmf_path, const std::string& h5_name, const TrajectoryLayout& layout,
                const std::vector<double>& times, std::size_t rows = 0);

// "run.h5" -> "run.xmf".
std::string xdmf_path_for(const std::string& h5_path);

}  // namespace fascia
