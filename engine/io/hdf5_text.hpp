// Text in fascia's HDF5 files: scalar, fixed-length, null-terminated UTF-8 strings, as datasets
// (/parameters/*, /checkpoint/scene) and attributes (/h5md/creator name, units). Fixed length,
// not variable length: a variable-length string lives in HDF5's global heap, and HDF5 1.10 reads
// a corrupt heap reference without bounds checks (a crash in H5HG_read), while a fixed-length
// string is read as plain bytes of a size the reader checks. Readers refuse variable-length text.
#pragma once

#include <hdf5.h>

#include <string>

namespace fascia {

void write_text_dataset(hid_t parent, const std::string& name, const std::string& value, const std::string& path);
void write_text_attribute(hid_t object, const std::string& name, const std::string& value, const std::string& path);

// The text of a scalar fixed-length string dataset or attribute; throws TrajectoryError naming the
// file and the object for anything else (variable length, an array, another type, a size larger
// than the file).
std::string read_text_dataset(hid_t parent, const std::string& name, const std::string& path);
std::string read_text_attribute(hid_t object, const std::string& name, const std::string& path);

}  // namespace fascia
