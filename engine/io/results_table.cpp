#include "io/results_table.hpp"

#include "io/hdf5_handle.hpp"
#include "io/trajectory.hpp"

#include <hdf5.h>

namespace fascia {

void write_results_table(const std::string& path, const std::vector<TableColumn>& columns) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  auto fail = [&path](const std::string& what) { throw TrajectoryError(path + ": HDF5 error: " + what); };
  Handle file(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose);
  if (!file.valid()) fail("cannot create file");
  Handle group(H5Gcreate2(file.get(), "results", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
  if (!group.valid()) fail("create /results");
  Handle text(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(text.get(), H5T_VARIABLE);
  H5Tset_cset(text.get(), H5T_CSET_UTF8);
  std::string names;
  for (const TableColumn& c : columns) {
    names += (names.empty() ? "" : ",") + c.name;
    const hsize_t rows = c.numeric ? c.numbers.size() : c.texts.size();
    Handle space(H5Screate_simple(1, &rows, nullptr), H5Sclose);
    Handle ds(H5Dcreate2(group.get(), c.name.c_str(), c.numeric ? H5T_IEEE_F64LE : text.get(), space.get(), H5P_DEFAULT,
                         H5P_DEFAULT, H5P_DEFAULT),
              H5Dclose);
    if (!ds.valid()) fail("create column " + c.name);
    if (rows == 0) continue;
    herr_t status = 0;
    if (c.numeric) {
      status = H5Dwrite(ds.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, c.numbers.data());
    } else {
      std::vector<const char*> data;
      for (const std::string& s : c.texts) data.push_back(s.c_str());
      status = H5Dwrite(ds.get(), text.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, data.data());
    }
    if (status < 0) fail("write column " + c.name);
  }
  Handle type(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(type.get(), names.size() + 1);
  Handle scalar(H5Screate(H5S_SCALAR), H5Sclose);
  Handle attr(H5Acreate2(group.get(), "columns", type.get(), scalar.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!attr.valid() || H5Awrite(attr.get(), type.get(), names.c_str()) < 0) fail("write the column names");
  if (H5Fflush(file.get(), H5F_SCOPE_GLOBAL) < 0) fail("flush");
}

}  // namespace fascia
