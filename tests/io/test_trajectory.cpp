// Round trip of the H5MD trajectory layout: what the writer puts in, the reader (and h5py, see
// tests/python) gets back, including after a refused (non-finite) step.
#include "io/trajectory.hpp"
#include "io/xdmf.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

using namespace fascia;
namespace fs = std::filesystem;

namespace {

TrajectoryLayout small_layout() {
  TrajectoryLayout layout;
  layout.frames = 3;
  layout.samples = 2;
  SurfaceLayout s;
  s.name = "slab";
  s.nodes_per_face = 3;
  s.faces = {0, 1, 2};
  s.vertex_frames = {0, 1, 2};
  layout.surfaces.push_back(s);
  layout.observables = {{"elastic_energy", false}, {"newton_iterations", true}};
  layout.fields = {{"samples", "cauchy_stress", 9, "Pa", true},  // stored as float32
                   {"slab", "displacement", 3, "m", false},
                   {"frames", "speed", 1, "m/s", false}};
  layout.capacity = 2;  // the third step doubles the preallocated rows
  return layout;
}

struct StepData {
  std::vector<double> x, q, p, surface;
  std::vector<double> stress, displacement, speed;  // the layout's fields
  std::vector<double> observables;
};

StepData data_for(int k) {
  StepData d;
  for (int i = 0; i < 9; ++i) d.x.push_back(k + 0.1 * i);
  for (int i = 0; i < 3; ++i) d.q.insert(d.q.end(), {1, 0, 0, 0.01 * k});
  for (int i = 0; i < 6; ++i) d.p.push_back(-k - 0.5 * i);
  d.surface = d.x;
  for (int i = 0; i < 18; ++i) d.stress.push_back(1e3 * k + i + 0.1);  // rounded in float32
  for (int i = 0; i < 9; ++i) d.displacement.push_back(-0.01 * k * i);
  d.speed = {1.0 * k, 2.0 * k, 3.0 * k};
  d.observables = {0.5 * k, static_cast<double>(k + 2)};
  return d;
}

TrajectoryStep step_of(const StepData& d, int k) {
  TrajectoryStep s;
  s.step = k;
  s.time = 0.01 * k;
  s.frame_positions = d.x.data();
  s.frame_orientations = d.q.data();
  s.sample_positions = d.p.data();
  s.surface_positions = {d.surface.data()};
  s.fields = {d.stress.data(), d.displacement.data(), d.speed.data()};
  s.observables = d.observables;
  return s;
}

}  // namespace

