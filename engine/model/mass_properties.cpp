#include "model/mass_properties.hpp"

#include <stdexcept>

namespace fascia {

MassProperties mass_properties(const SurfaceMesh& mesh, double density) {
  // Translate to the bounding-box centre first: the sums are then free of the cancellation a
  // far origin would cause.
  Vec3 lo, hi;
  surface_bounds(mesh, lo, hi);
  const Vec3 o = 0.5 * (lo + hi);
  double volume = 0;
  Vec3 first{0, 0, 0};
  Mat3 second = zero3();
  for (int t = 0; t < mesh.triangle_count(); ++t) {
    const int* v = &mesh.triangles[3 * t];
    const Vec3 a = load3(&mesh.vertices[3 * v[0]]) - o, b = load3(&mesh.vertices[3 * v[1]]) - o,
               c = load3(&mesh.vertices[3 * v[2]]) - o;
    const double V = dot(a, cross(b, c)) / 6;
    const Vec3 s = a + b + c;
    volume += V;
    first += (V / 4) * s;
    second += (V / 20) * (outer(a, a) + outer(b, b) + outer(c, c) + outer(s, s));
  }
  if (!(volume > 0)) throw std::invalid_argument("rigid body: the surface encloses no volume (open or inward oriented)");
  if (!(density > 0)) throw std::invalid_argument("rigid body: density must be > 0");
  MassProperties p;
  p.volume = volume;
  p.mass = density * volume;
  const Vec3 c = (1 / volume) * first;
  p.centre = o + c;
  // Second moment about the centre, then I = tr(C) I - C.
  const Mat3 C = density * (second - volume * outer(c, c));
  p.inertia = trace(C) * identity3() - C;
  return p;
}

}  // namespace fascia
