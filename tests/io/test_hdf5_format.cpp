// fascia's HDF5 format (io/hdf5_format.hpp): files are written with checksummed metadata, readers
// refuse files without it before HDF5 decodes them, and a damaged byte of metadata is refused by
// HDF5's checksum instead of being decoded.
#include "io/checkpoint.hpp"
#include "io/hdf5_format.hpp"
#include "io/hdf5_handle.hpp"
#include "io/trajectory.hpp"

#include <catch2/catch.hpp>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

using namespace fascia;
namespace fs = std::filesystem;

namespace {

std::string scratch(const std::string& name) {
  return (fs::temp_directory_path() / ("fascia_format_" + std::to_string(getpid()) + "_" + name)).string();
}

std::string bytes_of(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_bytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

// A one-frame trajectory with one step, written by the writer.
void write_trajectory(const std::string& path, const std::string& version) {
  TrajectoryHeader header;
  header.creator_version = version;
  TrajectoryLayout layout;
  layout.frames = 1;
  // More links in /observables than HDF5 keeps compact by default (8).
  for (int i = 0; i < 12; ++i) layout.observables.emplace_back("observable_" + std::to_string(i), false);
  TrajectoryWriter writer(path, header, layout);
  const double x[3] = {0, 0, 0}, q[4] = {1, 0, 0, 0};
  TrajectoryStep step;
  step.frame_positions = x;
  step.frame_orientations = q;
  step.observables.assign(12, 0.5);
  writer.append(step);
  writer.close();
}

}  // namespace

TEST_CASE("trajectories are written with a checksummed superblock and read back", "[io]") {
  const std::string path = scratch("written.h5");
  write_trajectory(path, "7.5.3");
  const std::string bytes = bytes_of(path);
  REQUIRE(bytes.size() > 9);
  CHECK(bytes[8] == 2);  // superblock version 2: the HDF5 1.8 format
  CHECK_NOTHROW(require_checksummed_format(path));
  {
    // Every link in its group's (checksummed) object header, none in dense storage.
    Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
    REQUIRE(file.valid());
    for (const char* group : {"/", "/observables", "/particles/frames"}) {
      H5G_info_t info;
      REQUIRE(H5Gget_info_by_name(file.get(), group, &info, H5P_DEFAULT) >= 0);
      CHECK(info.storage_type == H5G_STORAGE_TYPE_COMPACT);
    }
    H5G_info_t observables;
    REQUIRE(H5Gget_info_by_name(file.get(), "/observables", &observables, H5P_DEFAULT) >= 0);
    CHECK(observables.nlinks == 12);
  }
  const TrajectoryReader reader(path);
  CHECK(reader.creator_version() == "7.5.3");
  CHECK(reader.step_count() == 1);
  CHECK(reader.observable_names().size() == 12);
  fs::remove(path);
}

TEST_CASE("files without metadata checksums are refused before HDF5 decodes them", "[io]") {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  const std::string path = scratch("default_format.h5");
  {
    // HDF5's default format (superblock version 0, version 1 object headers): that of older
    // fascia files.
    Handle file(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose);
    REQUIRE(file.valid());
    Handle group(H5Gcreate2(file.get(), "h5md", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
  }
  REQUIRE(bytes_of(path)[8] == 0);
  const auto old_format = Catch::Contains(path + ": HDF5 superblock version 0, a format without metadata checksums");
  CHECK_THROWS_WITH(require_checksummed_format(path), old_format);
  CHECK_THROWS_AS(TrajectoryReader(path), TrajectoryError);
  CHECK_THROWS_WITH(TrajectoryReader(path), old_format);
  CHECK_THROWS_WITH(read_checkpoint(path), old_format);
  CHECK_THROWS_WITH(TrajectoryWriter(path, TrajectoryLayout{}, 1), old_format);  // --resume

  write_bytes(path, "fascia: 1\n");
  CHECK_THROWS_WITH(TrajectoryReader(path), Catch::Contains(path + ": not an HDF5 file"));
  write_bytes(path, "");
  CHECK_THROWS_WITH(require_checksummed_format(path), Catch::Contains("not an HDF5 file"));
  fs::remove(path);
  CHECK_THROWS_WITH(require_checksummed_format(path), Catch::Contains(path + ": cannot open: No such file"));
}

TEST_CASE("a damaged byte of an object header is refused by its checksum, not decoded", "[io]") {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  const std::string path = scratch("damaged.h5");
  write_trajectory(path, "7.5.3");
  std::string bytes = bytes_of(path);
  // The creator version is an attribute of /h5md/creator, stored inside that group's object
  // header (and a copy in /parameters/version, raw data).
  int damaged = 0;
  for (std::size_t at = bytes.find("7.5.3"); at != std::string::npos; at = bytes.find("7.5.3", at + 1), ++damaged)
    bytes[at] = '9';
  REQUIRE(damaged > 0);
  write_bytes(path, bytes);
  // Without checksums the reader would return "9.5.3".
  CHECK_THROWS_AS(TrajectoryReader(path).creator_version(), TrajectoryError);
  fs::remove(path);
}
