#pragma once
// The localizer's records as JSON (the report.json of tsdf-mcl localize; a ROS node's diagnostics can use the same
// records), and a writer that streams the per-scan entries to a file as they come, so that a long run's memory
// stays flat, and assembles the report atomically at the end.
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "tsdf_mcl/localizer/localizer.hpp"

namespace tsdf_mcl {

nlohmann::json pose_json(const Pose& world_T_sensor);  // x y z, quaternion, roll pitch yaw in degrees
nlohmann::json scan_json(const ScanRecord& record);
nlohmann::json initialization_json(const InitializationRecord& record);
nlohmann::json summary_json(const RunSummary& summary);

class ReportWriter {
 public:
  // Per-scan entries go to `entries_file` (a scratch file beside the report) as they are added.
  explicit ReportWriter(std::filesystem::path entries_file);
  void add(const nlohmann::json& scan_entry);
  // Writes `report` to `file` (atomically: a temporary file renamed over it) with the entries as its "scans"
  // array. Throws Error on a failed write (disk full).
  void write(const nlohmann::json& report, const std::filesystem::path& file);

 private:
  std::filesystem::path entries_file_;
  std::ofstream out_;
  std::size_t count_ = 0;
};

}  // namespace tsdf_mcl
