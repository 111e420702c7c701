#include "io/xdmf.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

namespace fascia {

namespace {

std::string joined(const std::vector<std::size_t>& v) {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? " " : "") + std::to_string(v[i]);
  return s;
}

// A <DataItem> holding row k of the dataset `source` ("file.h5:/path") of shape [t][shape...],
// float64 or (single) float32.
void row_item(std::ostringstream& out, XdmfDialect dialect, const std::string& source, std::size_t k, std::size_t t,
              const std::vector<std::size_t>& shape, const char* indent, bool single) {
  const char* precision = single ? "4" : "8";
  std::vector<std::size_t> dims{t}, start{k}, ones{1}, count{1};
  for (std::size_t s : shape) {
    dims.push_back(s);
    start.push_back(0);
    ones.push_back(1);
    count.push_back(s);
  }
  if (dialect == XdmfDialect::xdmf3) {
    // Xdmf3 heavy-data description: path|start:stride:count:dataspace.
    out << indent << "<DataItem Dimensions=\"" << joined(count) << "\" NumberType=\"Float\" Precision=\"" << precision
        << "\" Format=\"HDF\">"
        << source << "|" << joined(start) << ":" << joined(ones) << ":" << joined(count) << ":" << joined(dims)
        << "</DataItem>\n";
    return;
  }
  out << indent << "<DataItem ItemType=\"HyperSlab\" Dimensions=\"" << joined(count) << "\" Type=\"HyperSlab\">\n"
      << indent << "  <DataItem Dimensions=\"3 " << dims.size() << "\" Format=\"XML\">" << joined(start) << " "
      << joined(ones) << " " << joined(count) << "</DataItem>\n"
      << indent << "  <DataItem Dimensions=\"" << joined(dims) << "\" NumberType=\"Float\" Precision=\"" << precision
      << "\" Format=\"HDF\">"
      << source << "</DataItem>\n"
      << indent << "</DataItem>\n";
}

// Geometry and the group's fields as node attributes.
void geometry_and_fields(std::ostringstream& out, XdmfDialect dialect, const std::string& h5, const std::string& group,
                         const TrajectoryLayout& layout, std::size_t k, std::size_t t, std::size_t n) {
  out << "          <Geometry GeometryType=\"XYZ\">\n";
  row_item(out, dialect, h5 + ":/particles/" + group + "/position/value", k, t, {n, 3}, "            ", false);
  out << "          </Geometry>\n";
  for (const FieldLayout& f : layout.fields) {
    if (f.group != group) continue;
    const char* type = f.components == 1 ? "Scalar" : f.components == 3 ? "Vector" : "Tensor";
    std::vector<std::size_t> shape{n};
    if (f.components == 3) shape.push_back(3);
    if (f.components == 9) shape.insert(shape.end(), {3, 3});
    out << "          <Attribute Name=\"" << f.name << "\" AttributeType=\"" << type << "\" Center=\"Node\">\n";
    row_item(out, dialect, h5 + ":/particles/" + group + "/" + f.name + "/value", k, t, shape, "            ", f.single);
    out << "          </Attribute>\n";
  }
}

void point_cloud(std::ostringstream& out, XdmfDialect dialect, const std::string& name, const std::string& h5,
                 const TrajectoryLayout& layout, std::size_t k, std::size_t t, std::size_t n) {
  out << "        <Grid Name=\"" << name << "\" GridType=\"Uniform\">\n"
      << "          <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << n << "\" NodesPerElement=\"1\">\n"
      << "            <DataItem Dimensions=\"" << n << "\" NumberType=\"Int\" Precision=\"4\" Format=\"HDF\">" << h5
      << ":/connectivity/" << name << "</DataItem>\n          </Topology>\n";
  geometry_and_fields(out, dialect, h5, name, layout, k, t, n);
  out << "        </Grid>\n";
}

}  // namespace

std::string xdmf_text(const std::string& h5_name, const TrajectoryLayout& layout, const std::vector<double>& times,
                      std::size_t rows, XdmfDialect dialect) {
  std::ostringstream out;
  out.precision(17);
  const std::size_t t = rows ? rows : times.size();
  out << "<?xml version=\"1.0\" ?>\n<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n<Xdmf Version=\""
      << (dialect == XdmfDialect::xdmf3 ? "3.0" : "2.0") << "\">\n  <Domain>\n"
      << "    <Grid Name=\"fascia\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  for (std::size_t k = 0; k < times.size(); ++k) {
    out << "      <Grid Name=\"step " << k << "\" GridType=\"Collection\" CollectionType=\"Spatial\">\n"
        << "        <Time Value=\"" << times[k] << "\"/>\n";
    for (const SurfaceLayout& s : layout.surfaces) {
      const std::size_t faces = s.faces.size() / static_cast<std::size_t>(s.nodes_per_face);
      out << "        <Grid Name=\"" << s.name << "\" GridType=\"Uniform\">\n"
          << "          <Topology TopologyType=\"" << (s.nodes_per_face == 3 ? "Triangle" : "Quadrilateral")
          << "\" NumberOfElements=\"" << faces << "\">\n"
          << "            <DataItem Dimensions=\"" << faces << " " << s.nodes_per_face
          << "\" NumberType=\"Int\" Precision=\"4\" Format=\"HDF\">" << h5_name << ":/connectivity/" << s.name
          << "</DataItem>\n          </Topology>\n";
      geometry_and_fields(out, dialect, h5_name, s.name, layout, k, t, s.vertex_frames.size());
      out << "        </Grid>\n";
    }
    point_cloud(out, dialect, "frames", h5_name, layout, k, t, static_cast<std::size_t>(layout.frames));
    if (layout.samples > 0)
      point_cloud(out, dialect, "samples", h5_name, layout, k, t, static_cast<std::size_t>(layout.samples));
    out << "      </Grid>\n";
  }
  out << "    </Grid>\n  </Domain>\n</Xdmf>\n";
  return out.str();
}

namespace {

// Written beside and renamed into place: the sidecar on disk is always whole. A failed write (a
// full disk) removes the temporary and leaves the previous sidecar; the message gives the reason.
void write_atomically(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp";
  {
    errno = 0;
    std::ofstream out(tmp, std::ios::trunc);
    out << text;
    out.close();
    if (!out) {
      const int error = errno;
      std::remove(tmp.c_str());
      throw TrajectoryError(tmp + ": cannot write the XDMF sidecar" +
                            (error ? std::string(": ") + std::strerror(error) : std::string()));
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const int error = errno;
    std::remove(tmp.c_str());
    throw TrajectoryError(path + ": cannot rename the XDMF sidecar into place: " + std::strerror(error));
  }
}

}  // namespace

void write_xdmf(const std::string& xmf_path, const std::string& h5_name, const TrajectoryLayout& layout,
                const std::vector<double>& times, std::size_t rows) {
  write_atomically(xmf_path, xdmf_text(h5_name, layout, times, rows, XdmfDialect::xdmf3));
  write_atomically(xmf_path + "2", xdmf_text(h5_name, layout, times, rows, XdmfDialect::xdmf2));
}

std::string xdmf_path_for(const std::string& h5_path) {
  const std::size_t slash = h5_path.find_last_of('/');
  const std::size_t dot = h5_path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return h5_path + ".xmf";
  return h5_path.substr(0, dot) + ".xmf";
}

}  // namespace fascia
