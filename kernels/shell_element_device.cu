// The shell element body (mechanics/shell_element.hpp) compiled for the device: one thread per
// triangle evaluates its energy, gradient and Hessian, the same FASCIA_HD code the CPU driver
// (mechanics/shell.cpp) loops over. A CUDA shell force field launches this kernel and reduces
// the per-triangle results into the frames.
#include "core/rotation.hpp"
#include "mechanics/shell_element.hpp"

namespace fascia::gpu {

// elements: [T]; positions: [N][3] (m); orientations: [N][4] unit quaternions (w, x, y, z).
// Out: energies [T] (J), gradients [T][18], hessians [T][18][18] row-major (theta as in
// shell_element.hpp).
__global__ void shell_element_hessians(const ShellElementRest* elements, int count, ShellModuli moduli,
                                       const double* positions, const double* orientations, double* energies,
                                       double* gradients, double* hessians) {
  const int t = blockIdx.x * blockDim.x + threadIdx.x;
  if (t >= count) return;
  const ShellElementRest e = elements[t];
  Vec3 x[3];
  Mat3 R[3];
  for (int i = 0; i < 3; ++i) {
    x[i] = load3(positions + 3 * e.nodes[i]);
    R[i] = rotation_matrix(load_quat(orientations + 4 * e.nodes[i]));
  }
  energies[t] = shell_element_hessian(e, moduli, x, R, gradients + kShellElementDofs * static_cast<size_t>(t),
                                      hessians + kShellElementDofs * kShellElementDofs * static_cast<size_t>(t));
}

}  // namespace fascia::gpu
