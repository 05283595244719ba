// rosbag2 recordings as datasets (Dataset::open_bag) and the writer (BagWriter): one run written in every storage
// (MCAP with chunks uncompressed, zstd, lz4, without summary; SQLite3; folders, split in several files) reads back as
// the run, as the ROS 1 bag of it does; compressed recordings; and every bad input one sentence.
#include <gtest/gtest.h>
#include <sqlite3.h>
#include <zstd.h>

#include <cmath>
#include <string>
#include <vector>

#include "error_message.hpp"
#include "map_test_helpers.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/io/bag_writer.hpp"
#include "tsdf_mcl/io/dataset.hpp"
#include "tsdf_mcl/io/ros2_messages.hpp"

namespace tsdf_mcl {
namespace {

namespace fs = std::filesystem;
using test::TempDir;

// The error's text, which must be one line.
std::string error_of(const std::function<void()>& f) {
  const std::string e = test::error_of(f);
  EXPECT_EQ(e.find('\n'), std::string::npos) << e;
  return e;
}

Pose xyz_yaw(double x, double y, double z, double yaw) {
  return msg::pose_of({x, y, z}, Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ())));
}

// A short run: 12 scans at 10 Hz from t = 1 s, a mounted sensor, odometry drifting from the truth, IMU at 20 Hz.
constexpr std::size_t kScans = 12;
double scan_time(std::size_t k) { return 1.0 + 0.1 * static_cast<double>(k); }
const Pose kBaseTSensor = xyz_yaw(0.1, 0.0, 0.4, 0.3);
Pose odom_T_sensor(std::size_t k) { return xyz_yaw(0.2 * k, 0.05 * k, 0.0, 0.02 * k); }
Pose world_T_sensor(std::size_t k) {
  return xyz_yaw(5.0, -1.0, 0.0, 0.5) * odom_T_sensor(k) * xyz_yaw(0.01 * k, 0, 0, 0);
}
PointCloud cloud(std::size_t k) {
  PointCloud c;
  for (int i = 0; i < 200; ++i) {
    c.points.emplace_back(static_cast<float>(k) + 0.25f * i, std::sin(0.1f * i), 0.5f);
    c.intensity.push_back(static_cast<float>(i % 7));
  }
  return c;
}

void write_run(const fs::path& path, BagWriterOptions options = {}) {
  BagWriter bag(path, std::move(options));
  bag.set_base_T_sensor(kBaseTSensor);
  for (std::size_t k = 0; k < kScans; ++k) {
    bag.add_imu(scan_time(k), {0.1, 0.0, 9.81}, {0.0, 0.0, 0.2});
    bag.add_scan(scan_time(k), cloud(k), nullptr, world_T_sensor(k), odom_T_sensor(k));
    bag.add_imu(scan_time(k) + 0.05, {0.1, 0.0, 9.81}, {0.0, 0.0, 0.2});
  }
  bag.close();
}

BagOptions run_options() {
  BagOptions o;
  o.points_topic = "/points";
  o.ground_truth_topic = "/ground_truth";
  o.imu_topic = "/imu";
  return o;
}

void expect_near(const Pose& a, const Pose& b, double tolerance, const std::string& what) {
  EXPECT_LT((a.matrix() - b.matrix()).cwiseAbs().maxCoeff(), tolerance) << what;
}

