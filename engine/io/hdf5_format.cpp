#include "io/hdf5_format.hpp"

#include "io/trajectory.hpp"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <fstream>

namespace fascia {

namespace {

// HDF5 format specification 3.0, II.A: the signature, then the superblock version byte.
constexpr std::array<unsigned char, 8> kSignature = {0x89, 'H', 'D', 'F', '\r', '\n', 0x1a, '\n'};
// Superblock versions 2 and 3 carry a checksum (and go with version 2 object headers).
constexpr int kFirstChecksummedSuperblock = 2;

}  // namespace

void set_checksummed_format(hid_t fapl, const std::string& path) {
  if (H5Pset_libver_bounds(fapl, H5F_LIBVER_V18, H5F_LIBVER_V18) < 0)
    throw TrajectoryError(path + ": HDF5 refused the 1.8 file format");
}

namespace {

// The most links a group's object header may hold (H5Pset_link_phase_change's limit): groups
// never turn dense.
constexpr unsigned kMaxCompactLinks = 65535;

Handle compact_links(hid_t plist_class, const std::string& path) {
  Handle plist(H5Pcreate(plist_class), H5Pclose);
  if (!plist.valid() || H5Pset_link_phase_change(plist.get(), kMaxCompactLinks, kMaxCompactLinks) < 0)
    throw TrajectoryError(path + ": HDF5 refused compact link storage");
  return plist;
}

}  // namespace

Handle file_creation_properties(const std::string& path) { return compact_links(H5P_FILE_CREATE, path); }

Handle group_creation_properties(const std::string& path) { return compact_links(H5P_GROUP_CREATE, path); }

void require_checksummed_format(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw TrajectoryError(path + ": cannot open: " + std::strerror(errno));
  std::array<unsigned char, kSignature.size() + 1> head{};
  in.read(reinterpret_cast<char*>(head.data()), static_cast<std::streamsize>(head.size()));
  if (in.gcount() != static_cast<std::streamsize>(head.size()) ||
      !std::equal(kSignature.begin(), kSignature.end(), head.begin()))
    throw TrajectoryError(path + ": not an HDF5 file (no HDF5 signature at its start)");
  const int version = head[kSignature.size()];
  if (version < kFirstChecksummedSuperblock)
    throw TrajectoryError(path + ": HDF5 superblock version " + std::to_string(version) +
                          ", a format without metadata checksums (written by an older fascia, or by another "
                          "program in HDF5's default format); fascia reads only files whose metadata carries "
                          "checksums (superblock version 2 or later): run the scene again with this fascia "
                          "(h5py still reads the old file)");
}

}  // namespace fascia
