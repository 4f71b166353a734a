// A 1 kHz-style control loop over the cablesense C ABI: one estimator tick per
// encoder sample of the shipped track demo, cycled for N ticks (no sleeping), with
// the per-tick time percentiles. Build (see capi/tests/cpp_loop.rs):
//   cargo build --release -p cablesense-capi
//   c++ -O2 -std=c++17 -I capi/include examples/c/loop.cpp
//       target/release/libcablesense_capi.a -lpthread -ldl -lm -o loop   (one line)
//   ./loop data/scenes/track_demo.toml data/measurements/track_demo.csv 2000
#include "cablesense.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

static std::string read_file(const char *path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) {
    std::fprintf(stderr, "cannot open %s\n", path);
    std::exit(2);
  }
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// CSV rows "t_s,c0,c1,..." after a header; rows that do not parse are skipped
// (the demo has three deliberately bad ones); an empty cell is a missing cable.
static std::vector<std::vector<double>> read_rows(const std::string &text, size_t cables) {
  std::vector<std::vector<double>> rows;
  std::stringstream in(text);
  std::string line;
  bool header = false;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    if (!header) {
      header = true;
      continue;
    }
    std::vector<std::string> cells;
    std::stringstream ls(line);
    std::string cell;
    while (std::getline(ls, cell, ',')) cells.push_back(cell);
    if (line.back() == ',') cells.push_back("");
    if (cells.size() != cables + 1) continue;
    std::vector<double> row;
    bool ok = true;
    for (size_t j = 1; j < cells.size(); ++j) {
      if (cells[j].empty()) {
        row.push_back(NAN);
        continue;
      }
      char *end = nullptr;
      double v = std::strtod(cells[j].c_str(), &end);
      if (end == cells[j].c_str() || *end != '\0' || !std::isfinite(v)) ok = false;
      row.push_back(v);
    }
    if (ok) rows.push_back(row);
  }
  return rows;
}

int main(int argc, char **argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s SCENE.toml ENCODER.csv [TICKS]\n", argv[0]);
    return 2;
  }
  const long ticks = argc > 3 ? std::atol(argv[3]) : 2000;
  const std::string scene = read_file(argv[1]);
  CsEstimator *est = nullptr;
  if (cs_estimator_new(scene.c_str(), &est) != CS_CODE_OK) {
    std::fprintf(stderr, "error: %s\n", cs_last_error());
    return 1;
  }
  const size_t c = cs_estimator_cable_count(est), p = cs_estimator_unknown_count(est);
  const auto rows = read_rows(read_file(argv[2]), c);
  if (rows.empty()) {
    std::fprintf(stderr, "error: no encoder rows in %s\n", argv[2]);
    return 1;
  }
  std::vector<double> values(p), cov(p * p), first(p);
  double tip[3];
  std::vector<double> times;
  times.reserve(static_cast<size_t>(ticks));
  long converged = 0, poor = 0;
  for (long k = 0; k < ticks; ++k) {
    const auto &row = rows[static_cast<size_t>(k) % rows.size()];
    CsEstimateInfo info;
    const auto t0 = std::chrono::steady_clock::now();
    CsCode code = cs_estimator_tick(est, row.data(), nullptr, c, &info);
    if (code == CS_CODE_OK) code = cs_estimator_values(est, values.data(), cov.data(), p);
    if (code == CS_CODE_OK) code = cs_estimator_tip_position(est, tip);
    const auto t1 = std::chrono::steady_clock::now();
    if (code != CS_CODE_OK) {
      std::fprintf(stderr, "tick %ld: error %d: %s\n", k, static_cast<int>(code), cs_last_error());
      return 1;
    }
    times.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
    converged += info.status == 0;
    poor += info.poor_fit;
    if (k == 0) first = values;
  }
  // a bad call must fail cleanly with a message
  if (cs_estimator_tick(est, nullptr, nullptr, c, nullptr) != CS_CODE_BAD_ARGUMENT) return 1;
  std::printf("bad call: %s\n", cs_last_error());
  cs_estimator_free(est);

  std::sort(times.begin(), times.end());
  auto pct = [&](double q) { return times[static_cast<size_t>(q * (times.size() - 1))]; };
  std::printf("ticks: %ld  rows: %zu  converged: %ld  poor fits: %ld\n", ticks, rows.size(),
              converged, poor);
  std::printf("first estimate:");
  for (double v : first) std::printf(" %.6f", v);
  std::printf("\ntip (m): %.6f %.6f %.6f\n", tip[0], tip[1], tip[2]);
  std::printf("tick time (us): p50 %.1f  p90 %.1f  p99 %.1f  max %.1f\n", pct(0.5), pct(0.9),
              pct(0.99), times.back());
  return 0;
}