// The dataset is the run: every scan, its time, points, odometry and truth in the sensor frame, the IMU samples.
void expect_the_run(const fs::path& bag, std::size_t scans = kScans) {
  const Dataset ds = Dataset::open_bag(bag, run_options());
  ASSERT_EQ(ds.size(), scans) << bag << ": " << ds.summary();
  ASSERT_TRUE(ds.has_odometry() && ds.has_poses()) << ds.summary();
  for (std::size_t k = 0; k < scans; ++k) {
    EXPECT_NEAR(ds.time(k), scan_time(k), 1e-12) << bag << " " << k;  // a stamp's nanoseconds
    expect_near(ds.odometry(k), odom_T_sensor(k), 1e-9, bag.string() + " odometry");
    expect_near(ds.pose(k), world_T_sensor(k), 1e-9, bag.string() + " truth");
    const PointCloud c = ds.load_scan(k);
    EXPECT_EQ(c.points, cloud(k).points) << bag << " " << k;
    EXPECT_EQ(c.intensity, cloud(k).intensity) << bag << " " << k;
  }
  EXPECT_NE(ds.summary().find("odometry from tf 'odom' -> 'base_link'"), std::string::npos) << ds.summary();
  const std::vector<ImuSample> imu = ds.imu();
  ASSERT_GE(imu.size(), 2 * scans - 1);
  EXPECT_LT((imu[0].acceleration - Eigen::Vector3d(0.1, 0.0, 9.81)).norm(), 1e-12);
}

TEST(Rosbag2Dataset, EveryStorageReadsBackAsTheRun) {
  TempDir dir;
  BagWriterOptions zstd, lz4, no_summary, sqlite_folder, split;
  zstd.compression = "zstd";
  zstd.mcap_chunk_bytes = 8192;  // several chunks
  lz4.compression = "lz4";
  no_summary.mcap_summary = false;
  sqlite_folder.storage = "sqlite3";
  split.storage = "sqlite3";
  split.split_bytes = 20000;  // about 4 scans per file
  const std::vector<std::pair<std::string, BagWriterOptions>> bags = {{"run.mcap", {}},
                                                                      {"zstd.mcap", zstd},
                                                                      {"lz4.mcap", lz4},
                                                                      {"no_summary.mcap", no_summary},
                                                                      {"run.db3", {}},
                                                                      {"folder", {}},
                                                                      {"sqlite_folder", sqlite_folder},
                                                                      {"split", split}};
  for (const auto& [name, options] : bags) {
    write_run(dir / name, options);
    EXPECT_FALSE(fs::exists(dir / (name + ".partial"))) << name;
    expect_the_run(dir / name);
  }
  // The folders as `ros2 bag record -o NAME` writes them; the split one in order, every file listed.
  EXPECT_TRUE(fs::exists(dir / "folder/folder_0.mcap") && fs::exists(dir / "folder/metadata.yaml"));
  EXPECT_TRUE(fs::exists(dir / "sqlite_folder/sqlite_folder_0.db3"));
  const std::string metadata = test::read_bytes(dir / "split/metadata.yaml");
  EXPECT_NE(metadata.find("storage_identifier: sqlite3"), std::string::npos) << metadata;
  EXPECT_NE(metadata.find("relative_file_paths:\n    - split_0.db3\n    - split_1.db3\n    - split_2.db3\n"),
            std::string::npos)
      << metadata;
  EXPECT_NE(metadata.find("name: /points\n        type: sensor_msgs/msg/PointCloud2\n"), std::string::npos);
  EXPECT_NE(metadata.find("message_count: 12\n"), std::string::npos) << metadata;
  // Chunks compressed: smaller than uncompressed.
  EXPECT_LT(fs::file_size(dir / "zstd.mcap"), fs::file_size(dir / "run.mcap"));
  EXPECT_LT(fs::file_size(dir / "lz4.mcap"), fs::file_size(dir / "run.mcap"));
  // A split folder without its metadata.yaml (a recording cut off): the files in split order.
  fs::remove(dir / "split/metadata.yaml");
  expect_the_run(dir / "split");
  EXPECT_NE(Dataset::open_bag(dir / "split", run_options()).summary().find("no metadata.yaml: read the folder's"),
            std::string::npos);
  // The metadata.yaml itself names the folder.
  expect_the_run(dir / "folder/metadata.yaml");
}

