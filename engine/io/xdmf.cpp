#include "io/xdmf.hpp"

#include <cstdio>
#include <fstream>
#include <sstream>

namespace fascia {

namespace {

// <DataItem> selecting row k of a [T][n][c] dataset as an [n][c] array.
void hyperslab(std::ostringstream& out, const std::string& source, int k, std::size_t t, std::size_t n, int c,
               const char* indent) {
  out << indent << "<DataItem ItemType=\"HyperSlab\" Dimensions=\"1 " << n << " " << c << "\" Type=\"HyperSlab\">\n"
      << indent << "  <DataItem Dimensions=\"3 3\" Format=\"XML\">" << k << " 0 0 1 1 1 1 " << n << " " << c
      << "</DataItem>\n"
      << indent << "  <DataItem Dimensions=\"" << t << " " << n << " " << c
      << "\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << source << "</DataItem>\n"
      << indent << "</DataItem>\n";
}

void point_cloud(std::ostringstream& out, const std::string& name, const std::string& h5, int k, std::size_t t,
                 std::size_t n) {
  out << "        <Grid Name=\"" << name << "\" GridType=\"Uniform\">\n"
      << "          <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << n << "\" NodesPerElement=\"1\">\n"
      << "            <DataItem Dimensions=\"" << n << "\" NumberType=\"Int\" Precision=\"4\" Format=\"HDF\">" << h5
      << ":/connectivity/" << name << "</DataItem>\n          </Topology>\n"
      << "          <Geometry GeometryType=\"XYZ\">\n";
  hyperslab(out, h5 + ":/particles/" + name + "/position/value", k, t, n, 3, "            ");
  out << "          </Geometry>\n        </Grid>\n";
}

}  // namespace

std::string xdmf_text(const std::string& h5_name, const TrajectoryLayout& layout, const std::vector<double>& times,
                      std::size_t rows) {
  std::ostringstream out;
  out.precision(17);
  const std::size_t t = rows ? rows : times.size();
  out << "<?xml version=\"1.0\" ?>\n<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n<Xdmf Version=\"3.0\">\n  <Domain>\n"
      << "    <Grid Name=\"fascia\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  for (std::size_t k = 0; k < times.size(); ++k) {
    out << "      <Grid Name=\"step " << k << "\" GridType=\"Collection\" CollectionType=\"Spatial\">\n"
        << "        <Time Value=\"" << times[k] << "\"/>\n";
    for (const SurfaceLayout& s : layout.surfaces) {
      const std::size_t faces = s.faces.size() / static_cast<std::size_t>(s.nodes_per_face);
      const std::size_t v = s.vertex_frames.size();
      out << "        <Grid Name=\"" << s.name << "\" GridType=\"Uniform\">\n"
          << "          <Topology TopologyType=\"" << (s.nodes_per_face == 3 ? "Triangle" : "Quadrilateral")
          << "\" NumberOfElements=\"" << faces << "\">\n"
          << "            <DataItem Dimensions=\"" << faces << " " << s.nodes_per_face
          << "\" NumberType=\"Int\" Precision=\"4\" Format=\"HDF\">" << h5_name << ":/connectivity/" << s.name
          << "</DataItem>\n          </Topology>\n          <Geometry GeometryType=\"XYZ\">\n";
      hyperslab(out, h5_name + ":/particles/" + s.name + "/position/value", static_cast<int>(k), t, v, 3,
                "            ");
      out << "          </Geometry>\n        </Grid>\n";
    }
    point_cloud(out, "frames", h5_name, static_cast<int>(k), t, static_cast<std::size_t>(layout.frames));
    if (layout.samples > 0)
      point_cloud(out, "samples", h5_name, static_cast<int>(k), t, static_cast<std::size_t>(layout.samples));
    out << "      </Grid>\n";
  }
  out << "    </Grid>\n  </Domain>\n</Xdmf>\n";
  return out.str();
}

void write_xdmf(const std::string& xmf_path, const std::string& h5_name, const TrajectoryLayout& layout,
                const std::vector<double>& times, std::size_t rows) {
  const std::string tmp = xmf_path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    out << xdmf_text(h5_name, layout, times, rows);
    out.flush();
    if (!out) throw TrajectoryError(tmp + ": cannot write the XDMF sidecar");
  }
  if (std::rename(tmp.c_str(), xmf_path.c_str()) != 0)
    throw TrajectoryError(xmf_path + ": cannot rename the XDMF sidecar into place");
}

std::string xdmf_path_for(const std::string& h5_path) {
  const std::size_t slash = h5_path.find_last_of('/');
  const std::size_t dot = h5_path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return h5_path + ".xmf";
  return h5_path.substr(0, dot) + ".xmf";
}

}  // namespace fascia