TEST_CASE("trajectories round-trip through the H5MD layout", "[io]") {
  const fs::path path = fs::temp_directory_path() / "fascia_test_roundtrip.h5";
  TrajectoryHeader header;
  header.creator_version = "9.9.9";
  header.author = "tester";
  header.scene = "materials: {}\n";
  header.scene_file = "scene.yaml";
  header.command_line = "fascia run scene.yaml";
  header.environment = "{\"host\": \"h\"}";
  std::vector<StepData> data;
  {
    TrajectoryWriter writer(path.string(), header, small_layout());
    for (int k = 0; k < 3; ++k) {
      data.push_back(data_for(k));
      writer.append(step_of(data.back(), k));
    }
    // A diverged state is refused and leaves the file as it was.
    StepData bad = data_for(3);
    bad.x[4] = std::nan("");
    CHECK_THROWS_AS(writer.append(step_of(bad, 3)), TrajectoryError);
    CHECK(writer.steps_written() == 3);
    CHECK(writer.rows_allocated() == 4);
    // So is a single field's value beyond float32's range (a double field's is written).
    bad = data_for(3);
    bad.stress[5] = 1e39;
    CHECK_THROWS_WITH(writer.append(step_of(bad, 3)), Catch::Contains("beyond float32's range of samples/cauchy_stress"));
    // Non-finite values in a single field and infinities in a double one are named as such.
    bad = data_for(3);
    bad.stress[2] = std::nan("");
    CHECK_THROWS_WITH(writer.append(step_of(bad, 3)), Catch::Contains("non-finite values of samples/cauchy_stress"));
    bad = data_for(3);
    bad.stress[7] = -std::numeric_limits<double>::infinity();
    CHECK_THROWS_WITH(writer.append(step_of(bad, 3)), Catch::Contains("non-finite values of samples/cauchy_stress"));
    bad = data_for(3);
    bad.p.back() = std::numeric_limits<double>::infinity();
    CHECK_THROWS_WITH(writer.append(step_of(bad, 3)), Catch::Contains("non-finite values of samples/position"));
    CHECK(writer.steps_written() == 3);
  }
  TrajectoryReader reader(path.string());
  CHECK(reader.step_count() == 3);
  CHECK(reader.h5md_version() == std::vector<int>{1, 1});
  CHECK(reader.creator_name() == "fascia");
  CHECK(reader.creator_version() == "9.9.9");
  CHECK(reader.steps() == std::vector<int>{0, 1, 2});
  const std::vector<double> times = reader.times();
  REQUIRE(times.size() == 3);
  CHECK(times[2] == Approx(0.02));
  for (int k = 0; k < 3; ++k) {
    CHECK(reader.particle_values("frames", "position", k) == data[k].x);
    CHECK(reader.particle_values("frames", "orientation", k) == data[k].q);
    CHECK(reader.particle_values("samples", "position", k) == data[k].p);
    CHECK(reader.particle_values("slab", "position", k) == data[k].surface);
    std::vector<double> stored;  // the float32 values the file holds, read back as doubles
    for (double v : data[k].stress) stored.push_back(static_cast<double>(static_cast<float>(v)));
    CHECK(reader.particle_values("samples", "cauchy_stress", k) == stored);
    CHECK(stored != data[k].stress);
    CHECK(reader.particle_values("slab", "displacement", k) == data[k].displacement);
    CHECK(reader.particle_values("frames", "speed", k) == data[k].speed);
  }
  CHECK(reader.particle_elements("samples") == std::vector<std::string>{"cauchy_stress", "position"});
  CHECK(reader.observable("elastic_energy") == std::vector<double>{0, 0.5, 1.0});
  CHECK(reader.observable("newton_iterations") == std::vector<double>{2, 3, 4});
  CHECK(reader.observable_is_integer("newton_iterations"));
  CHECK_FALSE(reader.observable_is_integer("elastic_energy"));
  int nodes = 0;
  CHECK(reader.connectivity("slab", nodes) == std::vector<int>{0, 1, 2});
  CHECK(nodes == 3);
  CHECK(reader.parameter("scene") == header.scene);
  CHECK(reader.parameter("command_line") == header.command_line);
  CHECK(reader.parameter("environment") == header.environment);
  const auto groups = reader.particle_groups();
  REQUIRE(groups.size() == 3);
  CHECK_THROWS_AS(reader.particle_values("frames", "position", 3), TrajectoryError);
  fs::remove(path);
}

