// Outputs (issue 52): an output replaces only a regular file, never one of the command's own inputs, and the
// temporaries a killed build-map or export-cloud left are removed by the next run, as localize's are.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include "cli_test_support.hpp"
#include "office_cli_fixture.hpp"

namespace tsdf_mcl {
namespace {

namespace fs = std::filesystem;
using test::CliResult;
using test::expect_one_line_error;
using test::fixture;
using test::run_cli;
using test::TempDir;

std::string quoted(const fs::path& p) { return "'" + p.string() + "'"; }

// A small box mesh as binary STL.
fs::path write_box(const TempDir& dir) {
  const fs::path file = dir / "box.stl";
  test::write_binary_stl(test::box_mesh(Eigen::Vector3f(0, 0, 0), Eigen::Vector3f(1, 1, 1)), file);
  return file;
}

TEST(CliOutputs, OnlyRegularFilesAreReplaced) {
  TempDir dir;
  const fs::path box = write_box(dir);
  ASSERT_EQ(::mkfifo((dir / "fifo").c_str(), 0600), 0);
  fs::create_symlink("/dev/null", dir / "null");
  for (const char* name : {"fifo", "null"}) {
    expect_one_line_error(dir, "build-map --mesh " + quoted(box) + " -o " + quoted(dir / name),
                          "is not a regular file (a device, FIFO or socket)");
    expect_one_line_error(dir, "export-cloud --dataset " + fixture().dataset + " --count 2 -o " + quoted(dir / name),
                          "is not a regular file");
  }
  // A character device of its own where the test may make one (root): as /dev/null would be.
  if (::mknod((dir / "chardev").c_str(), S_IFCHR | 0600, makedev(1, 3)) == 0) {
    expect_one_line_error(dir, "build-map --mesh " + quoted(box) + " -o " + quoted(dir / "chardev"),
                          "is not a regular file");
    EXPECT_TRUE(fs::is_character_file(dir / "chardev"));
  }
  EXPECT_TRUE(fs::is_fifo(dir / "fifo"));
  EXPECT_TRUE(fs::is_symlink(dir / "null"));
  EXPECT_TRUE(fs::is_character_file("/dev/null"));
}

TEST(CliOutputs, AnOutputIsNeverOneOfTheCommandsInputs) {
  TempDir dir;
  const fs::path box = write_box(dir);
  const std::string mesh = test::read_bytes(box);
  expect_one_line_error(dir, "build-map --mesh " + quoted(box) + " -o " + quoted(box),
                        "is one of the command's inputs");
  fs::create_symlink(box, dir / "alias.stl");
  expect_one_line_error(dir, "build-map --mesh " + quoted(box) + " -o " + quoted(dir / "alias.stl"),
                        "is one of the command's inputs");
  EXPECT_EQ(test::read_bytes(box), mesh);
  const fs::path data = dir / "data";
  fs::copy(fixture().dataset, data, fs::copy_options::recursive);
  const std::string poses = test::read_bytes(data / "poses.txt");
  expect_one_line_error(dir, "export-cloud --dataset " + quoted(data) + " -o " + quoted(data / "poses.txt"),
                        "is one of the command's inputs");
  expect_one_line_error(dir, "build-map --dataset " + quoted(data) + " -o " + quoted(data / "times.txt"),
                        "is one of the command's inputs");
  EXPECT_EQ(test::read_bytes(data / "poses.txt"), poses);
  ASSERT_EQ(run_cli(dir, "build-map --mesh " + quoted(box) + " -o " + quoted(dir / "box.tsdf")).exit_code, 0);
  test::write_bytes(dir / "t.png", "0 0.5 0.5 0.5 0 0 0 1\n");  // a trajectory, oddly named
  expect_one_line_error(dir,
                        "render --map " + quoted(dir / "box.tsdf") + " --estimate " + quoted(dir / "t.png") + " -o " +
                            quoted(dir / "t.png"),
                        "is one of the command's inputs");
  EXPECT_EQ(test::read_bytes(dir / "t.png"), "0 0.5 0.5 0.5 0 0 0 1\n");
}

TEST(CliOutputs, TemporariesOfAKilledBuildAreRemovedByTheNextRun) {
  TempDir dir;
  const fs::path box = write_box(dir);
  // PIDs stop far below 2^31 - 1: no process has this one.
  const fs::path stale_map = dir / "box.tsdf.partial-2147483647-0", stale_cloud = dir / "c.pcd.partial-2147483647-3";
  const fs::path live = dir / ("box.tsdf.partial-" + std::to_string(::getpid()) + "-0");
  for (const fs::path& f : {stale_map, stale_cloud, live}) test::write_bytes(f, std::string(4096, 'x'));
  ASSERT_EQ(run_cli(dir, "build-map --mesh " + quoted(box) + " -o " + quoted(dir / "box.tsdf")).exit_code, 0);
  EXPECT_FALSE(fs::exists(stale_map));
  EXPECT_TRUE(fs::exists(live)) << "a running writer's temporary stays";
  EXPECT_TRUE(fs::exists(stale_cloud)) << "another output's waits for that output's next run";
  const CliResult r =
      run_cli(dir, "export-cloud --dataset " + fixture().dataset + " --count 2 -o " + quoted(dir / "c.pcd"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_FALSE(fs::exists(stale_cloud));
}

}  // namespace
}  // namespace tsdf_mcl
