// The sample fields of an output row (io/sample_fields.hpp) on the CUDA device: one thread per
// sample runs io/sample_point.hpp, the code of the host's rows, so that the host's threads only
// average and write them. Per row the frames' state goes up (positions, rotations, velocities:
// 18 doubles per frame) and the fields come down (45 doubles per sample, 46 with fibres, and the
// positions), on the object's own stream: rows are formed on the output thread, beside the step.
// The frames' averages of the measures (vertex_fields.hpp, frame_averages) are formed there too,
// a warp per frame, with io/frame_average.hpp's weights and pair shares.
#pragma once

#include "io/sample_fields.hpp"

#include <memory>

namespace fascia::gpu {

class DeviceSampleFields final : public SampleFieldsDevice {
 public:
  // The model (which must outlive the object) with its neighbour table and materials on the device.
  explicit DeviceSampleFields(const Model& model);
  ~DeviceSampleFields() override;
  void compute(const State& state, const std::vector<double>& rotations, std::vector<Field>& fields,
               std::vector<double>* positions) override;
  std::vector<Field> frame_averages(const std::vector<unsigned char>* frames) override;

  struct Impl;

 private:
  std::unique_ptr<Impl> m_impl;
};

// Makes DeviceSampleFields (the CUDA backend's sample fields: apps/fascia/backend.cpp).
SampleFieldsFactory device_sample_fields_factory();

}  // namespace fascia::gpu
