#include "io/hdf5_text.hpp"

#include "io/hdf5_handle.hpp"
#include "io/hdf5_read.hpp"
#include "io/trajectory.hpp"

#include <cstring>
#include <vector>

namespace fascia {

namespace {

// A fixed-length, null-terminated UTF-8 string type of `size` bytes (terminator included).
Handle text_type(std::size_t size) {
  Handle t(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(t.get(), size);
  H5Tset_strpad(t.get(), H5T_STR_NULLTERM);
  H5Tset_cset(t.get(), H5T_CSET_UTF8);
  return t;
}

[[noreturn]] void fail(const std::string& path, const std::string& what) { throw TrajectoryError(path + ": " + what); }

// The size in bytes of the fixed-length string type `type` of object `what`.
std::size_t text_size(hid_t object, hid_t type, const std::string& path, const std::string& what) {
  if (type < 0 || H5Tget_class(type) != H5T_STRING)
    fail(path, what + " is not text (corrupt or not written by fascia)");
  if (H5Tis_variable_str(type) != 0)
    fail(path, what + " is a variable-length string, which fascia does not read (written by another program or an earlier fascia)");
  const std::size_t size = H5Tget_size(type);
  if (size == 0) fail(path, what + ": unreadable string size (corrupt)");
  check_fits_file(object, static_cast<double>(size), path, what);
  return size;
}

// The file's own string type (size, padding and character set; HDF5 converts between neither
// character sets nor, here, sizes): its bytes are copied as stored.
Handle memory_type(hid_t file_type) { return Handle(H5Tcopy(file_type), H5Tclose); }

std::string trimmed(std::vector<char>& buffer) {
  buffer.push_back('\0');
  return std::string(buffer.data(), std::strlen(buffer.data()));
}

}  // namespace

void write_text_dataset(hid_t parent, const std::string& name, const std::string& value, const std::string& path) {
  Handle type = text_type(value.size() + 1);
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  Handle ds(H5Dcreate2(parent, name.c_str(), type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose);
  if (!ds.valid()) fail(path, "HDF5 error: create dataset " + name);
  if (H5Dwrite(ds.get(), type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, value.c_str()) < 0)
    fail(path, "HDF5 error: write " + name);
}

void write_text_attribute(hid_t object, const std::string& name, const std::string& value, const std::string& path) {
  Handle type = text_type(value.size() + 1);
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  Handle attr(H5Acreate2(object, name.c_str(), type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!attr.valid()) fail(path, "HDF5 error: create attribute " + name);
  if (H5Awrite(attr.get(), type.get(), value.c_str()) < 0) fail(path, "HDF5 error: write attribute " + name);
}

std::string read_text_dataset(hid_t parent, const std::string& name, const std::string& path) {
  Handle ds(H5Dopen2(parent, name.c_str(), H5P_DEFAULT), H5Dclose);
  if (!ds.valid()) fail(path, "cannot open " + name);
  Handle file_type(H5Dget_type(ds.get()), H5Tclose);
  const std::size_t size = text_size(ds.get(), file_type.get(), path, name);
  std::vector<char> buffer(size, '\0');
  read_exact(ds.get(), memory_type(file_type.get()).get(), {}, buffer.data(), path, name);
  return trimmed(buffer);
}

std::string read_text_attribute(hid_t object, const std::string& name, const std::string& path) {
  Handle attr(H5Aopen(object, name.c_str(), H5P_DEFAULT), H5Aclose);
  if (!attr.valid()) fail(path, "cannot open attribute " + name);
  Handle file_type(H5Aget_type(attr.get()), H5Tclose);
  const std::size_t size = text_size(attr.get(), file_type.get(), path, "attribute " + name);
  std::vector<char> buffer(size, '\0');
  read_attribute_exact(attr.get(), memory_type(file_type.get()).get(), {}, buffer.data(), path, "attribute " + name);
  return trimmed(buffer);
}

}  // namespace fascia
