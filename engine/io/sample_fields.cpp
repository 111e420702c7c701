#include "io/sample_fields.hpp"

#include "io/sample_point.hpp"

namespace fascia {

namespace {

void store(std::vector<double>& out, std::size_t index, const Vec3& v) {
  out[3 * index] = v.x;
  out[3 * index + 1] = v.y;
  out[3 * index + 2] = v.z;
}

// The model's neighbour table as sample_point.hpp reads it.
SampleTableView sample_table_view(const Model& model) {
  const NeighbourTable& t = model.neighbours;
  return {t.offsets.data(), t.frames.data(), t.weights.data(), t.weight_gradients.data(), t.rest_offsets.data()};
}

// A field of n particles, zero.
Field make(const char* name, int components, const char* unit, std::size_t n) {
  return Field{name, components, unit, std::vector<double>(n * static_cast<std::size_t>(components), 0.0), false};
}

// A strain or stress measure (stored in single precision), zero.
Field measure(const char* name, int components, const char* unit, std::size_t n) {
  Field f = make(name, components, unit, n);
  f.single = true;
  return f;
}

}  // namespace

std::vector<Field> measure_fields(std::size_t n, bool fibres) {
  std::vector<Field> f;
  f.push_back(measure("green_strain", 9, "", n));
  f.push_back(measure("second_piola", 9, "Pa", n));
  f.push_back(measure("cauchy_stress", 9, "Pa", n));
  f.push_back(measure("green_strain_principal", 3, "", n));
  f.push_back(measure("second_piola_principal", 3, "Pa", n));
  f.push_back(measure("cauchy_principal", 3, "Pa", n));
  f.push_back(measure("second_piola_von_mises", 1, "Pa", n));
  f.push_back(measure("cauchy_von_mises", 1, "Pa", n));
  f.push_back(measure("strain_energy_density", 1, "J/m^3", n));
  if (fibres) f.push_back(measure("fibre_stretch", 1, "", n));
  return f;
}

void set_measures(std::vector<Field>& fields, std::size_t first, std::size_t i, const StressMeasures& m) {
  put_measures(m, fields.size() > first + 9, static_cast<int>(first), [&](int field, int c, double v) {
    Field& f = fields[static_cast<std::size_t>(field)];
    f.values[static_cast<std::size_t>(f.components) * i + static_cast<std::size_t>(c)] = v;
  });
}

bool has_fibres(const Model& model) {
  for (const Material& m : model.materials)
    if (m.law == MaterialLaw::hgo) return true;
  return false;
}

void prepare_sample_fields(const Model& model, std::vector<Field>& f) {
  const std::size_t n = static_cast<std::size_t>(model.sample_count());
  const bool fibres = has_fibres(model);
  if (f.size() == kSampleMeasures + measure_fields(0, fibres).size() && f[0].values.size() == 3 * n) return;
  f.clear();
  f.push_back(make("displacement", 3, "m", n));
  f.push_back(make("velocity", 3, "m/s", n));
  for (Field& m : measure_fields(n, fibres)) f.push_back(std::move(m));
}

void sample_fields(const Model& model, const State& state, const std::vector<double>& rotations,
                   std::vector<Field>& f, std::vector<double>* positions) {
  const std::size_t n = static_cast<std::size_t>(model.sample_count());
  const bool fibres = has_fibres(model);
  prepare_sample_fields(model, f);
  const SampleTableView t = sample_table_view(model);
  if (positions) positions->resize(3 * n);
  double* p_out = positions ? positions->data() : nullptr;
#pragma omp parallel for schedule(static)
  for (long sl = 0; sl < static_cast<long>(n); ++sl) {
    const std::size_t si = static_cast<std::size_t>(sl);
    const Vec3 p = sample_point(
        t, static_cast<int>(sl), state.positions.data(), rotations.data(), state.velocities.data(),
        load3(&model.samples.rest_positions[3 * si]), model.materials[static_cast<std::size_t>(model.samples.materials[si])],
        fibres, [&](int field, int c, double v) {
          Field& out = f[static_cast<std::size_t>(field)];
          out.values[static_cast<std::size_t>(out.components) * si + static_cast<std::size_t>(c)] = v;
        });
    if (p_out) store3(p_out + 3 * si, p);
  }
}

std::vector<Field> frame_fields(const Model& model, const State& state, const std::vector<double>& rotations) {
  const std::size_t n = static_cast<std::size_t>(model.frame_count());
  std::vector<Field> f;
  f.push_back(make("displacement", 3, "m", n));
  f.push_back(make("velocity", 3, "m/s", n));
  f.push_back(make("angular_velocity", 3, "rad/s", n));
  f.push_back(make("axis_x", 3, "", n));
  f.push_back(make("axis_y", 3, "", n));
  f.push_back(make("axis_z", 3, "", n));
  for (std::size_t i = 0; i < n; ++i) {
    store(f[0].values, i, load3(&state.positions[3 * i]) - load3(&model.frame_rest_positions[3 * i]));
    store(f[1].values, i, load3(&state.velocities[6 * i]));
    store(f[2].values, i, load3(&state.velocities[6 * i + 3]));
    const Mat3 Ri = load_mat3(&rotations[9 * i]);
    for (int c = 0; c < 3; ++c) store(f[3 + static_cast<std::size_t>(c)].values, i, Vec3{Ri.m[0][c], Ri.m[1][c], Ri.m[2][c]});
  }
  return f;
}

}  // namespace fascia
