// Reads of HDF5 files that may be corrupt (a disk error, a truncated copy, a hostile file). HDF5
// trusts a file's dataspaces: H5Dread with H5S_ALL writes as many elements as the file's extent
// says, wherever the buffer ends. Every read here states the extent it expects, checks the file's
// against it before anything is allocated, and reads through a memory dataspace of that extent.
// Failures throw TrajectoryError naming the file and the object.
#pragma once

#include <hdf5.h>

#include <string>
#include <vector>

namespace fascia {

// The extent (dimensions) of a dataset or attribute's dataspace; {} for a scalar. Throws when the
// dataspace cannot be read or is neither simple nor scalar.
std::vector<hsize_t> dataset_extent(hid_t ds, const std::string& path, const std::string& what);
std::vector<hsize_t> attribute_extent(hid_t attr, const std::string& path, const std::string& what);

// Throws unless `bytes` fits in the file: fascia writes no compression and allocates every chunk,
// so a dataset holding more than the file's size is corrupt (its extent or type size).
void check_fits_file(hid_t object, double bytes, const std::string& path, const std::string& what);

// Reads the whole of `ds` into `out` as `mem_type`, once its extent equals `dims` ({} = scalar).
void read_exact(hid_t ds, hid_t mem_type, const std::vector<hsize_t>& dims, void* out, const std::string& path,
                const std::string& what);

// Reads the whole of attribute `attr` into `out` as `mem_type`, once its extent equals `dims`.
void read_attribute_exact(hid_t attr, hid_t mem_type, const std::vector<hsize_t>& dims, void* out,
                          const std::string& path, const std::string& what);

}  // namespace fascia
