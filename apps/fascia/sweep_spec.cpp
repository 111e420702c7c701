#include "sweep_spec.hpp"

#include "dsl/source_tree.hpp"
#include "dsl/units.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>

namespace fascia::app {

namespace {

namespace fs = std::filesystem;
using dsl::Diagnostics;
using dsl::SourceNode;

// A scalar or a flow list of scalars as `--set` value text.
std::string value_text(const SourceNode& node, Diagnostics& d) {
  if (node.is_scalar()) return node.text;
  if (node.is_sequence()) {
    std::string out = "[";
    for (std::size_t i = 0; i < node.items.size(); ++i) out += (i ? ", " : "") + value_text(node.items[i], d);
    return out + "]";
  }
  d.error(node.where, "expected a value (a number, a quantity such as '40 kPa', a word or a list), got " + node.describe());
  return "";
}

std::string si_text(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

// The values of one varied parameter: a list, or a range {from, to, count | step, scale}.
std::vector<std::string> values_of(const std::string& path, const SourceNode& node, Diagnostics& d) {
  std::vector<std::string> out;
  if (node.is_sequence()) {
    for (const SourceNode& item : node.items) out.push_back(value_text(item, d));
    if (out.empty()) d.error(node.where, path + ": the list of values is empty");
    return out;
  }
  if (!node.is_map()) {
    d.error(node.where, path + ": expected a list of values or a range {from, to, count}, got " + node.describe());
    return out;
  }
  for (const auto& [key, value] : node.fields)
    if (key != "from" && key != "to" && key != "count" && key != "step" && key != "scale")
      d.error(value.where, path + ": unknown range key '" + key + "' (expected from, to, count or step, scale)");
  const SourceNode *from = node.find("from"), *to = node.find("to"), *count = node.find("count"),
                   *step = node.find("step"), *scale = node.find("scale");
  if (!from || !to || (!count == !step)) {
    d.error(node.where, path + ": a range needs from, to and one of count or step");
    return out;
  }
  auto quantity = [&](const SourceNode* n, const char* what) -> std::optional<dsl::Quantity> {
    std::string error;
    std::optional<dsl::Quantity> q = n->is_scalar() ? dsl::parse_quantity(n->text, error) : std::nullopt;
    if (!q) d.error(n->where, path + ": " + what + " must be a number or a quantity such as '20 kPa'");
    return q;
  };
  const std::optional<dsl::Quantity> a = quantity(from, "from"), b = quantity(to, "to");
  if (!a || !b) return out;
  if (!a->bare && !b->bare && a->dimension != b->dimension) {
    d.error(to->where, path + ": from and to have different units");
    return out;
  }
  const bool log = scale && scale->text == "log";
  if (scale && scale->text != "log" && scale->text != "linear")
    d.error(scale->where, path + ": scale must be linear or log");
  if (log && (a->value <= 0 || b->value <= 0)) {
    d.error(node.where, path + ": a log range needs positive ends");
    return out;
  }
  long n = 0;
  double h = 0;  // step: linear in SI units, log in ln units
  if (count) {
    n = count->is_scalar() ? std::strtol(count->text.c_str(), nullptr, 10) : 0;
    if (n < 1 || n > 100000) d.error(count->where, path + ": count must be an integer from 1 to 100000");
  } else {
    const std::optional<dsl::Quantity> s = quantity(step, "step");
    if (!s) return out;
    const double span = log ? std::log(b->value / a->value) : b->value - a->value;
    h = log ? std::log(s->value) : s->value;
    if (!(h != 0) || span / h < -1e-9 || span / h > 100000) {
      d.error(step->where, path + ": step must lead from 'from' to 'to' in at most 100000 values");
      return out;
    }
    n = static_cast<long>(std::floor(span / h + 1e-9)) + 1;
  }
  for (long i = 0; i < n; ++i) {
    double v = 0;
    if (step) {
      v = log ? a->value * std::exp(static_cast<double>(i) * h) : a->value + static_cast<double>(i) * h;
    } else {
      const double t = n == 1 ? 0.0 : static_cast<double>(i) / static_cast<double>(n - 1);
      v = log ? a->value * std::pow(b->value / a->value, t) : a->value + t * (b->value - a->value);
      if (i == n - 1 && n > 1) v = b->value;  // the end exactly, not a rounded sum
    }
    out.push_back(si_text(v));
  }
  return out;
}

struct Axis {
  std::vector<std::string> names;
  std::vector<std::vector<std::string>> values;  // [value index][name index]
};

}  // namespace

Sweep read_sweep(const std::string& path) {
  Diagnostics d;
  std::ifstream in(path);
  if (!in) {
    d.error({path, 0, 0}, "cannot read the sweep file", dsl::ExitCode::missing_input);
    throw dsl::SceneError(d);
  }
  std::stringstream text;
  text << in.rdbuf();
  const SourceNode root = dsl::parse_yaml(text.str(), path, d);
  if (!d.empty()) throw dsl::SceneError(d);
  if (!root.is_map()) {
    d.error(root.where, "a sweep file is a map (scene, set, cross, zip, slurm, ...), got " + root.describe());
    throw dsl::SceneError(d);
  }
  Sweep sweep;
  sweep.file = path;
  for (const auto& [key, value] : root.fields)
    if (key != "scene" && key != "name" && key != "folder" && key != "set" && key != "cross" && key != "zip" &&
        key != "slurm")
      d.error(value.where, "unknown key '" + key + "' (expected scene, name, folder, set, cross, zip or slurm)");
  const SourceNode* scene = root.find("scene");
  if (!scene || !scene->is_scalar()) {
    d.error(root.where, "the sweep needs 'scene: FILE' (the base scene, relative to the sweep file)");
  } else {
    sweep.scene = (fs::path(path).parent_path() / scene->text).lexically_normal().string();
    if (!fs::exists(sweep.scene))
      d.error(scene->where, "base scene " + sweep.scene + " does not exist", dsl::ExitCode::missing_input);
  }
  const SourceNode* name = root.find("name");
  sweep.name = name && name->is_scalar() ? name->text : fs::path(path).stem().string();
  const SourceNode* folder = root.find("folder");
  sweep.folder = folder && folder->is_scalar() ? folder->text : sweep.name;

  std::vector<std::string> fixed;
  if (const SourceNode* set = root.find("set")) {
    if (!set->is_map()) d.error(set->where, "set: expected a map of scene paths to values");
    for (const auto& [key, value] : set->fields) fixed.push_back(key + "=" + value_text(value, d));
  }
  std::vector<Axis> axes;
  if (const SourceNode* cross = root.find("cross")) {
    if (!cross->is_map()) d.error(cross->where, "cross: expected a map of scene paths to value lists or ranges");
    for (const auto& [key, value] : cross->fields) {
      Axis axis;
      axis.names = {key};
      for (const std::string& v : values_of(key, value, d)) axis.values.push_back({v});
      axes.push_back(axis);
    }
  }
  if (const SourceNode* zip = root.find("zip")) {
    if (!zip->is_sequence()) d.error(zip->where, "zip: expected a list of maps (scene path -> values)");
    for (const SourceNode& group : zip->items) {
      if (!group.is_map() || group.fields.empty()) {
        d.error(group.where, "zip: each item is a map of scene paths to equally long value lists");
        continue;
      }
      Axis axis;
      std::vector<std::vector<std::string>> columns;
      for (const auto& [key, value] : group.fields) {
        axis.names.push_back(key);
        columns.push_back(values_of(key, value, d));
        if (columns.back().size() != columns.front().size())
          d.error(value.where, "zip: " + key + " has " + std::to_string(columns.back().size()) + " values, " +
                                   axis.names.front() + " " + std::to_string(columns.front().size()));
      }
      for (std::size_t i = 0; i < columns.front().size(); ++i) {
        std::vector<std::string> row;
        for (const auto& c : columns) row.push_back(i < c.size() ? c[i] : "");
        axis.values.push_back(row);
      }
      axes.push_back(axis);
    }
  }
  if (const SourceNode* slurm = root.find("slurm")) {
    if (!slurm->is_map()) d.error(slurm->where, "slurm: expected a map");
    for (const auto& [key, value] : slurm->fields) {
      const std::string v = value.is_scalar() ? value.text : "";
      if (key == "partition") sweep.slurm.partition = v;
      else if (key == "account") sweep.slurm.account = v;
      else if (key == "time") sweep.slurm.time = v;
      else if (key == "cpus_per_task" || key == "gpus_per_task") {
        char* end = nullptr;
        const long n = std::strtol(v.c_str(), &end, 10);
        if (v.empty() || *end || n < 0 || (key == "cpus_per_task" && n < 1))
          d.error(value.where, "slurm." + key + ": expected a whole number" + (key == "cpus_per_task" ? " >= 1" : " >= 0"));
        (key == "cpus_per_task" ? sweep.slurm.cpus_per_task : sweep.slurm.gpus_per_task) = static_cast<int>(n);
      } else if (key == "signal") {
        std::string error;
        const std::optional<dsl::Quantity> q = dsl::parse_quantity(v, error);
        if (!q || (!q->bare && q->dimension != dsl::dim::time) || q->value < 1)
          d.error(value.where, "slurm.signal: expected a time of at least 1 s (e.g. 2 min)");
        else
          sweep.slurm.signal_seconds = q->value;
      } else if (key == "extra") {
        if (!value.is_sequence()) d.error(value.where, "slurm.extra: expected a list of sbatch options");
        for (const SourceNode& item : value.items) sweep.slurm.extra.push_back(item.text);
      } else {
        d.error(value.where, "unknown slurm key '" + key +
                                 "' (expected partition, account, time, cpus_per_task, gpus_per_task, signal, extra)");
      }
    }
  }
  if (!d.empty()) throw dsl::SceneError(d);

  // The runs: the product of the axes, the first axis varying slowest.
  for (const Axis& a : axes) sweep.parameter_names.insert(sweep.parameter_names.end(), a.names.begin(), a.names.end());
  std::size_t total = 1;
  for (const Axis& a : axes) total *= a.values.size();
  const int width = std::max<int>(3, static_cast<int>(std::to_string(total > 0 ? total - 1 : 0).size()));
  for (std::size_t r = 0; r < total; ++r) {
    SweepRun run;
    run.task = static_cast<int>(r);
    std::string number = std::to_string(r);
    number.insert(0, static_cast<std::size_t>(width) - std::min(number.size(), static_cast<std::size_t>(width)), '0');
    run.name = sweep.name + "-" + number;
    run.output = (fs::path(sweep.folder) / (run.name + ".h5")).string();
    run.overrides = fixed;
    std::size_t rest = r, stride = total;
    for (const Axis& a : axes) {
      stride /= a.values.size();
      const std::size_t index = rest / stride;
      rest %= stride;
      for (std::size_t k = 0; k < a.names.size(); ++k) {
        run.parameters.push_back({a.names[k], a.values[index][k]});
        run.overrides.push_back(a.names[k] + "=" + a.values[index][k]);
      }
    }
    sweep.runs.push_back(run);
  }
  return sweep;
}

}  // namespace fascia::app