TEST(Rosbag2Dataset, Ros1AndRos2BagsOfARunAreOneDataset) {
  if (!Dataset::ros1_bag_support()) GTEST_SKIP() << "built without ROS 1 bag support";
  TempDir dir;
  write_run(dir / "run.bag");
  write_run(dir / "run.mcap");
  const Dataset ros1 = Dataset::open_bag(dir / "run.bag", run_options());
  const Dataset ros2 = Dataset::open_bag(dir / "run.mcap", run_options());
  ASSERT_EQ(ros1.size(), ros2.size());
  for (std::size_t k = 0; k < ros1.size(); ++k) {
    EXPECT_EQ(ros1.time(k), ros2.time(k));
    EXPECT_EQ(ros1.odometry(k).matrix(), ros2.odometry(k).matrix());
    EXPECT_EQ(ros1.pose(k).matrix(), ros2.pose(k).matrix());
    EXPECT_EQ(ros1.load_scan(k).points, ros2.load_scan(k).points);
  }
}

// Each message blob of an SQLite3 bag compressed as rosbag2 --compression-mode message does.
void compress_messages(const fs::path& db3) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(db3.c_str(), &db), SQLITE_OK);
  sqlite3_stmt* select = nullptr;
  sqlite3_stmt* update = nullptr;
  sqlite3_prepare_v2(db, "SELECT id, data FROM messages", -1, &select, nullptr);
  sqlite3_prepare_v2(db, "UPDATE messages SET data = ? WHERE id = ?", -1, &update, nullptr);
  while (sqlite3_step(select) == SQLITE_ROW) {
    const auto* data = static_cast<const char*>(sqlite3_column_blob(select, 1));
    const std::size_t size = static_cast<std::size_t>(sqlite3_column_bytes(select, 1));
    std::string out(ZSTD_compressBound(size), '\0');
    out.resize(ZSTD_compress(out.data(), out.size(), data, size, 3));
    sqlite3_bind_blob(update, 1, out.data(), static_cast<int>(out.size()), SQLITE_TRANSIENT);
    sqlite3_bind_int64(update, 2, sqlite3_column_int64(select, 0));
    EXPECT_EQ(sqlite3_step(update), SQLITE_DONE);
    sqlite3_reset(update);
  }
  sqlite3_finalize(select);
  sqlite3_finalize(update);
  sqlite3_close(db);
}

std::string zstd_of(const std::string& bytes) {
  std::string out(ZSTD_compressBound(bytes.size()), '\0');
  out.resize(ZSTD_compress(out.data(), out.size(), bytes.data(), bytes.size(), 3));
  return out;
}

TEST(Rosbag2Dataset, CompressedRecordingsAreReadOrRefusedWithTheFix) {
  TempDir dir;
  BagWriterOptions sqlite;
  sqlite.storage = "sqlite3";
  // --compression-mode message: each message a zstd frame.
  write_run(dir / "messages", sqlite);
  compress_messages(dir / "messages/messages_0.db3");
  std::string metadata = test::read_bytes(dir / "messages/metadata.yaml");
  const auto mode = [&](const std::string& format, const std::string& m) {
    std::string out = metadata;
    out.replace(out.find("compression_format: \"\""), 22, "compression_format: " + format);
    out.replace(out.find("compression_mode: \"\""), 20, "compression_mode: " + m);
    return out;
  };
  test::write_bytes(dir / "messages/metadata.yaml", mode("zstd", "MESSAGE"));
  expect_the_run(dir / "messages");
  EXPECT_NE(Dataset::open_bag(dir / "messages", run_options()).summary().find("messages zstd-compressed"),
            std::string::npos);
  expect_the_run(dir / "messages/messages_0.db3");  // the same file alone: its messages recognized as zstd frames

  // --compression-mode file: refused with the command that decompresses it; read once it is decompressed beside.
  write_run(dir / "files", sqlite);
  metadata = test::read_bytes(dir / "files/metadata.yaml");
  std::string with_zstd = mode("zstd", "FILE");
  with_zstd.replace(with_zstd.find("- files_0.db3"), 13, "- files_0.db3.zstd");
  test::write_bytes(dir / "files/metadata.yaml", with_zstd);
  test::write_bytes(dir / "files/files_0.db3.zstd", zstd_of(test::read_bytes(dir / "files/files_0.db3")));
  fs::rename(dir / "files/files_0.db3", dir / "files_0.db3");
  const std::string refused = error_of([&] { Dataset::open_bag(dir / "files", run_options()); });
  EXPECT_NE(refused.find("its storage files are zstd-compressed whole (rosbag2 --compression-mode file): 'zstd -d " +
                         (dir / "files" / "*.zstd").string() + "' decompresses them beside"),
            std::string::npos)
      << refused;
  EXPECT_NE(error_of([&] {
              Dataset::open_bag(dir / "files/files_0.db3.zstd", run_options());
            }).find("files_0.db3.zstd is zstd-compressed whole (rosbag2 --compression-mode file): 'zstd -d "),
            std::string::npos);
  fs::rename(dir / "files_0.db3", dir / "files/files_0.db3");  // what zstd -d leaves
  expect_the_run(dir / "files");
  test::write_bytes(dir / "files/metadata.yaml", mode("lz4", "FILE"));
  EXPECT_NE(error_of([&] { Dataset::open_bag(dir / "files", run_options()); }).find("compressed with 'lz4'"),
            std::string::npos);
}

