// fascia render RUN.h5: pictures of a run without ParaView. A thin front end to
// tools/post/fascia_post.py --render (matplotlib, headless): the deformed surfaces coloured by a
// field, with a colour bar in its unit, the time and a camera framing the objects; one step as
// PNG or every N-th step as a GIF or MP4 movie (MP4 through ffmpeg).
//
// Exit codes: 0 drawn · 64 usage (a movie name with --step, a PNG with --every) · 65 bad data
// (unreadable file, no such field, step out of range) · 66 RUN.h5 missing · 69 Python or the
// script missing · 74 the picture could not be written.
#include "commands.hpp"
#include "number_checks.hpp"

#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

namespace fascia::app {

namespace {

namespace fs = std::filesystem;

struct RenderOptions {
  std::string file;
  std::string output;
  int step = 0;
  int every = 0;
  bool has_step = false;
  std::string field = "displacement";
};

std::string extension(const std::string& path) {
  std::string e = fs::path(path).extension().string();
  for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e;
}

int render(const RenderOptions& o) {
  if (!fs::exists(o.file)) {
    std::cerr << "fascia render: error: " << o.file << ": no such file\n";
    return kNoInput;
  }
  const bool movie_requested = o.every > 0;
  std::string output = o.output;
  if (output.empty()) output = fs::path(o.file).replace_extension(movie_requested ? ".mp4" : ".png").string();
  const std::string ext = extension(output);
  if (ext != ".png" && ext != ".gif" && ext != ".mp4") {
    std::cerr << "fascia render: error: " << output << ": expected a .png, .gif or .mp4 name\n";
    return kUsage;
  }
  if (ext == ".png" && movie_requested) {
    std::cerr << "fascia render: error: --every draws a movie: name it .gif or .mp4\n";
    return kUsage;
  }
  if (ext != ".png" && o.has_step) {
    std::cerr << "fascia render: error: --step draws one picture: name it .png\n";
    return kUsage;
  }
  const char* script_env = std::getenv("FASCIA_POST_SCRIPT");
  const std::string script = script_env ? script_env : FASCIA_POST_SCRIPT;
  const std::string python = fs::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
  if (!fs::exists(script)) {
    std::cerr << "fascia render: error: " << script << " not found (tools/post of the source tree; set FASCIA_POST_SCRIPT)\n";
    return kUnavailable;
  }
  std::vector<std::string> args = {python, script, o.file, "--render", output, "--field", o.field};
  if (o.has_step) args.insert(args.end(), {"--step", std::to_string(o.step)});
  if (movie_requested) args.insert(args.end(), {"--every", std::to_string(o.every)});
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  std::cout.flush();
  const pid_t pid = fork();
  if (pid < 0) {
    std::cerr << "fascia render: error: cannot start " << python << "\n";
    return kUnavailable;
  }
  if (pid == 0) {
    execvp(argv[0], argv.data());
    _exit(127);
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) == 127) {
    std::cerr << "fascia render: error: " << python << " failed to run " << script << "\n";
    return kUnavailable;
  }
  return WEXITSTATUS(status);
}

}  // namespace

void register_render(CLI::App& app, Action& action) {
  auto options = std::make_shared<RenderOptions>();
  CLI::App* cmd = app.add_subcommand(
      "render", "Draw a run's deformed surfaces coloured by a field: one step (PNG) or a movie (GIF, MP4)");
  cmd->add_option("file", options->file, "HDF5 trajectory written by fascia run")->required();
  cmd->add_option("-o,--output", options->output,
                  "Picture (.png) or movie (.gif, .mp4); default RUN.png, or RUN.mp4 with --every");
  CLI::Option* step = cmd->add_option("--step", options->step, "Step index to draw (default the last; negative from the end)");
  CLI::Option* every =
      cmd->add_option("--every", options->every, "A movie of every N-th written step")->check(kPositiveNumber);
  step->excludes(every);
  cmd->add_option("--field", options->field,
                  "Colouring field of the surfaces (default displacement; fascia info lists them): a scalar, "
                  "the norm of a vector, the von Mises value of a tensor");
  cmd->callback([&action, options, step] {
    options->has_step = step->count() > 0;
    action = [options] { return render(*options); };
  });
}

}  // namespace fascia::app
