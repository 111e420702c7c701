// Per-particle fields written with a trajectory (HDF5 /particles/<group>/<name>, XDMF node
// attributes): the samples' kinematics and strain and stress measures, and the frames'
// kinematics and axes, computed from the model and a state.
//
// Samples (s, with pairs (s, i) of the neighbour table, eq. 3 and 8):
//   displacement  p_s - p̄_s, m                     velocity  sum_i w_is (v_i + omega_i x R_i l̄_is), m/s
//   green_strain, second_piola, cauchy_stress       3 x 3, (dimensionless, Pa, Pa) (stress_measures.hpp)
//   green_strain_principal, second_piola_principal, cauchy_principal   eigenvalues, largest first
//   second_piola_von_mises, cauchy_von_mises        Pa
//   strain_energy_density                           psi per rest volume, J/m^3
//   fibre_stretch                                   |F a| (models with an hgo material only; 0 at
//                                                   samples whose law has no fibres; frames average
//                                                   the samples with fibres only, vertex_fields.hpp)
// Frames (i): displacement x_i - x̄_i (m), velocity v_i (m/s), angular_velocity omega_i (rad/s,
// world axes), axis_x, axis_y, axis_z: the columns of R_i (the frame's axes in world coordinates).
#pragma once

#include "model/model.hpp"
#include "material/stress_measures.hpp"
#include "model/state.hpp"

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace fascia {

// One per-particle field: values [n][components] (components 1, 3 or 9; 3 x 3 row-major).
// `single`: stored in single precision (the strain and stress measures, whose accuracy the
// Newton tolerance bounds far above float's 6e-8 rounding); kinematics are stored in double.
struct Field {
  std::string name;
  int components = 1;
  std::string unit;  // SI, "" dimensionless
  std::vector<double> values;
  bool single = false;
};

// The sample fields in the order listed above into `fields`; rotations are
// rotation_matrices(state) ([N][9]). Every value is written: fields of this model's layout are
// overwritten in place (a caller keeping them across rows allocates them once), others replaced.
// `positions`, when given: the samples' positions p_s [S][3] (m), eq. (3), resized. Each sample's
// values come from sample_point.hpp.
void sample_fields(const Model& model, const State& state, const std::vector<double>& rotations,
                   std::vector<Field>& fields, std::vector<double>* positions = nullptr);

// Makes `fields` the sample fields of the model's layout (zero) unless they are already.
void prepare_sample_fields(const Model& model, std::vector<Field>& fields);

// The sample fields computed elsewhere than on this thread's CPU cores (the CUDA device:
// kernels/device_sample_fields.hpp), by the same per-sample code: sample_fields' contract.
class SampleFieldsDevice {
 public:
  virtual ~SampleFieldsDevice() = default;
  virtual void compute(const State& state, const std::vector<double>& rotations, std::vector<Field>& fields,
                       std::vector<double>* positions) = 0;
  // vertex_fields.hpp's frame_averages of the fields of the last compute().
  virtual std::vector<Field> frame_averages(const std::vector<unsigned char>* frames) = 0;
};
// Makes one for a model (which outlives it).
using SampleFieldsFactory = std::function<std::unique_ptr<SampleFieldsDevice>(const Model& model)>;

// The frame fields in the order listed above.
std::vector<Field> frame_fields(const Model& model, const State& state, const std::vector<double>& rotations);

// The strain and stress measure fields (green_strain ... strain_energy_density above, and
// fibre_stretch with `fibres`) for n particles, zero, and their values for particle `index` from
// a point's measures, into the measure fields fields[first], fields[first + 1], ... (the fibre
// stretch where fields holds it).
std::vector<Field> measure_fields(std::size_t n, bool fibres = false);
void set_measures(std::vector<Field>& fields, std::size_t first, std::size_t index, const StressMeasures& m);

// Whether any material of the model has fibres (its sample fields include fibre_stretch).
bool has_fibres(const Model& model);

}  // namespace fascia