// The first chunk record of an MCAP file written here: after the magic and the header record.
std::size_t first_chunk(const std::string& mcap) {
  std::uint64_t header_length = 0;
  std::memcpy(&header_length, mcap.data() + 9, 8);
  const std::size_t at = 8 + 9 + header_length;
  EXPECT_EQ(mcap[at], 0x06);
  return at;
}

TEST(Rosbag2Dataset, CutOffMcapIsReadUpToTheCut) {
  TempDir dir;
  BagWriterOptions small_chunks;
  small_chunks.mcap_chunk_bytes = 4096;  // about a scan per chunk
  write_run(dir / "run.mcap", small_chunks);
  const std::string bytes = test::read_bytes(dir / "run.mcap");
  // A recording cut off by a crash: no summary, the last record incomplete.
  test::write_bytes(dir / "cut.mcap", bytes.substr(0, bytes.size() * 6 / 10));
  const Dataset cut = Dataset::open_bag(dir / "cut.mcap", run_options());
  EXPECT_GT(cut.size(), 3u);
  EXPECT_LT(cut.size(), kScans);
  EXPECT_NE(cut.summary().find("cut.mcap ends inside a record at byte "), std::string::npos) << cut.summary();
  EXPECT_NE(cut.summary().find("(a recording cut off?): read up to there"), std::string::npos);
  for (std::size_t k = 0; k < cut.size(); ++k) EXPECT_EQ(cut.load_scan(k).points, cloud(k).points);
  // Nothing but the magic and part of the header: an error.
  test::write_bytes(dir / "header.mcap", bytes.substr(0, 20));
  EXPECT_NE(error_of([&] {
              Dataset::open_bag(dir / "header.mcap", run_options());
            }).find("header.mcap: truncated or corrupt MCAP file (20 bytes: no header record after the magic)"),
            std::string::npos);
}

