// fascia collect DIR: one table of every run in a folder (a sweep's): its parameters, status and
// final observables, as DIR/results.csv and DIR/results.h5, with DIR/manifest.json listing the
// files read (docs/hpc.md). Run files are read only; the three results files are rewritten.
#include "commands.hpp"

#include "io/checkpoint.hpp"
#include "io/results_table.hpp"
#include "io/trajectory.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <memory>

namespace fascia::app {

namespace {

namespace fs = std::filesystem;

struct CollectOptions {
  std::string folder;
  bool json = false;
};

struct RunRow {
  std::string name, file, status;
  double task = std::numeric_limits<double>::quiet_NaN();
  double exit_code = std::numeric_limits<double>::quiet_NaN();
  double steps = 0, time = std::numeric_limits<double>::quiet_NaN();
  std::map<std::string, std::string> parameters;
  std::map<std::string, double> finals;
  std::string version;
};

std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

std::string number_text(double v) {
  if (std::isnan(v)) return "";
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

// Writes through a temporary file and a rename: a reader never sees half a table.
bool write_atomically(const fs::path& path, const std::string& text) {
  const fs::path tmp = path.string() + ".tmp";
  {
    std::ofstream out(tmp);
    out << text;
    if (!out) return false;
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  return !ec;
}

int collect(const CollectOptions& options) {
  const fs::path folder = options.folder;
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) {
    std::cerr << "fascia: error: " << options.folder << ": no such folder\n";
    return kNoInput;
  }
  std::vector<fs::path> files;
  for (const fs::directory_entry& e : fs::directory_iterator(folder, ec))
    if (e.path().extension() == ".h5" && e.path().filename() != "results.h5") files.push_back(e.path());
  std::sort(files.begin(), files.end());

  std::vector<RunRow> rows;
  std::vector<std::string> parameter_names, observable_names;
  auto remember = [](std::vector<std::string>& names, const std::string& n) {
    if (std::find(names.begin(), names.end(), n) == names.end()) names.push_back(n);
  };
  for (const fs::path& file : files) {
    RunRow row;
    row.name = file.stem().string();
    row.file = file.string();
    // The task's record, written by `fascia sweep --task` (absent for plain runs).
    const fs::path record_path = fs::path(file).replace_extension(".json");
    if (std::ifstream in(record_path); in) {
      try {
        const nlohmann::json record = nlohmann::json::parse(in);
        row.task = record.value("task", row.task);
        row.exit_code = record.value("exit_code", row.exit_code);
        row.status = record.value("status", std::string());
        const nlohmann::json parameters = record.value("parameters", nlohmann::json::object());
        for (const auto& [key, value] : parameters.items()) {
          row.parameters[key] = value.is_string() ? value.get<std::string>() : value.dump();
          remember(parameter_names, key);
        }
      } catch (const nlohmann::json::exception&) {
        std::cerr << "fascia: warning: " << record_path.string() << " is not a task record; ignored\n";
      }
    }
    try {
      const std::optional<Checkpoint> c = read_checkpoint(file.string());
      const TrajectoryReader reader(file.string());
      row.version = reader.creator_version();
      const std::vector<int> steps = reader.steps();
      const std::vector<double> times = reader.times();
      if (!steps.empty()) {
        row.steps = steps.back();
        row.time = times.back();
      }
      for (const std::string& o : reader.observable_names()) {
        const std::vector<double> values = reader.observable(o);
        if (values.empty()) continue;
        row.finals[o] = values.back();
        remember(observable_names, o);
      }
      // The file is the authority on whether the run completed; the record on why it stopped.
      if (c && c->finished) row.status = "finished";
      else if (row.status.empty() || row.status == "finished") row.status = c ? "stopped" : "incomplete";
    } catch (const TrajectoryError& e) {
      row.status = "unreadable";
      std::cerr << "fascia: warning: " << e.what() << "\n";
    }
    rows.push_back(row);
  }

  // The table: fixed columns, then the parameters, then the final observables.
  std::vector<TableColumn> columns;
  auto text_column = [&](const std::string& name, auto get) {
    TableColumn c{name, false, {}, {}};
    for (const RunRow& r : rows) c.texts.push_back(get(r));
    columns.push_back(c);
  };
  auto number_column = [&](const std::string& name, auto get) {
    TableColumn c{name, true, {}, {}};
    for (const RunRow& r : rows) c.numbers.push_back(get(r));
    columns.push_back(c);
  };
  text_column("name", [](const RunRow& r) { return r.name; });
  number_column("task", [](const RunRow& r) { return r.task; });
  text_column("status", [](const RunRow& r) { return r.status; });
  number_column("exit_code", [](const RunRow& r) { return r.exit_code; });
  number_column("steps", [](const RunRow& r) { return r.steps; });
  number_column("time", [](const RunRow& r) { return r.time; });
  for (const std::string& p : parameter_names)
    text_column(p, [&p](const RunRow& r) {
      const auto it = r.parameters.find(p);
      return it == r.parameters.end() ? std::string() : it->second;
    });
  for (const std::string& o : observable_names)
    number_column(o, [&o](const RunRow& r) {
      const auto it = r.finals.find(o);
      return it == r.finals.end() ? std::numeric_limits<double>::quiet_NaN() : it->second;
    });

  std::string csv;
  for (std::size_t k = 0; k < columns.size(); ++k) csv += (k ? "," : "") + csv_field(columns[k].name);
  csv += "\n";
  for (std::size_t r = 0; r < rows.size(); ++r) {
    for (std::size_t k = 0; k < columns.size(); ++k)
      csv += (k ? "," : "") + csv_field(columns[k].numeric ? number_text(columns[k].numbers[r]) : columns[k].texts[r]);
    csv += "\n";
  }
  nlohmann::json manifest;
  manifest["folder"] = options.folder;
  manifest["tables"] = {"results.csv", "results.h5"};
  manifest["columns"] = nlohmann::json::array();
  for (const TableColumn& c : columns) manifest["columns"].push_back(c.name);
  manifest["runs"] = nlohmann::json::array();
  std::map<std::string, int> counts;
  for (const RunRow& r : rows) {
    ++counts[r.status];
    manifest["runs"].push_back({{"name", r.name}, {"file", r.file}, {"status", r.status}, {"version", r.version}});
  }
  manifest["counts"] = counts;
  try {
    const fs::path h5 = folder / "results.h5", tmp = folder / "results.h5.tmp";
    write_results_table(tmp.string(), columns);
    fs::rename(tmp, h5);
  } catch (const std::exception& e) {
    std::cerr << "fascia: error: " << e.what() << "\n";
    return kIoError;
  }
  if (!write_atomically(folder / "results.csv", csv) || !write_atomically(folder / "manifest.json", manifest.dump(2) + "\n")) {
    std::cerr << "fascia: error: cannot write the results into " << options.folder << "\n";
    return kIoError;
  }
  if (options.json) {
    std::cout << manifest.dump() << "\n";
  } else {
    std::cout << rows.size() << " runs";
    for (const auto& [status, n] : counts) std::cout << ", " << n << " " << status;
    std::cout << " -> " << (folder / "results.csv").string() << ", results.h5, manifest.json\n";
  }
  return kOk;
}

}  // namespace

void register_collect(CLI::App& app, Action& action) {
  auto options = std::make_shared<CollectOptions>();
  CLI::App* cmd = app.add_subcommand("collect", "Gather the runs of a folder into one table (CSV, HDF5) with a manifest");
  cmd->add_option("folder", options->folder, "Folder of run files (a sweep's folder)")->required();
  cmd->add_flag("--json", options->json, "Print the manifest as JSON on stdout");
  cmd->callback([&action, options] { action = [options] { return collect(*options); }; });
}

}  // namespace fascia::app