TEST_CASE("the XDMF sidecars select each written step's row, in both dialects", "[io]") {
  for (XdmfDialect dialect : {XdmfDialect::xdmf3, XdmfDialect::xdmf2}) {
    const std::string text = xdmf_text("run.h5", small_layout(), {0.0, 0.01}, 0, dialect);
    CHECK_THAT(text, Catch::Contains("CollectionType=\"Temporal\""));
    CHECK_THAT(text, Catch::Contains("<Time Value=\"0.01\"/>"));
    CHECK_THAT(text, Catch::Contains("run.h5:/connectivity/slab"));
    CHECK_THAT(text, Catch::Contains("TopologyType=\"Triangle\""));
    CHECK_THAT(text, Catch::Contains("<Attribute Name=\"cauchy_stress\" AttributeType=\"Tensor\" Center=\"Node\">"));
    CHECK_THAT(text, Catch::Contains("<Attribute Name=\"displacement\" AttributeType=\"Vector\" Center=\"Node\">"));
    CHECK_THAT(text, Catch::Contains("<Attribute Name=\"speed\" AttributeType=\"Scalar\" Center=\"Node\">"));
    if (dialect == XdmfDialect::xdmf3) {
      // Row 1 of frames' [2][3][3] positions and of the samples' [2][2][3][3] stresses.
      CHECK_THAT(text, Catch::Contains("run.h5:/particles/frames/position/value|1 0 0:1 1 1:1 3 3:2 3 3</DataItem>"));
      CHECK_THAT(text, Catch::Contains("run.h5:/particles/samples/cauchy_stress/value|1 0 0 0:1 1 1 1:1 2 3 3:2 2 3 3<"));
      CHECK_THAT(text, Catch::Contains("run.h5:/particles/frames/speed/value|1 0:1 1:1 3:2 3<"));
      CHECK_THAT(text, !Catch::Contains("HyperSlab"));
      // The float32 field is declared so; the others are doubles.
      CHECK_THAT(text, Catch::Contains("Precision=\"4\" Format=\"HDF\">run.h5:/particles/samples/cauchy_stress/value|"));
      CHECK_THAT(text, Catch::Contains("Precision=\"8\" Format=\"HDF\">run.h5:/particles/frames/speed/value|"));
    } else {
      CHECK_THAT(text, Catch::Contains("1 0 0 1 1 1 1 3 3</DataItem>"));
      CHECK_THAT(text, Catch::Contains("1 0 0 0 1 1 1 1 1 2 3 3</DataItem>"));
      CHECK_THAT(text, Catch::Contains("Dimensions=\"2 3 3\""));
      CHECK_THAT(text, !Catch::Contains("|"));
      CHECK_THAT(text, Catch::Contains("Precision=\"4\" Format=\"HDF\">run.h5:/particles/samples/cauchy_stress/value<"));
      CHECK_THAT(text, Catch::Contains("Precision=\"8\" Format=\"HDF\">run.h5:/particles/frames/speed/value<"));
    }
  }
  CHECK(xdmf_path_for("out/run.h5") == "out/run.xmf");
  CHECK(xdmf_path_for("out.d/run") == "out.d/run.xmf");
}

TEST_CASE("writing to an impossible path is an I/O error", "[io]") {
  CHECK_THROWS_AS(TrajectoryWriter("/nonexistent/dir/run.h5", TrajectoryHeader{}, small_layout()), TrajectoryError);
}

TEST_CASE("a float32 field larger than half its file reads back", "[io]") {
  // The reader checks that a read fits in the file by the stored elements' size: a one-row file
  // whose float32 field is most of it holds fewer bytes than that field read as doubles. The
  // writer rounds and checks such a row in blocks of 32 Ki values, in parallel: values it must
  // refuse in the last block of the float field (180,000 values) and of the samples' positions
  // (60,000) are found there too.
  const fs::path path = fs::temp_directory_path() / "fascia_test_single_field.h5";
  TrajectoryLayout layout;
  layout.frames = 1;
  layout.samples = 20000;
  layout.fields = {{"samples", "cauchy_stress", 9, "Pa", true}};
  layout.capacity = 1;
  std::vector<double> x(3, 0.0), q{1, 0, 0, 0}, p(3 * 20000, 0.0), stress(9 * 20000);
  for (std::size_t i = 0; i < stress.size(); ++i) stress[i] = 0.5 * static_cast<double>(i);
  {
    TrajectoryWriter writer(path.string(), TrajectoryHeader{}, layout);
    TrajectoryStep s;
    s.frame_positions = x.data();
    s.frame_orientations = q.data();
    s.sample_positions = p.data();
    s.fields = {stress.data()};
    stress[stress.size() - 2] = 1e39;
    CHECK_THROWS_WITH(writer.append(s), Catch::Contains("beyond float32's range of samples/cauchy_stress"));
    stress[stress.size() - 2] = 0.5 * static_cast<double>(stress.size() - 2);
    p[p.size() - 1] = std::nan("");
    CHECK_THROWS_WITH(writer.append(s), Catch::Contains("non-finite values of samples/position"));
    p[p.size() - 1] = 0;
    CHECK(writer.steps_written() == 0);
    writer.append(s);
  }
  REQUIRE(fs::file_size(path) < 2 * sizeof(float) * stress.size());
  TrajectoryReader reader(path.string());
  CHECK(reader.particle_values("samples", "cauchy_stress", 0) == stress);
  fs::remove(path);
}
