#include "device_shell.hpp"

#include "integrate/tangent_probing.hpp"
#include "mechanics/shell.hpp"

#include <map>

namespace fascia::gpu {

DeviceShells::DeviceShells(const Model& model) {
  std::vector<ShellElementRest> elements;
  std::vector<ShellModuli> moduli;
  for (const Shell& shell : model.shells) {
    const ShellModuli m = make_shell_moduli(shell.young, shell.poisson, shell.thickness);
    for (size_t t = 0; t + 2 < shell.triangles.size(); t += 3) {
      elements.push_back(make_shell_element(model.frame_rest_positions.data(), shell.triangles[t],
                                            shell.triangles[t + 1], shell.triangles[t + 2], shell));
      moduli.push_back(m);
    }
  }
  m_triangles = static_cast<int>(elements.size());
  if (m_triangles == 0) return;
  std::map<int, std::vector<int>> by_frame;  // frame -> 3 t + node, ascending t
  for (int t = 0; t < m_triangles; ++t)
    for (int k = 0; k < 3; ++k) {
      by_frame[elements[t].nodes[k]].push_back(3 * t + k);
      m_nodes.push_back(elements[t].nodes[k]);
    }
  std::vector<int> frames, offsets{0}, entries;
  for (const auto& [frame, list] : by_frame) {
    frames.push_back(frame);
    entries.insert(entries.end(), list.begin(), list.end());
    offsets.push_back(static_cast<int>(entries.size()));
  }
  m_frames = static_cast<int>(frames.size());
  m_elements.upload(elements);
  m_moduli.upload(moduli);
  m_frame_ids.upload(frames);
  m_offsets.upload(offsets);
  m_entries.upload(entries);
  m_values.resize(static_cast<size_t>(m_triangles) * kShellElementDofs);
  m_energies.resize(static_cast<size_t>(m_triangles));
  m_hessians.resize(static_cast<size_t>(m_triangles) * kShellElementDofs * kShellElementDofs);
}

void DeviceShells::set_tangent_blocks(const std::vector<int>& block_offsets, const std::vector<int>& block_frames) {
  m_touched_blocks = 0;
  if (empty()) return;
  std::map<int, std::vector<int>> by_block;  // block -> 9 t + 3 node_a + node_b, ascending t
  for (int t = 0; t < m_triangles; ++t)
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) {
        const int fa = m_nodes[3 * static_cast<size_t>(t) + static_cast<size_t>(a)],
                  fb = m_nodes[3 * static_cast<size_t>(t) + static_cast<size_t>(b)];
        if (fb > fa) continue;
        const int p = assembled_block(block_offsets.data(), block_frames.data(), fa, fb);
        if (p >= 0) by_block[p].push_back(9 * t + 3 * a + b);
      }
  std::vector<int> ids, offsets{0}, terms;
  for (const auto& [block, list] : by_block) {
    ids.push_back(block);
    terms.insert(terms.end(), list.begin(), list.end());
    offsets.push_back(static_cast<int>(terms.size()));
  }
  m_touched_blocks = static_cast<int>(ids.size());
  m_block_ids.upload(ids);
  m_block_offsets.upload(offsets);
  m_block_terms.upload(terms);
}

}  // namespace fascia::gpu
