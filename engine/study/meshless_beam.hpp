// The cantilever of the beam study (study/beam_study.hpp) discretised meshless from its box
// surface (discretise/meshless.hpp), with the clamp and tip probe the study needs.
//
// Clamp. Poisson-disk frames lie strictly inside, up to r_f from the boundary, so fixing "frames
// at x = 0" would fix nothing. A grid of frames is placed on the face x = 0 (extra_frames, spacing
// at most r_f, corners included) and fixed; Poisson frames within r_f / 2 of it are dropped.
// Meshless shape functions do not interpolate, so the clamp holds the face's frames, not exactly
// every material point of the face; the error is of the order of the discretisation error.
#pragma once

#include "discretise/meshless.hpp"
#include "discretise/probe.hpp"
#include "study/beam_study.hpp"

namespace fascia {

struct MeshlessBeam {
  Model model;             // clamp frames fixed
  Probe tip;               // centre of the free end (length, width / 2, height / 2)
  MeshlessStatistics statistics;
  int clamped_frames = 0;
};

// frame_spacing r_f (m); the sample spacing is r_f / cbrt(settings.samples_per_frame).
MeshlessBeam build_meshless_beam(const BeamSettings& settings, double frame_spacing);

// Cells per axis of the grid of spacing about r_f over the beam (the study's `resolution` of a
// meshless row): ceil(extent / r_f - 1e-9), at least 1.
void meshless_beam_resolution(const BeamSettings& settings, double frame_spacing, int& nx, int& ny, int& nz);

}  // namespace fascia
