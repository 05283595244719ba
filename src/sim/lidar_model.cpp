#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/sim/simulator.hpp"

namespace tsdf_mcl::sim {

namespace {

std::string hz(double rate) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g Hz", rate);
  return text;
}

void check_rate(double rate_hz, const std::string& lidar) {
  if (!(rate_hz > 0.0) || rate_hz > 100.0)
    throw Error(lidar + ": scan rate " + hz(rate_hz) + " is outside (0, 100] Hz");
}

}  // namespace

LidarModel LidarModel::vlp16(double rate_hz) {
  if (!(rate_hz >= 5.0 && rate_hz <= 20.0)) {
    throw Error("vlp16 spins at 5-20 Hz, not " + hz(rate_hz));
  }
  LidarModel m;
  m.name = "vlp16";
  for (int b = 0; b < 16; ++b) m.elevations_deg.push_back(-15.0 + 2.0 * b);
  // The firing cycle is fixed, so the azimuth step grows with the spin rate: 0.2 deg at 10 Hz.
  m.columns = std::max(1, static_cast<int>(std::lround(18000.0 / rate_hz)));
  m.min_range = 0.5;
  m.max_range = 100.0;
  m.rate_hz = rate_hz;
  return m;
}

LidarModel LidarModel::os0_64(double rate_hz) {
  if (rate_hz != 10.0 && rate_hz != 20.0) throw Error("os0-64 spins at 10 or 20 Hz, not " + hz(rate_hz));
  LidarModel m;
  m.name = "os0-64";
  for (int b = 0; b < 64; ++b) m.elevations_deg.push_back(-45.0 + 90.0 * b / 63.0);
  m.columns = 1024;
  m.min_range = 0.3;
  m.max_range = 50.0;
  m.rate_hz = rate_hz;
  return m;
}

LidarModel LidarModel::from_beam_table(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) throw Error("cannot open beam table " + file.string());
  LidarModel m;
  m.name = file.stem().string();
  bool have_columns = false, have_min = false, have_max = false;
  std::string line;
  std::size_t line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const std::string where = file.string() + ":" + std::to_string(line_no) + ": ";
    if (const auto hash = line.find('#'); hash != std::string::npos) line.resize(hash);
    std::istringstream ss(line);
    std::string first;
    if (!(ss >> first)) continue;
    std::string rest;
    if (first == "name") {
      if (!(ss >> m.name)) throw Error(where + "'name' needs a value");
      if (ss >> rest) throw Error(where + "unexpected '" + rest + "'");
      continue;
    }
    double value = 0.0;
    char* end = nullptr;
    const bool is_key = first == "columns" || first == "min_range" || first == "max_range" || first == "rate";
    if (is_key) {
      std::string text;
      if (!(ss >> text)) throw Error(where + "'" + first + "' needs a value");
      value = std::strtod(text.c_str(), &end);
      if (*end != '\0' || !std::isfinite(value))
        throw Error(where + "'" + first + "' expects a number, got '" + text + "'");
    } else {
      value = std::strtod(first.c_str(), &end);
      if (*end != '\0' || !std::isfinite(value)) {
        throw Error(where + "expected an elevation in degrees or columns/min_range/max_range/rate/name, got '" + first +
                    "'");
      }
    }
    if (ss >> rest) throw Error(where + "unexpected '" + rest + "'");
    if (first == "columns") {
      if (value < 1 || value > 1e5 || value != std::floor(value))
        throw Error(where + "columns must be an integer in [1, 100000]");
      m.columns = static_cast<int>(value);
      have_columns = true;
    } else if (first == "min_range") {
      m.min_range = value;
      have_min = true;
    } else if (first == "max_range") {
      m.max_range = value;
      have_max = true;
    } else if (first == "rate") {
      m.rate_hz = value;
    } else {
      if (value < -90.0 || value > 90.0) throw Error(where + "elevation " + first + " deg is outside [-90, 90]");
      m.elevations_deg.push_back(value);
    }
  }
  if (!have_columns || !have_min || !have_max) {
    throw Error("beam table " + file.string() + " must give columns, min_range and max_range");
  }
  if (m.elevations_deg.empty()) throw Error("beam table " + file.string() + " lists no beam elevations");
  if (!(m.min_range >= 0.0) || !(m.max_range > m.min_range)) {
    throw Error("beam table " + file.string() + ": need 0 <= min_range < max_range");
  }
  check_rate(m.rate_hz, "beam table " + file.string());
  std::sort(m.elevations_deg.begin(), m.elevations_deg.end());
  return m;
}

LidarModel LidarModel::from_name(const std::string& name_or_file, double rate_hz) {
  if (name_or_file == "vlp16") return vlp16(rate_hz > 0.0 ? rate_hz : 20.0);
  if (name_or_file == "os0-64") return os0_64(rate_hz > 0.0 ? rate_hz : 10.0);
  if (!std::filesystem::is_regular_file(name_or_file)) {
    throw Error("unknown lidar '" + name_or_file + "': expected vlp16, os0-64 or a beam table file");
  }
  LidarModel m = from_beam_table(name_or_file);
  if (rate_hz > 0.0) {
    check_rate(rate_hz, m.name);
    m.rate_hz = rate_hz;
  }
  return m;
}

double LidarModel::azimuth_of(int column) const { return -2.0 * M_PI * column / columns; }

Eigen::Vector3f LidarModel::direction(int beam, int column) const {
  const double elevation = elevations_deg.at(static_cast<std::size_t>(beam)) * M_PI / 180.0;
  const double azimuth = azimuth_of(column);
  return Eigen::Vector3d(std::cos(elevation) * std::cos(azimuth), std::cos(elevation) * std::sin(azimuth),
                         std::sin(elevation))
      .cast<float>();
}

}  // namespace tsdf_mcl::sim
