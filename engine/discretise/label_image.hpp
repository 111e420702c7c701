// Label images: segmentations stored as a 3D grid of integer labels (0 = background by custom)
// with the affine map from voxel index to world position.
//
// Formats and libraries (Debian 12):
// - NIfTI-1 and NIfTI-2 (.nii, .nii.gz, .hdr/.img) through nifticlib's nifti2 library
//   (libnifti2-dev 3.0.1), the NIfTI reference implementation, which reads both versions;
// - NRRD (.nrrd, .nhdr, Slicer's .seg.nrrd) through teem's nrrd library (libteem-dev 1.12), the
//   NRRD reference implementation.
// Both are small C libraries; ITK reads both too but pulls in a toolkit many times fascia's size.
//
// World axes. Positions are in metres in the RAS+ frame of NIfTI (+x towards the patient's
// right, +y anterior, +z superior). NIfTI:
// the sform when sform_code > 0, else the qform (qform_code > 0), else the voxel sizes alone
// (nifticlib's "method 1"); xyz_units metre, millimetre or micron, unknown read as millimetres.
// NRRD: space directions and space origin; a left-posterior-superior (LPS, DICOM's) space is
// turned to RAS by negating x and y; without a space, axis spacings; space units "m", "mm",
// "um" or none (millimetres).
#pragma once

#include "core/small_math.hpp"

#include <array>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace fascia {

class LabelImageError : public std::runtime_error {
 public:
  enum class Kind { missing_input, bad_data };
  LabelImageError(Kind kind, const std::string& message) : std::runtime_error(message), m_kind(kind) {}
  Kind kind() const { return m_kind; }

 private:
  Kind m_kind;
};

struct LabelImage {
  std::array<long long, 3> size{0, 0, 0};  // voxels along i, j, k
  std::vector<std::int32_t> labels;        // [k][j][i]: index i + size[0] * (j + size[1] * k)
  // World position of the centre of voxel (i, j, k): index_to_world * (i, j, k) + origin, m.
  // The columns of index_to_world are the voxel edge vectors (m); it may be oblique and
  // anisotropic, and has a non-zero determinant.
  Mat3 index_to_world = identity3();
  Vec3 origin{0, 0, 0};

  long long voxel_count() const { return size[0] * size[1] * size[2]; }
  std::int32_t at(long long i, long long j, long long k) const {
    return labels[static_cast<std::size_t>(i + size[0] * (j + size[1] * k))];
  }
  // |det index_to_world|, m^3.
  double voxel_volume() const;
  // Number of voxels holding each of `wanted`.
  long long count(const std::vector<int>& wanted) const;
  // Sorted distinct labels present.
  std::vector<int> present() const;
};

// The largest image accepted, in voxels (2^30: 4 GiB of 32-bit labels). Headers asking for more
// are rejected before any data is read.
constexpr long long kMaxLabelImageVoxels = 1LL << 30;

// Reads a NIfTI (.nii, .nii.gz, .hdr, .img) or NRRD (.nrrd, .nhdr, .seg.nrrd) label image,
// chosen by extension. Accepts integer voxel types, and floating-point voxels whose values are
// all integers (some tools write labels as float). Throws LabelImageError naming the file:
// missing_input when the file does not exist; bad_data for an unknown extension, a header the
// library rejects, more than 3 dimensions of size > 1, more than kMaxLabelImageVoxels voxels,
// truncated data, scaled values (NIfTI scl_slope/scl_inter), non-integer values, labels outside
// the 32-bit range, or a singular index-to-world map.
LabelImage read_label_image(const std::string& path);

}  // namespace fascia
