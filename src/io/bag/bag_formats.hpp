#pragma once
// The bag formats behind Dataset::open_bag and BagWriter (docs/bags.md): ROS 1 bags (src/io/rosbag/, built where
// rosbag_storage is found; src/io/no_rosbag.cpp stands in otherwise) and rosbag2 recordings, SQLite3 or MCAP
// (src/io/rosbag2/, always built). A bag is recognized by its content, not its name.
#include <filesystem>
#include <memory>

#include "bag_contents.hpp"
#include "bag_sink.hpp"
#include "tsdf_mcl/io/bag_writer.hpp"
#include "tsdf_mcl/io/dataset.hpp"

namespace tsdf_mcl::bag_io {

// What a file starts with.
enum class FileSignature { ros1_bag, sqlite3, mcap, zstd, rosbag2_metadata, other };
// Reads the file's first bytes; throws Error where it cannot be read (naming it), or holds more than a bag may.
FileSignature file_signature(const std::filesystem::path& file);

// A bag opened as a dataset: what was read from it, and where its scans come from.
struct OpenedBag {
  BagContents contents;
  std::shared_ptr<const Dataset::ScanSource> scans;
};

bool ros1_bag_support();
OpenedBag open_ros1_bag(const std::filesystem::path& file, const BagOptions& options);
// A rosbag2 folder (metadata.yaml and its storage files, or the storage files alone), a .db3 or an .mcap file.
OpenedBag open_rosbag2(const std::filesystem::path& path, const BagOptions& options);

std::unique_ptr<BagSink> make_ros1_sink(const std::filesystem::path& file, const BagWriterOptions& options);
std::unique_ptr<BagSink> make_rosbag2_sink(const std::filesystem::path& path, const BagWriterOptions& options);

}  // namespace tsdf_mcl::bag_io
