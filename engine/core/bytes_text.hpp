// A byte count for messages: "1.5 GiB", "310 MiB", "9.77 KiB" (three significant digits, powers
// of 1024).
#pragma once

#include <cmath>
#include <cstdio>
#include <string>

namespace fascia {

inline std::string bytes_text(double bytes) {
  if (!std::isfinite(bytes)) return "more than can be counted";
  const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
  int u = 0;
  while (bytes >= 1024 && u < 6) {
    bytes /= 1024;
    ++u;
  }
  char text[64];
  std::snprintf(text, sizeof text, "%.3g %s", bytes, units[u]);
  return text;
}

}  // namespace fascia
