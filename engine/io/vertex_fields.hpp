// Fields at the vertices of the output surfaces (meshes of tissues, shells, rigid bodies), so
// that ParaView colours the surfaces: the kinematic fields exactly, the strain and stress
// measures (sample_fields.hpp) averaged.
//
//  * displacement and velocity: of the vertex itself (a frame's for mesh-based and shell vertices;
//    eq. (3) through the surface's skin weights for meshless and rigid surfaces).
//  * measures of a tissue surface: each frame takes the average of its samples' values weighted by
//    |w_is| v_s (the samples' share of the frame, as in the lumped mass m_i = sum_s w_is rho v_s),
//    and a skinned vertex the |w|-weighted average of its frames' values. Averaging is done per
//    component and per scalar, so a vertex's von Mises is the average of its samples' von Mises,
//    not the von Mises of the averaged stress. Frames without samples (rigid bodies) get 0.
//  * measures of a shell surface: the membrane (mid-surface) measures of each triangle
//    (shell_membrane_measures) averaged over the triangles around each vertex, weighted by area.
//    Bending stresses vanish on the mid-surface and are not included.
#pragma once

#include "io/frame_average.hpp"
#include "io/sample_fields.hpp"
#include "io/trajectory.hpp"
#include "material/stress_measures.hpp"
#include "mechanics/shell.hpp"

namespace fascia {

// How a surface's vertices follow the frames.
struct SurfaceSource {
  const SurfaceLayout* surface = nullptr;
  const NeighbourTable* skin = nullptr;  // skinned surfaces (meshless, rigid): a row per vertex; null: vertex = frame
  const Shell* shell = nullptr;          // shell objects: measures from the shell's membrane
  std::vector<ShellElementRest> shell_elements;  // the shell's triangles' rest elements (shell_surface_source)
};

// The source of a shell object's surface: the shell, and its triangles' rest elements
// (make_shell_element), made once for all the rows that the source serves.
SurfaceSource shell_surface_source(const Model& model, const SurfaceLayout& surface, const Shell& shell);

// Membrane strain and stress of a shell triangle (rest element e: make_shell_element of its frames;
// frame positions x [N][3]), as 3 x 3
// tensors in world axes: with F2 = [x1 - x0, x2 - x0] Dm^{-1} (3 x 2, rest in-plane coordinates
// along the rest axes A = [e1 e2], 3 x 2) and E2 = (F2^T F2 - I)/2, the plane-stress StVK law of
// the shell (mechanics/shell.hpp): S2 = lambda* tr(E2) I + 2 mu E2, lambda* = Y nu / (1 - nu^2),
// mu = Y / (2 (1 + nu)); E = A E2 A^T, S = A S2 A^T, sigma = F2 S2 F2^T / J2 with the area ratio
// J2 = sqrt(det F2^T F2) (the thickness change of plane stress is not modelled), and
// psi = mu tr(E2^2) + lambda*/2 tr(E2)^2 per rest volume.
StressMeasures shell_membrane_measures(const ShellElementRest& e, const Shell& shell, const double* x);

// The measure fields of `samples` (sample_fields) averaged to the frames, [N][components] each:
// every frame, or where `frames` ([N]) is non-zero, the other frames' values zero. Each frame's
// weights and pair shares are frame_average.hpp's.
std::vector<Field> frame_averages(const Model& model, const std::vector<Field>& samples,
                                  const std::vector<unsigned char>* frames = nullptr);

// Per material, 1 where its law has fibres (FrameAverageView::fibred_material).
std::vector<unsigned char> fibred_materials(const Model& model);

// Marks in `frames` ([N]) the frames whose averages surface_fields reads for this surface: its
// skin's frames, or its vertices' own; none for a shell surface (its measures are the shell's).
void mark_surface_frames(const SurfaceSource& source, std::vector<unsigned char>& frames);

// Fields at the surface's vertices: displacement, velocity, then the measures of `frame_measures`
// (frame_averages) in its order, or the shell's membrane measures for a shell surface.
std::vector<Field> surface_fields(const Model& model, const State& state, const std::vector<double>& rotations,
                                  const SurfaceSource& source, const std::vector<Field>& frame_measures);

}  // namespace fascia