TEST(Rosbag2Dataset, CorruptMcapIsOneSentence) {
  TempDir dir;
  write_run(dir / "run.mcap");
  BagWriterOptions zstd;
  zstd.compression = "zstd";
  write_run(dir / "zstd.mcap", zstd);
  const std::string bytes = test::read_bytes(dir / "run.mcap");
  const std::size_t chunk = first_chunk(bytes);
  // Chunk content: start, end (16), uncompressed_size (8), crc (4), compression "" (4), records length (8), records.
  const std::size_t size_at = chunk + 9 + 16, records_at = chunk + 9 + 16 + 8 + 4 + 4 + 8;
  const auto corrupt = [&](const std::string& name, std::size_t at, char value, const std::string& base) {
    std::string b = base;
    b[at] = value;
    test::write_bytes(dir / name, b);
    return error_of([&] {
      const Dataset ds = Dataset::open_bag(dir / name, run_options());
      for (std::size_t k = 0; k < ds.size(); ++k) ds.load_scan(k);
    });
  };
  EXPECT_NE(corrupt("crc.mcap", records_at + 200, 'x', bytes)
                .find("crc.mcap: the chunk at byte " + std::to_string(chunk) + ": CRC mismatch"),
            std::string::npos);
  EXPECT_NE(corrupt("size.mcap", size_at, static_cast<char>(bytes[size_at] + 1), bytes).find("declared"),
            std::string::npos);
  // With the CRC left out (0: not checked), what the records themselves hold.
  std::string no_crc = bytes;
  std::memset(no_crc.data() + size_at + 8, 0, 4);
  EXPECT_NE(corrupt("opcode.mcap", records_at, 0, no_crc)
                .find("corrupt MCAP: a record of opcode 0 at byte 0 of the "
                      "chunk at byte " +
                      std::to_string(chunk)),
            std::string::npos);
  EXPECT_NE(corrupt("length.mcap", records_at + 8, 0x7F, no_crc).find("runs past the end of its chunk"),
            std::string::npos);
  const std::string z = test::read_bytes(dir / "zstd.mcap");
  const std::size_t zchunk = first_chunk(z);
  const std::string zstd_error = corrupt("zstd_data.mcap", zchunk + 9 + 16 + 8 + 4 + 4 + 4 + 8 + 20, 0x55, z);
  EXPECT_TRUE(zstd_error.find("corrupt zstd data") != std::string::npos ||
              zstd_error.find("CRC mismatch") != std::string::npos)
      << zstd_error;
  // The footer's CRC of the summary.
  EXPECT_NE(corrupt("summary.mcap", bytes.size() - 8 - 29 - 40, 'x', bytes).find("the summary's CRC"),
            std::string::npos);
}

TEST(Rosbag2Dataset, BadSqliteIsOneSentence) {
  TempDir dir;
  write_run(dir / "run.db3");
  // Locked: still being written by another process.
  sqlite3* writer = nullptr;
  ASSERT_EQ(sqlite3_open((dir / "run.db3").c_str(), &writer), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(writer, "BEGIN EXCLUSIVE", nullptr, nullptr, nullptr), SQLITE_OK);
  EXPECT_EQ(error_of([&] { Dataset::open_bag(dir / "run.db3", run_options()); }),
            (dir / "run.db3").string() + ": the SQLite3 database is locked by another process (still being recorded?)");
  sqlite3_exec(writer, "ROLLBACK", nullptr, nullptr, nullptr);
  sqlite3_close(writer);
  expect_the_run(dir / "run.db3");

  // Corrupt pages (the tables' b-trees overwritten).
  std::string bytes = test::read_bytes(dir / "run.db3");
  for (std::size_t i = 4096; i < 4096 * 4; ++i) bytes[i] = static_cast<char>(i * 7);
  test::write_bytes(dir / "corrupt.db3", bytes);
  const std::string corrupt = error_of([&] { Dataset::open_bag(dir / "corrupt.db3", run_options()); });
  EXPECT_NE(corrupt.find("corrupt.db3: "), std::string::npos) << corrupt;
  EXPECT_TRUE(corrupt.find("corrupt SQLite3 database") != std::string::npos ||
              corrupt.find("not a rosbag2 SQLite3 file") != std::string::npos)
      << corrupt;

  // Another SQLite database, and one whose messages "table" is a view.
  sqlite3* other = nullptr;
  ASSERT_EQ(sqlite3_open((dir / "other.db3").c_str(), &other), SQLITE_OK);
  sqlite3_exec(other, "CREATE TABLE topics(id INTEGER); CREATE VIEW messages AS SELECT 1", nullptr, nullptr, nullptr);
  sqlite3_close(other);
  EXPECT_NE(error_of([&] {
              Dataset::open_bag(dir / "other.db3", run_options());
            }).find("not a rosbag2 SQLite3 file (its 'messages' is a view, not a table)"),
            std::string::npos);
}

