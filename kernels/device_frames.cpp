#include "device_frames.hpp"

#include <stdexcept>

namespace fascia::gpu {

DeviceFrames::DeviceFrames(int frames, cudaStream_t stream) : m_frames(frames), m_stream(stream) {
  m_x.resize(3LL * frames, stream);
  m_q.resize(4LL * frames, stream);
}

DeviceFrames::DeviceFrames(const DeviceFrames& o) : DeviceFrames(o.m_frames, o.m_stream) { *this = o; }

DeviceFrames& DeviceFrames::operator=(const DeviceFrames& o) {
  if (this == &o) return *this;
  if (o.m_frames != m_frames || o.m_stream != m_stream) {
    m_frames = o.m_frames;
    m_stream = o.m_stream;
    m_x.resize(3LL * m_frames, m_stream);
    m_q.resize(4LL * m_frames, m_stream);
  }
  FASCIA_CUDA(cudaMemcpyAsync(m_x.data(), o.m_x.data(), 3 * sizeof(double) * m_frames, cudaMemcpyDeviceToDevice, m_stream));
  FASCIA_CUDA(cudaMemcpyAsync(m_q.data(), o.m_q.data(), 4 * sizeof(double) * m_frames, cudaMemcpyDeviceToDevice, m_stream));
  return *this;
}

void DeviceFrames::upload(const State& state) {
  if (state.frame_count() != m_frames || state.orientations.size() != 4 * static_cast<size_t>(m_frames))
    throw std::invalid_argument("DeviceFrames: the state has the wrong frame count");
  FASCIA_CUDA(cudaMemcpyAsync(m_x.data(), state.positions.data(), 3 * sizeof(double) * m_frames,
                              cudaMemcpyHostToDevice, m_stream));
  // From pageable memory the copies stage the arrays before they return (CUDA runtime API, "API
  // synchronization behavior"): the host arrays may change at once, and the copies are ordered
  // before the stream's later work.
  FASCIA_CUDA(cudaMemcpyAsync(m_q.data(), state.orientations.data(), 4 * sizeof(double) * m_frames,
                              cudaMemcpyHostToDevice, m_stream));
}

void DeviceFrames::download(State& state) const {
  state.positions.resize(3 * static_cast<size_t>(m_frames));
  state.orientations.resize(4 * static_cast<size_t>(m_frames));
  FASCIA_CUDA(cudaMemcpyAsync(state.positions.data(), m_x.data(), 3 * sizeof(double) * m_frames,
                              cudaMemcpyDeviceToHost, m_stream));
  FASCIA_CUDA(cudaMemcpyAsync(state.orientations.data(), m_q.data(), 4 * sizeof(double) * m_frames,
                              cudaMemcpyDeviceToHost, m_stream));
  FASCIA_CUDA(cudaStreamSynchronize(m_stream));
}

}  // namespace fascia::gpu
