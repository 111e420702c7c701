#include "io/vertex_fields.hpp"

#include "mechanics/frame_sample.hpp"
#include "mechanics/shell.hpp"

#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

namespace fascia {

StressMeasures shell_membrane_measures(const ShellElementRest& e, const Shell& shell, const double* x) {
  const int n0 = e.nodes[0], n1 = e.nodes[1], n2 = e.nodes[2];
  const Vec3 x0 = load3(x + 3 * n0), d1 = load3(x + 3 * n1) - x0, d2 = load3(x + 3 * n2) - x0;
  // F2 columns f_c = d1 Dm^{-1}_{0c} + d2 Dm^{-1}_{1c}.
  const Vec3 f[2] = {e.dm_inverse[0][0] * d1 + e.dm_inverse[1][0] * d2, e.dm_inverse[0][1] * d1 + e.dm_inverse[1][1] * d2};
  double E2[2][2], S2[2][2];
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b) E2[a][b] = 0.5 * (dot(f[a], f[b]) - (a == b ? 1.0 : 0.0));
  const double nu = shell.poisson, mu = shell.young / (2 * (1 + nu)), lambda = shell.young * nu / (1 - nu * nu);
  const double tr = E2[0][0] + E2[1][1];
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b) S2[a][b] = 2 * mu * E2[a][b] + (a == b ? lambda * tr : 0.0);
  const double c00 = dot(f[0], f[0]), c11 = dot(f[1], f[1]), c01 = dot(f[0], f[1]);
  const double J2 = std::sqrt(std::max(c00 * c11 - c01 * c01, 0.0));
  StressMeasures m;
  m.green_strain = zero3();
  m.second_piola = zero3();
  m.cauchy = zero3();
  const Vec3 A[2] = {e.axes[0], e.axes[1]};
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b) {
      m.green_strain += E2[a][b] * outer(A[a], A[b]);
      m.second_piola += S2[a][b] * outer(A[a], A[b]);
      m.cauchy += (S2[a][b] / J2) * outer(f[a], f[b]);
    }
  m.energy_density = mu * (E2[0][0] * E2[0][0] + 2 * E2[0][1] * E2[0][1] + E2[1][1] * E2[1][1]) + 0.5 * lambda * tr * tr;
  return m;
}

void mark_surface_frames(const SurfaceSource& source, std::vector<unsigned char>& frames) {
  if (source.shell) return;
  if (source.skin) {
    for (int i : source.skin->frames) frames[static_cast<std::size_t>(i)] = 1;
  } else {
    for (int i : source.surface->vertex_frames) frames[static_cast<std::size_t>(i)] = 1;
  }
}

std::vector<unsigned char> fibred_materials(const Model& model) {
  std::vector<unsigned char> f;
  for (const Material& m : model.materials) f.push_back(m.law == MaterialLaw::hgo ? 1 : 0);
  return f;
}

namespace {

// The model's tables as frame_average.hpp reads them (fibred_material: fibred_materials(model),
// which must outlive the view).
FrameAverageView frame_average_view(const Model& model, const std::vector<unsigned char>& fibred_material) {
  return {model.reverse.offsets.data(), model.reverse.pairs.data(),    model.reverse.pair_samples.data(),
          model.neighbours.weights.data(), model.samples.volumes.data(), model.samples.materials.data(),
          fibred_material.data()};
}

}  // namespace