TEST(Rosbag2Dataset, TopicErrorsNameRos2Types) {
  TempDir dir;
  write_run(dir / "run.db3");
  const auto open = [&](const BagOptions& o) { return error_of([&] { Dataset::open_bag(dir / "run.db3", o); }); };
  BagOptions o = run_options();
  o.points_topic = "/velodyne_points";
  EXPECT_NE(open(o).find("has no topic /velodyne_points (the points topic); its sensor_msgs/msg/PointCloud2 "
                         "topics: /points"),
            std::string::npos)
      << open(o);
  o.points_topic = "odom";  // with or without the leading '/'
  EXPECT_NE(open(o).find("topic /odom (the points topic) carries nav_msgs/msg/Odometry, not "
                         "sensor_msgs/msg/PointCloud2"),
            std::string::npos)
      << open(o);
  o = run_options();
  o.ground_truth_topic = "/imu";
  EXPECT_NE(open(o).find("carries sensor_msgs/msg/Imu, not nav_msgs/msg/Odometry or geometry_msgs/msg/PoseStamped "
                         "or geometry_msgs/msg/PoseWithCovarianceStamped"),
            std::string::npos)
      << open(o);
  o = run_options();
  o.base_frame = "chassis";
  EXPECT_NE(open(o).find("no tf connects 'odom' and 'chassis'"), std::string::npos) << open(o);
}

TEST(Rosbag2Dataset, MessagesThatDoNotDecodeAreNamed) {
  TempDir dir;
  write_run(dir / "run.db3");
  // Scan 3's data sequence claims a gigabyte: its load is the error, naming the scan; nothing is allocated.
  msg::Header h = msg::stamp_of(scan_time(3));
  h.frame_id = "lidar";
  const EncodedPointCloud2 encoded = encode_pointcloud2(cloud(3));
  std::vector<std::uint8_t> message = ros2::encode_pointcloud2_message(h, encoded.layout, encoded.data);
  const std::size_t length_at = message.size() - encoded.data.size() - 1 - 4;
  message[length_at + 3] = 0x40;
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open((dir / "run.db3").c_str(), &db), SQLITE_OK);
  sqlite3_stmt* update = nullptr;
  sqlite3_prepare_v2(db,
                     "UPDATE messages SET data = ? WHERE id = (SELECT m.id FROM messages m JOIN topics t ON "
                     "m.topic_id = t.id WHERE t.name = '/points' ORDER BY m.timestamp LIMIT 1 OFFSET 3)",
                     -1, &update, nullptr);
  sqlite3_bind_blob(update, 1, message.data(), static_cast<int>(message.size()), SQLITE_TRANSIENT);
  EXPECT_EQ(sqlite3_step(update), SQLITE_DONE);
  sqlite3_finalize(update);
  sqlite3_close(db);
  const Dataset ds = Dataset::open_bag(dir / "run.db3", run_options());
  EXPECT_EQ(ds.load_scan(2).points, cloud(2).points);
  const std::string e = error_of([&] { ds.load_scan(3); });
  EXPECT_NE(e.find("run.db3:/points[3]: data holds 1073745024 elements of at least 1 bytes, more than the 3201 bytes "
                   "left in the message"),
            std::string::npos)
      << e;
}

TEST(Rosbag2Dataset, WriterRefusesWhatItCannotWrite) {
  TempDir dir;
  fs::create_directories(dir / "exists");
  EXPECT_NE(error_of([&] { BagWriter(dir / "exists"); }).find("already exists"), std::string::npos);
  BagWriterOptions o;
  o.storage = "rosbag";
  EXPECT_NE(error_of([&] { BagWriter(dir / "x", o); }).find("unknown rosbag2 storage 'rosbag'"), std::string::npos);
  {
    BagWriter unfinished(dir / "unfinished");
    unfinished.add_scan(1.0, cloud(0), nullptr, std::nullopt, odom_T_sensor(0));
  }
  EXPECT_FALSE(fs::exists(dir / "unfinished"));
  EXPECT_FALSE(fs::exists(dir / "unfinished.partial"));
  BagWriter late(dir / "late.mcap");
  EXPECT_NE(error_of([&] { late.add_scan(3e9, cloud(0), nullptr, std::nullopt, std::nullopt); }).find("2^31"),
            std::string::npos);
}

}  // namespace
}  // namespace tsdf_mcl
