#include "device_shell.hpp"

#include "mechanics/shell.hpp"

namespace fascia::gpu {
namespace {

// Every shell triangle's rest data, in shell and triangle order.
std::vector<ShellElementRest> shell_elements(const Model& model) {
  std::vector<ShellElementRest> elements;
  for (const Shell& shell : model.shells)
    for (size_t t = 0; t + 2 < shell.triangles.size(); t += 3)
      elements.push_back(make_shell_element(model.frame_rest_positions.data(), shell.triangles[t], shell.triangles[t + 1],
                                            shell.triangles[t + 2], shell));
  return elements;
}

// The moduli of each triangle's shell, in the order of shell_elements.
std::vector<ShellModuli> shell_moduli(const Model& model) {
  std::vector<ShellModuli> moduli;
  for (const Shell& shell : model.shells)
    moduli.insert(moduli.end(), shell.triangles.size() / 3, make_shell_moduli(shell.young, shell.poisson, shell.thickness));
  return moduli;
}

// [T][3] the triangles' frames.
std::vector<int> triangle_nodes(const std::vector<ShellElementRest>& elements) {
  std::vector<int> nodes;
  for (const ShellElementRest& e : elements) nodes.insert(nodes.end(), e.nodes, e.nodes + 3);
  return nodes;
}

}  // namespace

DeviceShells::DeviceShells(const Model& model) : DeviceShells(shell_elements(model), shell_moduli(model)) {}

DeviceShells::DeviceShells(const std::vector<ShellElementRest>& elements, const std::vector<ShellModuli>& moduli)
    : DeviceElementTerms(3, triangle_nodes(elements)) {
  if (empty()) return;
  m_elements.upload(elements);
  m_moduli.upload(moduli);
}

}  // namespace fascia::gpu