std::vector<Field> frame_averages(const Model& model, const std::vector<Field>& samples,
                                  const std::vector<unsigned char>* frames) {
  const long n = static_cast<long>(model.frame_count());
  std::vector<Field> out = measure_fields(static_cast<std::size_t>(n), has_fibres(model));
  std::vector<const Field*> sources(out.size(), nullptr);
  for (std::size_t f = 0; f < out.size(); ++f)
    for (const Field& field : samples)
      if (field.name == out[f].name) sources[f] = &field;
  const std::vector<unsigned char> fibred_material = fibred_materials(model);
  const FrameAverageView view = frame_average_view(model, fibred_material);
  // The sources packed per sample, [S][C] with C the components of every field but the fibre
  // stretch (which averages other samples), so that a frame sums one contiguous row per pair.
  const std::size_t S = static_cast<std::size_t>(model.sample_count());
  std::vector<std::size_t> at(out.size(), 0);
  std::size_t C = 0, fibre = out.size();
  for (std::size_t f = 0; f < out.size(); ++f) {
    if (!sources[f]) continue;
    if (out[f].name == "fibre_stretch") {
      fibre = f;
      continue;
    }
    at[f] = C;
    C += static_cast<std::size_t>(out[f].components);
  }
  // Every sample is packed, in parallel (marking only the samples of the frames averaged would be
  // a serial pass over their pairs); the buffer is left uninitialised, so that its pages are
  // first touched by the threads that fill them, not zeroed by one.
  const std::unique_ptr<double[]> packed(new double[S * C]);
#pragma omp parallel for schedule(static)
  for (long sl = 0; sl < static_cast<long>(S); ++sl) {
    const std::size_t s = static_cast<std::size_t>(sl);
    for (std::size_t f = 0; f < out.size(); ++f) {
      if (!sources[f] || f == fibre) continue;
      const std::size_t c = static_cast<std::size_t>(out[f].components);
      for (std::size_t j = 0; j < c; ++j) packed[C * s + at[f] + j] = sources[f]->values[c * s + j];
    }
  }
  // Each frame gathers its pairs (the reverse table) in their fixed order: frames in parallel, in
  // chunks of 8 (a meshless frame carries hundreds of pairs, and the frames not averaged none).
  // The fibre stretch averages the samples that have fibres only: a frame that a ligament shares
  // with an isotropic organ shows the ligament's stretch, not a blend with 0.
#pragma omp parallel
  {
    std::vector<double> row(C);
#pragma omp for schedule(dynamic, 8)
    for (long il = 0; il < n; ++il) {
      const std::size_t i = static_cast<std::size_t>(il);
      if (frames && !(*frames)[i]) continue;
      double weight = 0, weight_fibred = 0;
      frame_average_weights(view, static_cast<int>(i), 0, 1, weight, weight_fibred);
      if (weight > 0) {
        std::fill(row.begin(), row.end(), 0.0);
        for (int k = view.offsets[i]; k < view.offsets[i + 1]; ++k) {
          const int q = view.pairs[k], s = view.pair_samples[q];
          const double w = pair_share(view, q, s, weight);
          const double* in = &packed[C * static_cast<std::size_t>(s)];
          for (std::size_t j = 0; j < C; ++j) row[j] += w * in[j];
        }
        for (std::size_t f = 0; f < out.size(); ++f) {
          if (!sources[f] || f == fibre) continue;
          const std::size_t c = static_cast<std::size_t>(out[f].components);
          for (std::size_t j = 0; j < c; ++j) out[f].values[c * i + j] = row[at[f] + j];
        }
      }
      if (fibre < out.size() && weight_fibred > 0) {
        double sum = 0;
        for (int k = view.offsets[i]; k < view.offsets[i + 1]; ++k) {
          const int q = view.pairs[k], s = view.pair_samples[q];
          if (fibred(view, s)) sum += pair_share(view, q, s, weight_fibred) * sources[fibre]->values[static_cast<std::size_t>(s)];
        }
        out[fibre].values[i] = sum;
      }
    }
  }
  return out;
}

namespace {

// Per frame, the area-weighted average of the shell's membrane measures over its triangles
// (rest elements `elements`).
std::vector<Field> shell_frame_averages(const Model& model, const Shell& shell,
                                        const std::vector<ShellElementRest>& elements, const State& state) {
  const std::size_t n = static_cast<std::size_t>(model.frame_count());
  const std::size_t triangles = shell.triangles.size() / 3;
  if (elements.size() != triangles)
    throw std::invalid_argument("shell surface: " + std::to_string(elements.size()) + " rest elements for " +
                                std::to_string(triangles) + " triangles (make the source with shell_surface_source)");
  std::vector<Field> per_triangle = measure_fields(triangles);
  std::vector<double> area(triangles), weight(n, 0.0);
  // Triangles are independent (their principal values are most of a row's shell work): in
  // parallel; the frames' weights and averages are then summed in triangle order.
#pragma omp parallel for schedule(static)
  for (long tl = 0; tl < static_cast<long>(triangles); ++tl) {
    const std::size_t t = static_cast<std::size_t>(tl);
    const ShellElementRest& e = elements[t];
    set_measures(per_triangle, 0, t, shell_membrane_measures(e, shell, state.positions.data()));
    area[t] = e.area;
  }
  for (std::size_t t = 0; t < triangles; ++t)
    for (int k = 0; k < 3; ++k) weight[static_cast<std::size_t>(shell.triangles[3 * t + static_cast<std::size_t>(k)])] += area[t];
  std::vector<Field> out = measure_fields(n);
  for (std::size_t f = 0; f < out.size(); ++f) {
    const std::size_t c = static_cast<std::size_t>(out[f].components);
    for (std::size_t t = 0; t < triangles; ++t)
      for (int k = 0; k < 3; ++k) {
        const std::size_t i = static_cast<std::size_t>(shell.triangles[3 * t + static_cast<std::size_t>(k)]);
        for (std::size_t j = 0; j < c; ++j) out[f].values[c * i + j] += area[t] / weight[i] * per_triangle[f].values[c * t + j];
      }
  }
  return out;
}

}  // namespace

