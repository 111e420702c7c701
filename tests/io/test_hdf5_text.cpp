// Text in HDF5 files: fixed-length UTF-8 round trips; variable-length strings (kept in HDF5's
// global heap, whose corrupt references HDF5 1.10 follows unchecked), arrays and non-text are
// refused with the file and the object named.
#include "io/hdf5_text.hpp"
#include "io/hdf5_handle.hpp"
#include "io/trajectory.hpp"

#include <catch2/catch.hpp>

#include <unistd.h>

#include <filesystem>

using namespace fascia;
namespace fs = std::filesystem;

namespace {

struct ScratchFile {
  std::string path = (fs::temp_directory_path() / ("fascia_text_" + std::to_string(getpid()) + ".h5")).string();
  Handle file{H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose};
  ~ScratchFile() {
    file.reset();
    fs::remove(path);
  }
};

}  // namespace

TEST_CASE("text datasets and attributes round trip as fixed-length UTF-8", "[io]") {
  ScratchFile s;
  const std::string scene = "materials:\n  fascia: {young: 40 kPa}  # µ, é\n";
  write_text_dataset(s.file.get(), "scene", scene, s.path);
  write_text_dataset(s.file.get(), "empty", "", s.path);
  write_text_attribute(s.file.get(), "unit", "m/s", s.path);
  CHECK(read_text_dataset(s.file.get(), "scene", s.path) == scene);
  CHECK(read_text_dataset(s.file.get(), "empty", s.path).empty());
  CHECK(read_text_attribute(s.file.get(), "unit", s.path) == "m/s");
  Handle ds(H5Dopen2(s.file.get(), "scene", H5P_DEFAULT), H5Dclose);
  Handle type(H5Dget_type(ds.get()), H5Tclose);
  CHECK(H5Tis_variable_str(type.get()) == 0);
  CHECK(H5Tget_size(type.get()) == scene.size() + 1);
}

TEST_CASE("variable-length strings, arrays and numbers are refused as text", "[io]") {
  ScratchFile s;
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  {
    Handle type(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(type.get(), H5T_VARIABLE);
    Handle space(H5Screate(H5S_SCALAR), H5Sclose);
    Handle ds(H5Dcreate2(s.file.get(), "vlen", type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
              H5Dclose);
    const char* text = "abc";
    REQUIRE(H5Dwrite(ds.get(), type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, &text) >= 0);
  }
  {
    Handle type(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(type.get(), 4);
    const hsize_t n = 3;
    Handle space(H5Screate_simple(1, &n, nullptr), H5Sclose);
    Handle ds(H5Dcreate2(s.file.get(), "array", type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
              H5Dclose);
    const char text[3][4] = {"abc", "def", "ghi"};
    REQUIRE(H5Dwrite(ds.get(), type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, text) >= 0);
  }
  {
    Handle space(H5Screate(H5S_SCALAR), H5Sclose);
    Handle ds(H5Dcreate2(s.file.get(), "number", H5T_IEEE_F64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
              H5Dclose);
  }
  REQUIRE_THROWS_WITH(read_text_dataset(s.file.get(), "vlen", s.path),
                      Catch::Contains(s.path) && Catch::Contains("vlen is a variable-length string"));
  REQUIRE_THROWS_WITH(read_text_dataset(s.file.get(), "array", s.path),
                      Catch::Contains("array: holds 3, expected a scalar"));
  REQUIRE_THROWS_WITH(read_text_dataset(s.file.get(), "number", s.path), Catch::Contains("number is not text"));
  REQUIRE_THROWS_WITH(read_text_dataset(s.file.get(), "missing", s.path), Catch::Contains("cannot open missing"));
}
