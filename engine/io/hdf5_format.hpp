// The HDF5 file format of fascia's files: metadata with checksums.
//
// Files are written in the HDF5 1.8 format (H5Pset_libver_bounds(V18, V18); readable by HDF5 1.8
// and later: h5py, ParaView): superblock version 2 and version 2 object headers (datatypes,
// dataspaces, attributes, links), each with a Jenkins lookup3 checksum that HDF5 verifies before
// decoding it. A damaged byte of that metadata is then an error instead of garbage decoded: HDF5
// 1.10.8 decodes the metadata of the default format (superblock 0, version 1 object headers)
// unchecked, and a corrupt attribute message overflows a heap buffer inside H5Aopen. Not the 1.10
// format: its superblock (version 3) records that the file is open for writing, and HDF5 refuses
// to open a file whose writer was killed until that flag is cleared (h5clear), which would make a
// killed run unreadable.
// Groups keep their links in their object header however many they hold ("compact" storage):
// HDF5 moves a group of more than 8 links by default to "dense" storage, a fractal heap whose
// blocks HDF5 1.10.8 decodes without a checksum (a damaged link name there freed a wild pointer
// in H5G__link_release_table). The chunk indexes of the 1.8 format (version 1 B-trees) and raw
// data carry no checksum; readers check extents and values themselves (io/hdf5_read.hpp).
#pragma once

#include "io/hdf5_handle.hpp"

#include <hdf5.h>

#include <string>

namespace fascia {

// Sets the format above on a file-access property list (for H5Fcreate and H5Fopen for writing).
// Throws TrajectoryError naming path if HDF5 refuses.
void set_checksummed_format(hid_t fapl, const std::string& path);

// Creation properties for the file (its root group) and for every group: links kept compact.
// Throws TrajectoryError naming path if HDF5 refuses.
Handle file_creation_properties(const std::string& path);
Handle group_creation_properties(const std::string& path);

// Refuses, before HDF5 decodes anything of it, a file that is not HDF5 or whose superblock has no
// checksum (version 0 or 1: written by an older fascia or in HDF5's default format), reading the
// signature and superblock version at byte 0 (fascia writes no user block). Throws TrajectoryError
// naming path and the version found.
void require_checksummed_format(const std::string& path);

}  // namespace fascia
