#include "discretise/label_image.hpp"

#include <nifti2_io.h>
#include <teem/nrrd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <memory>
#include <sstream>

namespace fascia {

double LabelImage::voxel_volume() const { return std::abs(det(index_to_world)); }

long long LabelImage::count(const std::vector<int>& wanted) const {
  long long n = 0;
#pragma omp parallel for reduction(+ : n) schedule(static)
  for (long long v = 0; v < static_cast<long long>(labels.size()); ++v)
    n += std::find(wanted.begin(), wanted.end(), labels[static_cast<std::size_t>(v)]) != wanted.end() ? 1 : 0;
  return n;
}

std::vector<int> LabelImage::present() const {
  std::vector<int> out;
  std::vector<std::int32_t> sorted = labels;
  std::sort(sorted.begin(), sorted.end());
  sorted.erase(std::unique(sorted.begin(), sorted.end()), sorted.end());
  out.assign(sorted.begin(), sorted.end());
  return out;
}

namespace {

using Kind = LabelImageError::Kind;

[[noreturn]] void fail(const std::string& path, const std::string& what, Kind kind = Kind::bad_data) {
  throw LabelImageError(kind, path + ": " + what);
}

bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && std::equal(tail.rbegin(), tail.rend(), s.rbegin(),
                                               [](char a, char b) { return std::tolower(a) == b; });
}

void check_size(const std::string& path, const std::array<long long, 3>& size) {
  long double n = 1;
  for (long long s : size) {
    if (s < 1) fail(path, "the header gives a dimension of size " + std::to_string(s));
    n *= static_cast<long double>(s);
  }
  if (n > static_cast<long double>(kMaxLabelImageVoxels)) {
    std::ostringstream out;
    out << "the header gives " << size[0] << " x " << size[1] << " x " << size[2]
        << " voxels, more than the " << kMaxLabelImageVoxels << " accepted";
    fail(path, out.str());
  }
}

// Converts n values of type T to labels; floating-point values must be integers.
template <class T>
void convert(const std::string& path, const void* data, std::size_t n, std::vector<std::int32_t>& labels) {
  const T* values = static_cast<const T*>(data);
  labels.resize(n);
  long long bad = std::numeric_limits<long long>::max();  // first offending voxel
#pragma omp parallel for schedule(static) reduction(min : bad)
  for (long long v = 0; v < static_cast<long long>(n); ++v) {
    const T x = values[v];
    const double d = static_cast<double>(x);
    if (!(d == std::floor(d)) || d < std::numeric_limits<std::int32_t>::min() ||
        d > std::numeric_limits<std::int32_t>::max()) {
      bad = std::min(bad, v);
      continue;
    }
    labels[static_cast<std::size_t>(v)] = static_cast<std::int32_t>(x);
  }
  if (bad != std::numeric_limits<long long>::max()) {
    std::ostringstream out;
    out << "voxel " << bad << " (in file order) holds " << static_cast<double>(values[bad])
        << ", not a label: a label image holds integers within the 32-bit range";
    fail(path, out.str());
  }
}

double unit_scale_nifti(int units) {
  switch (units & 0x07) {
    case NIFTI_UNITS_METER: return 1.0;
    case NIFTI_UNITS_MICRON: return 1e-6;
    default: return 1e-3;  // millimetres, or unknown (the usual unit of medical images)
  }
}

LabelImage read_nifti(const std::string& path) {
  nifti_set_debug_level(0);
  std::unique_ptr<nifti_image, void (*)(nifti_image*)> nim(nifti_image_read(path.c_str(), 0), nifti_image_free);
  if (!nim) fail(path, "not a readable NIfTI-1 or NIfTI-2 header");
  for (int d = 4; d <= std::min<long long>(nim->dim[0], 7); ++d)
    if (nim->dim[d] > 1)
      fail(path, "has " + std::to_string(nim->dim[0]) + " dimensions with size " + std::to_string(nim->dim[d]) +
                     " along dimension " + std::to_string(d) + "; a label image has 3");
  LabelImage image;
  image.size = {nim->nx, nim->dim[0] >= 2 ? nim->ny : 1, nim->dim[0] >= 3 ? nim->nz : 1};
  check_size(path, image.size);
  if (nim->scl_slope != 0 && (nim->scl_slope != 1 || nim->scl_inter != 0))
    fail(path, "scales its values (scl_slope " + std::to_string(nim->scl_slope) + ", scl_inter " +
                   std::to_string(nim->scl_inter) + "); a label image stores the labels themselves");
  const nifti_dmat44& m = nim->sform_code > 0 ? nim->sto_xyz : nim->qto_xyz;
  const double unit = unit_scale_nifti(nim->xyz_units);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) image.index_to_world.m[r][c] = unit * m.m[r][c];
  image.origin = Vec3{unit * m.m[0][3], unit * m.m[1][3], unit * m.m[2][3]};

