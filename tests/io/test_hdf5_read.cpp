// Sized reads of HDF5 files: a dataset or attribute whose extent differs from the caller's buffer
// is refused before anything is read (H5S_ALL would write past the buffer), naming the file, the
// object and both extents; a size beyond the file is refused before anything is allocated.
#include "io/hdf5_read.hpp"
#include "io/hdf5_handle.hpp"
#include "io/trajectory.hpp"

#include <catch2/catch.hpp>

#include <unistd.h>

#include <filesystem>

using namespace fascia;
namespace fs = std::filesystem;

TEST_CASE("reads of a wrong extent are refused, reads of the expected one succeed", "[io]") {
  const std::string path = (fs::temp_directory_path() / ("fascia_read_" + std::to_string(getpid()) + ".h5")).string();
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  {
    Handle file(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose);
    const hsize_t n = 6;
    Handle space(H5Screate_simple(1, &n, nullptr), H5Sclose);
    Handle ds(H5Dcreate2(file.get(), "commit", H5T_STD_I64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
              H5Dclose);
    const long long values[6] = {1, 2, 3, 4, 5, 6};
    REQUIRE(H5Dwrite(ds.get(), H5T_NATIVE_LLONG, H5S_ALL, H5S_ALL, H5P_DEFAULT, values) >= 0);
    Handle attr(H5Acreate2(ds.get(), "frames", H5T_STD_I32LE, space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
    const int ints[6] = {7, 8, 9, 10, 11, 12};
    REQUIRE(H5Awrite(attr.get(), H5T_NATIVE_INT, ints) >= 0);
  }
  Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  Handle ds(H5Dopen2(file.get(), "commit", H5P_DEFAULT), H5Dclose);
  Handle attr(H5Aopen(ds.get(), "frames", H5P_DEFAULT), H5Aclose);

  long long two[2 + 1] = {0, 0, -99};  // the guard element stays untouched
  REQUIRE_THROWS_WITH(read_exact(ds.get(), H5T_NATIVE_LLONG, {2}, two, path, "commit"),
                      Catch::Contains(path + ": commit: holds 6, expected 2"));
  CHECK(two[0] == 0);
  CHECK(two[2] == -99);
  REQUIRE_THROWS_WITH(read_exact(ds.get(), H5T_NATIVE_LLONG, {}, two, path, "commit"),
                      Catch::Contains("holds 6, expected a scalar"));
  long long six[6] = {};
  read_exact(ds.get(), H5T_NATIVE_LLONG, {6}, six, path, "commit");
  CHECK(six[5] == 6);

  int one = 0;
  REQUIRE_THROWS_WITH(read_attribute_exact(attr.get(), H5T_NATIVE_INT, {}, &one, path, "frames"),
                      Catch::Contains("frames: holds 6, expected a scalar"));
  CHECK(one == 0);
  int ints[6] = {};
  read_attribute_exact(attr.get(), H5T_NATIVE_INT, {6}, ints, path, "frames");
  CHECK(ints[0] == 7);

  CHECK(dataset_extent(ds.get(), path, "commit") == std::vector<hsize_t>{6});
  CHECK_NOTHROW(check_fits_file(ds.get(), 48, path, "commit"));
  REQUIRE_THROWS_WITH(check_fits_file(ds.get(), 1e15, path, "commit"),
                      Catch::Contains("would hold 1000000000000000 bytes in a file of"));
  attr.reset();
  ds.reset();
  file.reset();
  fs::remove(path);
}
