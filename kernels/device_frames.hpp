// A frame configuration held on the device: positions [N][3] and unit quaternions [N][4]
// (model/state.hpp), the State of the device Newton problem (device_problem.hpp). Copies are
// device-to-device on the owner's stream; the host sees a state only through upload/download.
#pragma once

#include "device_vector.hpp"
#include "model/state.hpp"

namespace fascia::gpu {

class DeviceFrames {
 public:
  DeviceFrames(int frames, cudaStream_t stream);
  DeviceFrames(const DeviceFrames& o);
  DeviceFrames& operator=(const DeviceFrames& o);
  DeviceFrames(DeviceFrames&&) noexcept = default;
  DeviceFrames& operator=(DeviceFrames&&) noexcept = default;

  int frames() const { return m_frames; }
  double* positions() { return m_x.data(); }
  const double* positions() const { return m_x.data(); }
  double* orientations() { return m_q.data(); }
  const double* orientations() const { return m_q.data(); }

  // Positions and orientations from / into host memory (velocities untouched).
  void upload(const State& state);
  void download(State& state) const;

 private:
  int m_frames;
  cudaStream_t m_stream;
  DeviceVector m_x, m_q;
};

}  // namespace fascia::gpu
