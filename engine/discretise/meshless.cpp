#include "discretise/meshless.hpp"

#include "core/morton_order.hpp"
#include "discretise/point_grid.hpp"
#include "discretise/poisson_disk.hpp"
#include "discretise/sample_volumes.hpp"
#include "discretise/surface_quadrature.hpp"
#include "discretise/voxel_domain.hpp"
#include "shape/consistent_integration.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <sstream>
#include <stdexcept>

namespace fascia {
namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

std::vector<int> badly_supported(const MeshlessTable& table, double min_spread) {
  std::vector<int> bad;
  for (int s = 0; s < static_cast<int>(table.spreads.size()); ++s)
    if (!(table.spreads[s] >= min_spread) || table.spreads[s] == 0) bad.push_back(s);
  return bad;
}

std::string thin_part_message(const std::vector<int>& bad, const MeshlessTable& table, const std::vector<double>& samples,
                              const VoxelDomain& domain, const MeshlessOptions& options, bool after_repair) {
  Vec3 lo{1e300, 1e300, 1e300}, hi = -lo, worst{0, 0, 0};
  double worst_spread = 2, depth = 0;
  for (int s : bad) {
    const Vec3 p = load3(&samples[3 * s]);
    lo = Vec3{std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = Vec3{std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
    if (table.spreads[s] < worst_spread) worst_spread = table.spreads[s], worst = p;
    depth = std::max(depth, -domain.signed_distance(p));
  }
  // A sample at depth d below the surface of a sheet sees a thickness of at least 2 d.
  const double thickness = std::max(2 * depth, domain.voxel_size());
  std::ostringstream out;
  out << bad.size() << " samples have too few well-spread neighbour frames for F to be defined"
      << (after_repair ? " even after adding frames" : "") << ": worst at (" << worst.x << ", " << worst.y << ", "
      << worst.z << ") m with spread " << worst_spread << " < " << options.min_spread << ", region box [(" << lo.x
      << ", " << lo.y << ", " << lo.z << "), (" << hi.x << ", " << hi.y << ", " << hi.z
      << ")] m. The object is about " << thickness << " m thick there, thinner than frame_spacing "
      << options.frame_spacing << " m: use frame_spacing <= " << thickness / 2 << " m (and sample_spacing below it)"
      << (options.thin_parts == ThinParts::stop ? ", or thin_parts: repair" : "") << ".";
  return out.str();
}

}  // namespace

std::string MeshlessStatistics::describe() const {
  std::ostringstream out;
  out << "frames " << frames << " (" << added_frames << " added for thin parts), samples " << samples << "\n"
      << "neighbours per sample min " << neighbours_min << " mean " << neighbours_mean << " max " << neighbours_max
      << ", smallest spread " << min_spread << ", frame supports " << support_min << " to " << support_max
      << " m\n"
      << "consistent integration: " << boundary_points << " surface points, defect " << integration_defect_before
      << " -> " << integration_defect << " (" << integration_iterations << " CG iterations)\n"
      << "voxel size " << voxel_size << " m, " << voxels << " voxels; frames drawn on a lattice of " << frame_voxel_size
      << " m\n"
      << "volume: surface " << surface_volume << " m^3, voxels " << voxel_volume << " m^3 (error "
      << 100 * volume_error << " %";
  if (unassigned_volume > 0) out << ", " << unassigned_volume << " m^3 without a sample in reach";
  out << "), samples " << sample_volume << " m^3 (voxel shares scaled by " << volume_scale << ")\n"
      << "seconds: voxelise " << seconds_voxelise << ", frames " << seconds_frames << ", samples " << seconds_samples
      << ", volumes " << seconds_volumes << ", shape functions " << seconds_shape << ", consistent integration "
      << seconds_integration << ", total " << seconds_total << "\n";
  return out.str();
}

double frame_lattice_spacing(double frame_spacing) { return frame_spacing / std::cbrt(10.0) / 2; }

namespace {

// The points [M][3] along a Morton curve (core/morton_order.hpp): nearby points get nearby
// indices, so that the per-sample loops read nearby frames and a frame's samples lie close
// together in memory.
std::vector<double> in_morton_order(const std::vector<double>& points) {
  const std::vector<int> order = morton_order(points);
  std::vector<double> sorted(points.size());
  for (std::size_t k = 0; k < order.size(); ++k)
    for (int c = 0; c < 3; ++c) sorted[3 * k + c] = points[3 * static_cast<std::size_t>(order[k]) + c];
  return sorted;
}

// Frames on frame_domain, samples and volumes on domain (meshless.hpp, frame lattice).
MeshlessBuild build_on(const VoxelDomain& domain, const VoxelDomain& frame_domain, const SurfaceMesh& boundary,
                       const Material& material, const MeshlessOptions& options);

void check_spacings(const MeshlessOptions& options) {
  if (!(options.sample_spacing > 0) || !(options.frame_spacing > options.sample_spacing))
    throw std::invalid_argument("meshless: need 0 < sample_spacing < frame_spacing");
}

}  // namespace

MeshlessBuild build_meshless_model(const SurfaceMesh& surface, const Material& material, const MeshlessOptions& options) {
  const auto t_start = std::chrono::steady_clock::now();
  check_spacings(options);
  const double h = options.voxel_size > 0 ? options.voxel_size : options.sample_spacing / 2;
  const double h_frames = frame_lattice_spacing(options.frame_spacing);
  if (options.require_closed_surface) {
    const SurfaceDefects defects = check_surface(surface);
    if (!defects.ok()) throw std::invalid_argument("meshless: the surface cannot bound a volume:\n" + defects.describe());
  }
  const auto t0 = std::chrono::steady_clock::now();
  const VoxelDomain domain(surface, h);
  // The same surface and voxel size give the same lattice: one voxelisation serves both.
  std::optional<VoxelDomain> frame_lattice;
  if (h != h_frames) frame_lattice.emplace(surface, h_frames);
  const double seconds_voxelise = seconds_since(t0);
  MeshlessBuild build = build_on(domain, frame_lattice ? *frame_lattice : domain, surface, material, options);
  build.statistics.seconds_voxelise = seconds_voxelise;
  build.statistics.seconds_total = seconds_since(t_start);
  return build;
}

MeshlessBuild build_meshless_model(const VoxelDomain& domain, const SurfaceMesh& boundary, const Material& material,
                                   const MeshlessOptions& options) {
  const auto t_start = std::chrono::steady_clock::now();
  check_spacings(options);
  const VoxelDomain frame_domain(boundary, frame_lattice_spacing(options.frame_spacing));
  const double seconds_voxelise = seconds_since(t_start);
  MeshlessBuild build = build_on(domain, frame_domain, boundary, material, options);
  build.statistics.seconds_voxelise = seconds_voxelise;
  build.statistics.seconds_total = seconds_since(t_start);
  return build;
}

namespace {

MeshlessBuild build_on(const VoxelDomain& domain, const VoxelDomain& frame_domain, const SurfaceMesh& boundary,
                       const Material& material, const MeshlessOptions& options) {
  const auto t_start = std::chrono::steady_clock::now();
  const double rf = options.frame_spacing, rs = options.sample_spacing;
  // Enclosed volume by the divergence theorem, exact for the triangulation; negative when the
  // triangles face inwards (then the boundary rule's normals are turned outwards below).
  const double signed_volume = surface_volume(boundary);
  const double reference_volume = std::abs(signed_volume);
  if (!(reference_volume > 0)) throw std::invalid_argument("meshless: the boundary surface encloses no volume");
  MeshlessBuild build;
  MeshlessStatistics& st = build.statistics;
  st.voxel_size = domain.voxel_size();
  st.frame_voxel_size = frame_domain.voxel_size();
  st.surface_volume = reference_volume;

  auto t0 = std::chrono::steady_clock::now();
  // Caller-placed frames count as already placed: Poisson-disk frames keep r_f from them.
  std::vector<double> frames =
      in_morton_order(poisson_disk_sample(frame_domain, PoissonDiskOptions{rf, options.seed, 30, options.extra_frames}));
  frames.insert(frames.end(), options.extra_frames.begin(), options.extra_frames.end());
  st.seconds_frames = seconds_since(t0);
  t0 = std::chrono::steady_clock::now();
  const std::vector<double> samples =
      in_morton_order(poisson_disk_sample(domain, PoissonDiskOptions{rs, options.seed ^ 0x5bd1e9955bd1e995ull, 30, {}}));
  st.seconds_samples = seconds_since(t0);
  if (frames.empty()) {
    std::ostringstream out;
    out << "meshless: no point of the frames' lattice (spacing " << frame_domain.voxel_size()
        << " m, frame_spacing / 4.3) lies inside the surface; the object is thinner than that: use a smaller "
           "frame_spacing";
    throw std::runtime_error(out.str());
  }
  if (samples.empty())
    throw std::runtime_error("meshless: no voxel centre lies inside the surface; use a smaller voxel_size");

  t0 = std::chrono::steady_clock::now();
  SampleVolumes volumes = sample_volumes(domain, samples, rs);
  st.seconds_volumes = seconds_since(t0);

  t0 = std::chrono::steady_clock::now();
  MeshlessShape shape = make_meshless_shape(frames, options.shape);
  MeshlessTable table = build_meshless_table(shape, samples);
  std::vector<int> bad = badly_supported(table, options.min_spread);
  if (!bad.empty() && options.thin_parts == ThinParts::stop)
    throw std::runtime_error("meshless: " + thin_part_message(bad, table, samples, domain, options, false));
  const int poisson_frames = static_cast<int>(frames.size() / 3);
  for (int pass = 0; pass < options.repair_passes && !bad.empty(); ++pass) {
    const Vec3 margin{2 * rf, 2 * rf, 2 * rf};
    PointGrid near_grid(domain.lower() - margin, domain.upper() + margin, 0.5 * rf / std::sqrt(3.0), 2);
    PointGrid extra_grid(domain.lower() - margin, domain.upper() + margin, rf / std::sqrt(3.0), 2);
    for (int i = 0; i < static_cast<int>(frames.size() / 3); ++i) {
      if (i < poisson_frames) near_grid.set(near_grid.cell_of(load3(&frames[3 * i])), i);
      else extra_grid.set(extra_grid.cell_of(load3(&frames[3 * i])), i);
    }
    const size_t before = frames.size();
    for (int s : bad) {
      const Vec3 p = load3(&samples[3 * s]), n = load3(&table.weak_directions[3 * s]);
      for (double side : {1.0, -1.0}) {
        const Vec3 x = p + (side * rf) * n;
        const long long ca = near_grid.cell_of(x), cb = extra_grid.cell_of(x);
        if (ca < 0 || cb < 0 || near_grid.at(ca) >= 0 || extra_grid.at(cb) >= 0) continue;
        if (near_grid.any_within(x, ca, 0.5 * rf, frames) || extra_grid.any_within(x, cb, rf, frames)) continue;
        const int id = static_cast<int>(frames.size() / 3);
        frames.insert(frames.end(), {x.x, x.y, x.z});
        extra_grid.set(cb, id);
      }
    }
    if (frames.size() == before) break;
    shape = make_meshless_shape(frames, options.shape);
    table = build_meshless_table(shape, samples);
    bad = badly_supported(table, options.min_spread);
  }
  if (!bad.empty()) throw std::runtime_error("meshless: " + thin_part_message(bad, table, samples, domain, options, true));

  // Frames that no sample uses carry no mass and no stiffness: drop them.
  const int n_all = static_cast<int>(frames.size() / 3);
  std::vector<int> used(n_all, 0), renumber(n_all, -1);
  for (int i : table.neighbours.frames) used[i] = 1;
  Model& model = build.model;
  for (int i = 0; i < n_all; ++i) {
    if (!used[i]) continue;
    renumber[i] = static_cast<int>(model.frame_rest_positions.size() / 3);
    model.frame_rest_positions.insert(model.frame_rest_positions.end(), {frames[3 * i], frames[3 * i + 1], frames[3 * i + 2]});
    if (i >= poisson_frames) ++st.added_frames;
  }
  for (int& i : table.neighbours.frames) i = renumber[i];
  build.shape.frames = model.frame_rest_positions;
  for (int i = 0; i < n_all; ++i)
    if (renumber[i] >= 0) build.shape.supports.push_back(shape.supports[i]);
  st.seconds_shape = seconds_since(t0);

  model.samples.rest_positions = samples;
  model.samples.volumes = std::move(volumes.volumes);
  model.samples.materials.assign(model.samples.volumes.size(), 0);
  model.neighbours = std::move(table.neighbours);
  model.materials = {material};
  build_reverse_table(model);
  model.fixed_dofs.assign(model.dof_count(), 0);

  st.frames = model.frame_count();
  st.samples = model.sample_count();
  st.neighbours_min = 1 << 30;
  for (int s = 0; s < st.samples; ++s) {
    const int c = model.neighbours.offsets[s + 1] - model.neighbours.offsets[s];
    st.neighbours_min = std::min(st.neighbours_min, c);
    st.neighbours_max = std::max(st.neighbours_max, c);
  }
  st.neighbours_mean = static_cast<double>(model.pair_count()) / std::max(st.samples, 1);
  st.min_spread = table.spreads.empty() ? 0 : *std::min_element(table.spreads.begin(), table.spreads.end());
  st.voxels = domain.covered_count();
  st.voxel_volume = volumes.assigned + volumes.unassigned;
  st.unassigned_volume = volumes.unassigned;
  st.volume_error = (st.voxel_volume - st.surface_volume) / st.surface_volume;
  st.volume_scale = st.surface_volume / volumes.assigned;
  for (double& v : model.samples.volumes) v *= st.volume_scale;

  st.support_min = *std::min_element(build.shape.supports.begin(), build.shape.supports.end());
  st.support_max = *std::max_element(build.shape.supports.begin(), build.shape.supports.end());

  // Consistent integration; it also tilts the volumes so that they integrate x exactly, hence
  // the masses are computed after it.
  t0 = std::chrono::steady_clock::now();
  SurfaceQuadrature rule = surface_quadrature(boundary, rs);
  if (signed_volume < 0)
    for (double& a : rule.normals) a = -a;
  const MeshlessTable boundary_table = build_meshless_table(build.shape, rule.points, /*weights_only=*/true);
  if (!boundary_table.failed.empty()) {
    const Vec3 b = load3(&rule.points[3 * boundary_table.failed.front()]);
    throw std::runtime_error("meshless: " + std::to_string(boundary_table.failed.size()) +
                             " surface points are not covered by enough frames, e.g. (" + std::to_string(b.x) + ", " +
                             std::to_string(b.y) + ", " + std::to_string(b.z) + ") m; use a smaller frame_spacing");
  }
  const ConsistentIntegrationReport integration =
      make_integration_consistent(model.neighbours, model.samples.volumes, model.samples.rest_positions, build.shape,
                                  boundary_table.neighbours, rule.points, rule.normals);
  st.boundary_points = static_cast<long long>(rule.points.size() / 3);
  st.integration_defect_before = integration.initial_defect;
  st.integration_defect = integration.defect;
  st.integration_iterations = integration.iterations;
  st.seconds_integration = seconds_since(t0);

  compute_frame_inertia(model);
  st.sample_volume = model.total_volume();
  st.seconds_total = seconds_since(t_start);
  return build;
}

}  // namespace
}  // namespace fascia
