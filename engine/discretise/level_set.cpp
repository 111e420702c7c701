#include "discretise/level_set.hpp"

#include "discretise/voxel_module.hpp"

#include <stdexcept>

namespace fascia {

LevelSet::LevelSet(std::unique_ptr<Impl> impl) : m_impl(std::move(impl)) {}
LevelSet::~LevelSet() = default;
LevelSet::LevelSet(LevelSet&&) noexcept = default;
LevelSet& LevelSet::operator=(LevelSet&&) noexcept = default;

LevelSet LevelSet::from_labels(const LabelImage& image, const std::vector<int>& labels, double voxel_size,
                               int half_width) {
  if (!(voxel_size > 0)) throw std::invalid_argument("voxel size must be positive");
  if (labels.empty()) throw std::invalid_argument("no label selected");
  return LevelSet(voxel_module().from_labels(image, labels, voxel_size, half_width));
}

LevelSet LevelSet::from_surface(const SurfaceMesh& surface, double voxel_size, int half_width) {
  if (!(voxel_size > 0)) throw std::invalid_argument("voxel size must be positive");
  if (surface.triangle_count() == 0) throw std::invalid_argument("cannot voxelise an empty surface");
  return LevelSet(voxel_module().from_surface(surface, voxel_size, half_width));
}

LevelSet LevelSet::between(const LevelSet& a, const LevelSet& b, double within,
                           const std::function<double(const Vec3&)>& region) {
  return LevelSet(voxel_module().between(*a.m_impl, *b.m_impl, within, region));
}

int LevelSet::smoothing_band(double standard_deviation, double voxel_size) {
  return voxel_module().smoothing_band(standard_deviation, voxel_size);
}

double LevelSet::smooth(double standard_deviation) { return m_impl->smooth(standard_deviation); }
double LevelSet::voxel_size() const { return m_impl->voxel_size(); }
double LevelSet::band() const { return m_impl->band(); }
Vec3 LevelSet::gradient(const Vec3& x) const { return m_impl->gradient(x); }
double LevelSet::volume() const { return m_impl->volume(); }
SurfaceMesh LevelSet::surface() const { return m_impl->surface(); }

}  // namespace fascia
