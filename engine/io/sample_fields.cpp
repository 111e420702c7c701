#include "io/sample_fields.hpp"

#include "material/stress_measures.hpp"
#include "mechanics/frame_sample.hpp"

namespace fascia {

namespace {

void store(std::vector<double>& out, std::size_t index, const Vec3& v) {
  out[3 * index] = v.x;
  out[3 * index + 1] = v.y;
  out[3 * index + 2] = v.z;
}

void store(std::vector<double>& out, std::size_t index, const Mat3& a) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out[9 * index + static_cast<std::size_t>(3 * r + c)] = a.m[r][c];
}

void store(std::vector<double>& out, std::size_t index, const std::array<double, 3>& v) {
  for (std::size_t k = 0; k < 3; ++k) out[3 * index + k] = v[k];
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
  Field* f = fields.data() + first;
  store(f[0].values, i, m.green_strain);
  store(f[1].values, i, m.second_piola);
  store(f[2].values, i, m.cauchy);
  store(f[3].values, i, principal_values(m.green_strain));
  store(f[4].values, i, principal_values(m.second_piola));
  store(f[5].values, i, principal_values(m.cauchy));
  f[6].values[i] = von_mises(m.second_piola);
  f[7].values[i] = von_mises(m.cauchy);
  f[8].values[i] = m.energy_density;
  if (fields.size() > first + 9) f[9].values[i] = m.fibre_stretch;
}

bool has_fibres(const Model& model) {
  for (const Material& m : model.materials)
    if (m.law == MaterialLaw::hgo) return true;
  return false;
}

void sample_fields(const Model& model, const State& state, const std::vector<double>& rotations,
                   std::vector<Field>& f, std::vector<double>* positions) {
  const std::size_t n = static_cast<std::size_t>(model.sample_count());
  const bool fibres = has_fibres(model);
  constexpr std::size_t kKinematic = 2;  // displacement, velocity; then the measures
  if (f.size() != kKinematic + measure_fields(0, fibres).size() || f[0].values.size() != 3 * n) {
    f.clear();
    f.push_back(make("displacement", 3, "m", n));
    f.push_back(make("velocity", 3, "m/s", n));
    for (Field& m : measure_fields(n, fibres)) f.push_back(std::move(m));
  }

  const NeighbourTable& t = model.neighbours;
  const double* x = state.positions.data();
  const double* R = rotations.data();
  if (positions) positions->resize(3 * n);
  double* p_out = positions ? positions->data() : nullptr;
#pragma omp parallel for schedule(static)
  for (long sl = 0; sl < static_cast<long>(n); ++sl) {
    const std::size_t si = static_cast<std::size_t>(sl);
    // One pass over the sample's pairs: with a = R_i l and y = x_i + a, the position
    // p = sum w y (sample_position), F = sum y g^T + w R_i (sample_deformation_gradient) and the
    // velocity v = sum w (v_i + omega_i x a), each summed in pair order as those functions do.
    Vec3 p{0, 0, 0}, v{0, 0, 0};
    Mat3 F = zero3();
    for (int q = t.offsets[si]; q < t.offsets[si + 1]; ++q) {
      const std::size_t qi = static_cast<std::size_t>(q);
      const std::size_t i = static_cast<std::size_t>(t.frames[qi]);
      const Mat3 Ri = load_mat3(R + 9 * i);
      const Vec3 a = Ri * load3(&t.rest_offsets[3 * qi]), y = load3(x + 3 * i) + a;
      p += t.weights[qi] * y;
      F += outer(y, load3(&t.weight_gradients[3 * qi])) + t.weights[qi] * Ri;
      v += t.weights[qi] * (load3(&state.velocities[6 * i]) + cross(load3(&state.velocities[6 * i + 3]), a));
    }
    if (p_out) store3(p_out + 3 * si, p);
    store(f[0].values, si, p - load3(&model.samples.rest_positions[3 * si]));
    store(f[1].values, si, v);
    set_measures(f, kKinematic, si, stress_measures(model.materials[static_cast<std::size_t>(model.samples.materials[si])], F));
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