  switch (nim->datatype) {
    case NIFTI_TYPE_INT8: case NIFTI_TYPE_UINT8: case NIFTI_TYPE_INT16: case NIFTI_TYPE_UINT16:
    case NIFTI_TYPE_INT32: case NIFTI_TYPE_UINT32: case NIFTI_TYPE_INT64: case NIFTI_TYPE_UINT64:
    case NIFTI_TYPE_FLOAT32: case NIFTI_TYPE_FLOAT64: break;
    default:
      fail(path, std::string("holds ") + nifti_datatype_string(nim->datatype) +
                     " voxels; a label image holds integers (or integral floating-point values)");
  }
  // nifti_image_load allocates the header's size before reading: a header asking for more data
  // than its file can hold is refused first. A gzip file inflates at most 1032-fold (DEFLATE's
  // largest ratio), so a compressed image is held to that bound.
  std::error_code ec;
  const std::string image_file = nim->iname ? nim->iname : path;
  const double file_bytes = static_cast<double>(std::filesystem::file_size(image_file, ec));
  const bool gzip = image_file.size() > 3 && image_file.compare(image_file.size() - 3, 3, ".gz") == 0;
  const double needed = static_cast<double>(nim->iname_offset) +
                        static_cast<double>(image.voxel_count()) * static_cast<double>(nim->nbyper);
  if (!ec && needed > file_bytes * (gzip ? 1032.0 : 1.0))
    fail(path, "the header asks for " + std::to_string(static_cast<long long>(needed)) + " bytes of voxel data, the " +
                   (gzip ? "compressed " : "") + "file holds " + std::to_string(static_cast<long long>(file_bytes)) +
                   " (truncated or corrupt file?)");
  if (nifti_image_load(nim.get()) != 0 || nim->data == nullptr)
    fail(path, "the voxel data cannot be read (truncated or corrupt file?)");
  const std::size_t n = static_cast<std::size_t>(image.voxel_count());
  switch (nim->datatype) {
    case NIFTI_TYPE_INT8: convert<std::int8_t>(path, nim->data, n, image.labels); break;
    case NIFTI_TYPE_UINT8: convert<std::uint8_t>(path, nim->data, n, image.labels); break;
    case NIFTI_TYPE_INT16: convert<std::int16_t>(path, nim->data, n, image.labels); break;
    case NIFTI_TYPE_UINT16: convert<std::uint16_t>(path, nim->data, n, image.labels); break;
    case NIFTI_TYPE_INT32: convert<std::int32_t>(path, nim->data, n, image.labels); break;
    case NIFTI_TYPE_UINT32: convert<std::uint32_t>(path, nim->data, n, image.labels); break;
    case NIFTI_TYPE_INT64: convert<std::int64_t>(path, nim->data, n, image.labels); break;
    case NIFTI_TYPE_UINT64: convert<std::uint64_t>(path, nim->data, n, image.labels); break;
    case NIFTI_TYPE_FLOAT32: convert<float>(path, nim->data, n, image.labels); break;
    default: convert<double>(path, nim->data, n, image.labels); break;
  }
  return image;
}

struct NrrdFree {
  void operator()(Nrrd* n) const { nrrdNuke(n); }
};

std::string biff_message() {
  char* err = biffGetDone(NRRD);
  std::string text = err ? err : "";
  std::free(err);
  while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
  return text;
}

double unit_scale_nrrd(const char* unit) {
  if (unit == nullptr) return 1e-3;
  const std::string u(unit);
  if (u == "m") return 1.0;
  if (u == "um" || u == "micron") return 1e-6;
  return 1e-3;
}

