// One sample's row of the sample fields (sample_fields.hpp): its position, kinematics and strain
// and stress measures from the frames' state. FASCIA_HD: the host's rows (sample_fields) and the
// device's (kernels/device_sample_fields.hpp) run this code.
#pragma once

#include "core/config.hpp"
#include "core/small_math.hpp"
#include "material/stress_measures.hpp"

namespace fascia {

// The neighbour table (model.hpp, NeighbourTable) as arrays.
struct SampleTableView {
  const int* offsets;              // [S+1]
  const int* frames;               // [P]
  const double* weights;           // [P]
  const double* weight_gradients;  // [P][3], 1/m
  const double* rest_offsets;      // [P][3], m
};

// The sample fields' places: field k of sample_fields.hpp's order (displacement, velocity, then
// the measures of measure_fields) and its components.
constexpr int kSampleDisplacement = 0, kSampleVelocity = 1, kSampleMeasures = 2;

// The measure fields of m from field `first` on (measure_fields' order: green_strain,
// second_piola, cauchy_stress, their principal values, the two von Mises values, the strain
// energy density, and with `fibres` the fibre stretch): put(field, component, value).
template <class Put>
FASCIA_HD void put_measures(const StressMeasures& m, bool fibres, int first, Put&& put) {
  const Mat3* tensors[3] = {&m.green_strain, &m.second_piola, &m.cauchy};
  for (int k = 0; k < 3; ++k) {
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) put(first + k, 3 * r + c, tensors[k]->m[r][c]);
    const std::array<double, 3> p = principal_values(*tensors[k]);
    for (int c = 0; c < 3; ++c) put(first + 3 + k, c, p[static_cast<std::size_t>(c)]);
  }
  put(first + 6, 0, von_mises(m.second_piola));
  put(first + 7, 0, von_mises(m.cauchy));
  put(first + 8, 0, m.energy_density);
  if (fibres) put(first + 9, 0, m.fibre_stretch);
}

// Sample s's fields from the frames' positions x [N][3], rotations R [N][9] (row-major) and
// velocities [N][6], its rest position and material: put(field, component, value) for each; returns
// the sample's position p_s (eq. 3). One pass over the sample's pairs: with a = R_i l and
// y = x_i + a, the position p = sum w y (sample_position), F = sum y g^T + w R_i
// (sample_deformation_gradient) and the velocity v = sum w (v_i + omega_i x a), each summed in
// pair order as those functions do.
template <class Put>
FASCIA_HD Vec3 sample_point(const SampleTableView& t, int s, const double* x, const double* R, const double* velocities,
                            const Vec3& rest_position, const Material& material, bool fibres, Put&& put) {
  Vec3 p{0, 0, 0}, v{0, 0, 0};
  Mat3 F = zero3();
  for (int q = t.offsets[s]; q < t.offsets[s + 1]; ++q) {
    const long long i = t.frames[q];
    const Mat3 Ri = load_mat3(R + 9 * i);
    const Vec3 a = Ri * load3(t.rest_offsets + 3LL * q), y = load3(x + 3 * i) + a;
    p += t.weights[q] * y;
    F += outer(y, load3(t.weight_gradients + 3LL * q)) + t.weights[q] * Ri;
    v += t.weights[q] * (load3(velocities + 6 * i) + cross(load3(velocities + 6 * i + 3), a));
  }
  const Vec3 u = p - rest_position;
  put(kSampleDisplacement, 0, u.x), put(kSampleDisplacement, 1, u.y), put(kSampleDisplacement, 2, u.z);
  put(kSampleVelocity, 0, v.x), put(kSampleVelocity, 1, v.y), put(kSampleVelocity, 2, v.z);
  put_measures(stress_measures(material, F), fibres, kSampleMeasures, put);
  return p;
}

}  // namespace fascia
