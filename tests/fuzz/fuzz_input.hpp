// Shared by the libFuzzer targets: the readers take file names, so each input is written to a
// scratch file of the reader's extension; an outcome other than a value or the reader's documented
// refusal is a finding (std::abort, which libFuzzer reports with the input that caused it).
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>

namespace fascia::fuzz {

// A file of this process under the temporary directory, holding `data`.
inline std::string scratch_file(const std::uint8_t* data, std::size_t size, const std::string& extension) {
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("fascia_fuzz_" + std::to_string(::getpid()) + extension))
                               .string();
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return path;
}

[[noreturn]] inline void finding(const std::string& what) {
  std::fprintf(stderr, "fuzz finding: %s\n", what.c_str());
  std::abort();
}

}  // namespace fascia::fuzz