LabelImage read_nrrd(const std::string& path) {
  std::unique_ptr<Nrrd, NrrdFree> header(nrrdNew());
  NrrdIoState* nio = nrrdIoStateNew();
  nio->skipData = AIR_TRUE;
  const int header_status = nrrdLoad(header.get(), path.c_str(), nio);
  nrrdIoStateNix(nio);
  if (header_status) fail(path, "not a readable NRRD header: " + biff_message());
  // Axes of size 1 (a leading list axis of a one-layer .seg.nrrd) are dropped.
  std::vector<unsigned> axes;
  for (unsigned a = 0; a < header->dim; ++a)
    if (header->axis[a].size > 1) axes.push_back(a);
  if (axes.size() > 3)
    fail(path, "has " + std::to_string(axes.size()) +
                   " axes of size > 1 (a .seg.nrrd with overlapping segments stores one layer per segment); a "
                   "label image has 3");
  while (axes.size() < 3) {  // pad with size-1 axes so that thin images keep a direction
    unsigned a = 0;
    while (a < header->dim && std::find(axes.begin(), axes.end(), a) != axes.end()) ++a;
    if (a >= header->dim) fail(path, "has fewer than 3 axes");
    axes.push_back(a);
  }
  std::sort(axes.begin(), axes.end());
  LabelImage image;
  for (int d = 0; d < 3; ++d) image.size[d] = static_cast<long long>(header->axis[axes[d]].size);
  check_size(path, image.size);
  if (header->type == nrrdTypeBlock || header->type == nrrdTypeUnknown)
    fail(path, "holds block voxels; a label image holds integers (or integral floating-point values)");

  if (header->spaceDim == 3) {
    const bool lps = header->space == nrrdSpaceLeftPosteriorSuperior || header->space == nrrdSpaceLeftPosteriorSuperiorTime;
    const bool las = header->space == nrrdSpaceLeftAnteriorSuperior || header->space == nrrdSpaceLeftAnteriorSuperiorTime;
    const double flip[3] = {(lps || las) ? -1.0 : 1.0, lps ? -1.0 : 1.0, 1.0};
    for (int d = 0; d < 3; ++d) {
      const double* dir = header->axis[axes[d]].spaceDirection;
      const double unit = unit_scale_nrrd(header->spaceUnits[d]);
      for (int r = 0; r < 3; ++r) image.index_to_world.m[r][d] = std::isnan(dir[r]) ? 0.0 : flip[r] * unit * dir[r];
    }
    double o[3];
    for (int r = 0; r < 3; ++r) {
      const double unit = unit_scale_nrrd(header->spaceUnits[r]);
      o[r] = std::isnan(header->spaceOrigin[r]) ? 0.0 : flip[r] * unit * header->spaceOrigin[r];
    }
    image.origin = Vec3{o[0], o[1], o[2]};
  } else if (header->spaceDim == 0) {
    for (int d = 0; d < 3; ++d) {
      const double s = header->axis[axes[d]].spacing;
      image.index_to_world.m[d][d] = 1e-3 * (std::isnan(s) ? 1.0 : std::abs(s));
    }
  } else {
    fail(path, "has a " + std::to_string(header->spaceDim) + "-dimensional space; a label image lives in 3D");
  }
  // A size-1 padding axis has no direction in the file: give it the normal of the other two.
  for (int d = 0; d < 3; ++d) {
    const Vec3 col{image.index_to_world.m[0][d], image.index_to_world.m[1][d], image.index_to_world.m[2][d]};
    if (norm(col) > 0) continue;
    auto column = [&](int c) {
      return Vec3{image.index_to_world.m[0][c], image.index_to_world.m[1][c], image.index_to_world.m[2][c]};
    };
    const Vec3 a = column((d + 1) % 3), b = column((d + 2) % 3);
    const Vec3 n = cross(a, b);
    const double len = norm(n);
    if (len > 0) {
      const Vec3 c = (std::sqrt(std::max(norm(a), norm(b)) * std::min(norm(a), norm(b))) / len) * n;
      image.index_to_world.m[0][d] = c.x, image.index_to_world.m[1][d] = c.y, image.index_to_world.m[2][d] = c.z;
    }
  }

  std::unique_ptr<Nrrd, NrrdFree> nrrd(nrrdNew());
  if (nrrdLoad(nrrd.get(), path.c_str(), nullptr))
    fail(path, "the voxel data cannot be read (truncated or corrupt file?): " + biff_message());
  const std::size_t n = static_cast<std::size_t>(image.voxel_count());
  if (nrrdElementNumber(nrrd.get()) != n) fail(path, "the voxel data does not match the header's sizes");
  const void* data = nrrd->data;
  switch (nrrd->type) {
    case nrrdTypeChar: convert<signed char>(path, data, n, image.labels); break;
    case nrrdTypeUChar: convert<unsigned char>(path, data, n, image.labels); break;
    case nrrdTypeShort: convert<short>(path, data, n, image.labels); break;
    case nrrdTypeUShort: convert<unsigned short>(path, data, n, image.labels); break;
    case nrrdTypeInt: convert<int>(path, data, n, image.labels); break;
    case nrrdTypeUInt: convert<unsigned int>(path, data, n, image.labels); break;
    case nrrdTypeLLong: convert<long long>(path, data, n, image.labels); break;
    case nrrdTypeULLong: convert<unsigned long long>(path, data, n, image.labels); break;
    case nrrdTypeFloat: convert<float>(path, data, n, image.labels); break;
    case nrrdTypeDouble: convert<double>(path, data, n, image.labels); break;
    default: fail(path, "holds voxels of an unsupported type");
  }
  return image;
}

}  // namespace

LabelImage read_label_image(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) fail(path, "no such file", Kind::missing_input);
  LabelImage image;
  if (ends_with(path, ".nii") || ends_with(path, ".nii.gz") || ends_with(path, ".hdr") || ends_with(path, ".img") ||
      ends_with(path, ".hdr.gz") || ends_with(path, ".img.gz"))
    image = read_nifti(path);
  else if (ends_with(path, ".nrrd") || ends_with(path, ".nhdr"))
    image = read_nrrd(path);
  else
    fail(path, "unknown label image format: expected .nii, .nii.gz, .hdr/.img (NIfTI), .nrrd, .seg.nrrd or .nhdr (NRRD)");
  if (!(image.voxel_volume() > 0)) fail(path, "the index-to-world map is singular (zero voxel size or parallel axes)");
  return image;
}

}  // namespace fascia
