#include "device_rigid.hpp"

#include "mechanics/rigid_mapping.hpp"

#include <map>

namespace fascia::gpu {

DeviceRigidMapping::DeviceRigidMapping(const Model& model) {
  const RigidMapping mapping(model);
  m_reduced_fixed = mapping.reduced_fixed(model);
  m_count = static_cast<int>(mapping.mapped().size());
  if (m_count == 0) return;
  std::vector<double> rest(3 * static_cast<size_t>(m_count));
  for (int k = 0; k < m_count; ++k) {
    const int a = mapping.mapped()[k], b = mapping.bodies()[k];
    for (int c = 0; c < 3; ++c)
      rest[3 * k + c] = model.frame_rest_positions[3 * a + c] - model.frame_rest_positions[3 * b + c];
  }
  std::map<int, std::vector<int>> by_body;
  for (int k = 0; k < m_count; ++k) by_body[mapping.bodies()[k]].push_back(k);
  std::vector<int> body, offsets{0}, entries;
  for (const auto& [b, ks] : by_body) {
    body.push_back(b);
    entries.insert(entries.end(), ks.begin(), ks.end());
    offsets.push_back(static_cast<int>(entries.size()));
  }
  m_bodies = static_cast<int>(body.size());
  m_frames = model.frame_count();
  std::vector<int> slot(static_cast<size_t>(m_frames), -1);
  for (int k = 0; k < m_count; ++k) slot[static_cast<size_t>(mapping.mapped()[k])] = k;
  m_slot.upload(slot);
  m_mapped.upload(mapping.mapped());
  m_parent.upload(mapping.bodies());
  m_body.upload(body);
  m_body_offsets.upload(offsets);
  m_body_entries.upload(entries);
  m_rest_offsets.upload(rest);
  m_offsets.upload(rest);
  m_forces.resize(3 * static_cast<size_t>(m_count));
  m_forces.zero();
}

}  // namespace fascia::gpu
