// A table of results (one row per run, named columns of numbers or texts) as HDF5:
//   /results/<column>   [R] float64, or [R] variable-length UTF-8 strings
//   /results            attribute columns: the column names in order (one string, comma-separated)
// h5py reads each column as an array; pandas builds a DataFrame from them.
#pragma once

#include <string>
#include <vector>

namespace fascia {

struct TableColumn {
  std::string name;
  bool numeric = true;
  std::vector<double> numbers;     // numeric: one per row (NaN where unknown)
  std::vector<std::string> texts;  // otherwise: one per row
};

// Writes the table to a new file at `path` (replaced if present). Throws TrajectoryError.
void write_results_table(const std::string& path, const std::vector<TableColumn>& columns);

}  // namespace fascia
