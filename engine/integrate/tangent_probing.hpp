// Recovering the step tangent H (6N x 6N, of the reduced potential of step_potential.hpp) from a
// few products H e (Curtis, Powell & Reid 1974; Coleman & More 1983): the columns of frames that
// no row couples to twice are probed together, one product per colour and per DOF component, and
// each entry of a product is returned to the one column of its colour that its row couples to.
//
// Frames couple where they share a sample (the elasticity, eq. 18) or a shell triangle; a rigid
// body's frame takes the couplings of every frame attached to it (the rigid mapping), which
// makes it a hub coupled to hundreds of frames. A hub is probed alone and its rows are taken
// from its columns by symmetry, so that its neighbours need not all have distinct colours.
//
// The host builds the colouring once per model; the per-entry rule below (FASCIA_HD) is what the
// device's scatter runs and what the host test checks against the assembled tangent.
#pragma once

#include "core/config.hpp"
#include "model/model.hpp"

#include <cstdint>
#include <vector>

namespace fascia {

// A frame coupled to more than this many times the median frame's number of coupled frames is
// probed alone (a hub): the colour count of the other frames then follows the tissues'
// neighbourhoods, not the bodies' attachments.
inline constexpr int kProbeHubFactor = 4;

struct TangentProbing {
  int frames = 0;
  int colours = 0;
  std::vector<int> colour;     // [N] probe colour of each frame; -1: not probed (mapped to a rigid body)
  std::vector<int> hub_frame;  // [colours] the frame a hub colour probes, -1 for the other colours
  std::vector<int> owner;      // [colours][N] the frame of colour c that frame r couples to, -1: none
                               // (and -1 in every hub frame's row: hub rows come from hub columns)
};

// The colouring of model's step tangent (frames mapped to rigid bodies are not unknowns); frames
// coupled to more than hub_degree frames are hubs (0: kProbeHubFactor times the median).
TangentProbing tangent_probing(const Model& model, int hub_degree = 0);

// The probe vector of colour c and component k (0..5) at DOF i: 1 on DOF k of the colour's
// frames, 0 elsewhere and on fixed DOFs.
FASCIA_HD double probe_entry(const int* colour, const std::uint8_t* fixed, int c, int k, int i) {
  return (i % 6 == k && colour[i / 6] == c && !fixed[i]) ? 1.0 : 0.0;
}

// Where entry i of the product H e(c, k) belongs in H (column-major, n rows): the column of its
// row's frame of colour c, or -1 (a fixed row, a hub's row of another colour, no coupled frame).
// A hub colour's product is the hub's column, stored as its row as well (mirror = true).
FASCIA_HD long long probe_column(const int* owner_c, int hub_frame_c, const std::uint8_t* fixed, int k, int i,
                                 bool& mirror) {
  mirror = false;
  if (fixed[i]) return -1;
  if (hub_frame_c >= 0) {
    mirror = true;
    return 6LL * hub_frame_c + k;
  }
  const int j = owner_c[i / 6];
  return j >= 0 ? 6LL * j + k : -1;
}

}  // namespace fascia
