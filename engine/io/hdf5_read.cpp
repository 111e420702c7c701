#include "io/hdf5_read.hpp"

#include "io/hdf5_handle.hpp"
#include "io/trajectory.hpp"

namespace fascia {

namespace {

[[noreturn]] void corrupt(const std::string& path, const std::string& what, const std::string& why) {
  throw TrajectoryError(path + ": " + what + ": " + why + " (corrupt or not written by fascia)");
}

std::string dims_text(const std::vector<hsize_t>& dims) {
  if (dims.empty()) return "a scalar";
  std::string s;
  for (hsize_t d : dims) s += (s.empty() ? "" : " x ") + std::to_string(d);
  return s;
}

std::vector<hsize_t> extent_of(hid_t space_id, const std::string& path, const std::string& what) {
  Handle space(space_id, H5Sclose);
  if (!space.valid()) corrupt(path, what, "unreadable dataspace");
  const H5S_class_t kind = H5Sget_simple_extent_type(space.get());
  if (kind == H5S_SCALAR) return {};
  if (kind != H5S_SIMPLE) corrupt(path, what, "neither a scalar nor an array");
  const int rank = H5Sget_simple_extent_ndims(space.get());
  if (rank < 0 || rank > H5S_MAX_RANK) corrupt(path, what, "unreadable rank");
  std::vector<hsize_t> dims(static_cast<std::size_t>(rank));
  if (rank > 0 && H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr) < 0)
    corrupt(path, what, "unreadable dimensions");
  return dims;
}

void check_dims(const std::vector<hsize_t>& found, const std::vector<hsize_t>& dims, const std::string& path,
                const std::string& what) {
  if (found != dims) corrupt(path, what, "holds " + dims_text(found) + ", expected " + dims_text(dims));
}

}  // namespace

std::vector<hsize_t> dataset_extent(hid_t ds, const std::string& path, const std::string& what) {
  return extent_of(H5Dget_space(ds), path, what);
}

std::vector<hsize_t> attribute_extent(hid_t attr, const std::string& path, const std::string& what) {
  return extent_of(H5Aget_space(attr), path, what);
}

void check_fits_file(hid_t object, double bytes, const std::string& path, const std::string& what) {
  Handle file(H5Iget_file_id(object), H5Fclose);
  hsize_t size = 0;
  if (!file.valid() || H5Fget_filesize(file.get(), &size) < 0) corrupt(path, what, "cannot tell the file's size");
  if (bytes > static_cast<double>(size))
    corrupt(path, what, "would hold " + std::to_string(static_cast<unsigned long long>(bytes)) + " bytes in a file of " +
                            std::to_string(size));
}

void read_exact(hid_t ds, hid_t mem_type, const std::vector<hsize_t>& dims, void* out, const std::string& path,
                const std::string& what) {
  check_dims(dataset_extent(ds, path, what), dims, path, what);
  Handle mspace(dims.empty() ? H5Screate(H5S_SCALAR) : H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr),
                H5Sclose);
  if (H5Dread(ds, mem_type, mspace.get(), H5S_ALL, H5P_DEFAULT, out) < 0) corrupt(path, what, "cannot be read");
}

void read_attribute_exact(hid_t attr, hid_t mem_type, const std::vector<hsize_t>& dims, void* out,
                          const std::string& path, const std::string& what) {
  check_dims(attribute_extent(attr, path, what), dims, path, what);
  if (H5Aread(attr, mem_type, out) < 0) corrupt(path, what, "cannot be read");
}

}  // namespace fascia