SurfaceSource shell_surface_source(const Model& model, const SurfaceLayout& surface, const Shell& shell) {
  SurfaceSource source;
  source.surface = &surface;
  source.shell = &shell;
  const std::size_t triangles = shell.triangles.size() / 3;
  source.shell_elements.reserve(triangles);
  for (std::size_t t = 0; t < triangles; ++t) {
    const int* v = &shell.triangles[3 * t];
    source.shell_elements.push_back(make_shell_element(model.frame_rest_positions.data(), v[0], v[1], v[2], shell));
  }
  return source;
}

std::vector<Field> surface_fields(const Model& model, const State& state, const std::vector<double>& rotations,
                                  const SurfaceSource& source, const std::vector<Field>& frame_measures) {
  const SurfaceLayout& surface = *source.surface;
  const std::size_t V = surface.vertex_frames.size();
  std::vector<Field> out;
  out.push_back(Field{"displacement", 3, "m", std::vector<double>(3 * V, 0.0), false});
  out.push_back(Field{"velocity", 3, "m/s", std::vector<double>(3 * V, 0.0), false});
  const std::vector<Field> shell_measures =
      source.shell ? shell_frame_averages(model, *source.shell, source.shell_elements, state) : std::vector<Field>{};
  const std::vector<Field>& measures = source.shell ? shell_measures : frame_measures;
  const std::size_t first_measure = out.size();
  for (const Field& f : measures)
    out.push_back(
        Field{f.name, f.components, f.unit, std::vector<double>(V * static_cast<std::size_t>(f.components), 0.0), f.single});

  // The measures packed per frame, [N][C] with C all their components, so that a vertex sums
  // one contiguous row per frame.
  std::size_t C = 0;
  for (const Field& f : measures) C += static_cast<std::size_t>(f.components);
  const std::size_t N = static_cast<std::size_t>(model.frame_count());
  std::vector<double> packed(N * C);
  for (std::size_t i = 0, at = 0; i < N; ++i)
    for (const Field& f : measures) {
      const std::size_t c = static_cast<std::size_t>(f.components);
      for (std::size_t k = 0; k < c; ++k) packed[at++] = f.values[c * i + k];
    }
  // Vertices are independent: in parallel.
#pragma omp parallel
  {
    std::vector<double> row(C);
#pragma omp for schedule(static)
    for (long vl = 0; vl < static_cast<long>(V); ++vl) {
      const std::size_t v = static_cast<std::size_t>(vl);
      Vec3 u{0, 0, 0}, velocity{0, 0, 0};
      std::fill(row.begin(), row.end(), 0.0);
      auto add_measures = [&](std::size_t frame, double w) {
        const double* in = &packed[C * frame];
        for (std::size_t k = 0; k < C; ++k) row[k] += w * in[k];
      };
      if (source.skin) {
        // eq. (3) at the state minus eq. (3) at rest (R = I): sum_i w (x_i + R_i l - x̄_i - l).
        const NeighbourTable& t = *source.skin;
        double total = 0;
        for (int q = t.offsets[v]; q < t.offsets[v + 1]; ++q) total += std::abs(t.weights[static_cast<std::size_t>(q)]);
        for (int q = t.offsets[v]; q < t.offsets[v + 1]; ++q) {
          const std::size_t qi = static_cast<std::size_t>(q);
          const std::size_t i = static_cast<std::size_t>(t.frames[qi]);
          const Vec3 l = load3(&t.rest_offsets[3 * qi]), a = load_mat3(&rotations[9 * i]) * l;
          u += t.weights[qi] * (load3(&state.positions[3 * i]) + a - load3(&model.frame_rest_positions[3 * i]) - l);
          velocity += t.weights[qi] * (load3(&state.velocities[6 * i]) + cross(load3(&state.velocities[6 * i + 3]), a));
          if (total > 0) add_measures(i, std::abs(t.weights[qi]) / total);
        }
      } else {
        const std::size_t i = static_cast<std::size_t>(surface.vertex_frames[v]);
        u = load3(&state.positions[3 * i]) - load3(&model.frame_rest_positions[3 * i]);
        velocity = load3(&state.velocities[6 * i]);
        add_measures(i, 1.0);
      }
      for (std::size_t k = 0; k < 3; ++k) {
        out[0].values[3 * v + k] = k == 0 ? u.x : k == 1 ? u.y : u.z;
        out[1].values[3 * v + k] = k == 0 ? velocity.x : k == 1 ? velocity.y : velocity.z;
      }
      for (std::size_t f = 0, at = 0; f < measures.size(); ++f) {
        const std::size_t c = static_cast<std::size_t>(measures[f].components);
        for (std::size_t k = 0; k < c; ++k) out[first_measure + f].values[c * v + k] = row[at++];
      }
    }
  }
  return out;
}

}  // namespace fascia
