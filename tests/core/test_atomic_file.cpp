// Outputs replace only regular files, never one of the command's inputs, and never stop at a NUL in the name;
// temporaries of a killed writer are removed by the next write.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <functional>
#include <string>

#include "map_test_helpers.hpp"
#include "error_message.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/atomic_file.hpp"

namespace tsdf_mcl {
namespace {

using test::error_of;

namespace fs = std::filesystem;
using test::read_bytes;
using test::TempDir;
using test::write_bytes;

// A process id that no process has any more: a child that has exited and been reaped.
pid_t dead_pid() {
  const pid_t pid = ::fork();
  if (pid == 0) ::_exit(0);
  int status = 0;
  ::waitpid(pid, &status, 0);
  return pid;
}

TEST(AtomicFile, OnlyARegularFileIsReplaced) {
  TempDir dir;
  ASSERT_EQ(::mkfifo((dir / "fifo").c_str(), 0600), 0);
  fs::create_symlink("/dev/null", dir / "null");
  for (const char* name : {"fifo", "null"}) {
    const fs::path target = dir / name;
    const std::string what = error_of([&] { check_output_file(target, "map"); });
    EXPECT_NE(what.find("is not a regular file"), std::string::npos) << name << ": " << what;
    EXPECT_NE(error_of([&] { write_file_atomically(target, "bytes", "map"); }).find("is not a regular file"),
              std::string::npos)
        << name;
  }
  EXPECT_TRUE(fs::is_fifo(dir / "fifo"));
  EXPECT_TRUE(fs::is_symlink(dir / "null"));
  EXPECT_TRUE(fs::is_character_file("/dev/null"));
  fs::create_directory(dir / "folder");
  EXPECT_NE(error_of([&] { write_file_atomically(dir / "folder", "x", "map"); }).find("it is a folder"),
            std::string::npos);
  write_bytes(dir / "old.tsdf", "old");
  write_file_atomically(dir / "old.tsdf", "new", "map");
  EXPECT_EQ(read_bytes(dir / "old.tsdf"), "new");
}

TEST(AtomicFile, AnOutputIsNoneOfTheInputs) {
  TempDir dir;
  write_bytes(dir / "box.obj", "v 0 0 0\n");
  fs::create_symlink(dir / "box.obj", dir / "link.obj");
  const std::string what = error_of([&] { check_output_file(dir / "link.obj", "map", {dir / "box.obj"}); });
  EXPECT_NE(what.find("is one of the command's inputs"), std::string::npos) << what;
  EXPECT_NE(error_of([&] {
              check_output_file(dir / "box.obj", "map", {dir / "other.obj", dir / "box.obj"});
            }).find("is one of the command's inputs"),
            std::string::npos);
  check_output_file(dir / "map.tsdf", "map", {dir / "box.obj", dir / "missing.obj"});  // a new file: fine
  EXPECT_EQ(read_bytes(dir / "box.obj"), "v 0 0 0\n");
}

TEST(AtomicFile, ANameWithANulIsRefused) {
  TempDir dir;
  write_bytes(dir / "map.tsdf", "old");
  const fs::path cut = (dir / "map.tsdf").string() + std::string("\0.bak", 5);
  EXPECT_NE(error_of([&] { write_file_atomically(cut, "new", "map"); }).find("NUL"), std::string::npos);
  EXPECT_NE(error_of([&] { check_output_file(cut, "map"); }).find("NUL"), std::string::npos);
  EXPECT_EQ(read_bytes(dir / "map.tsdf"), "old");
}

TEST(AtomicFile, TemporariesOfAKilledWriterGoWithTheNextWrite) {
  TempDir dir;
  const std::string dead = std::to_string(dead_pid()), alive = std::to_string(::getpid());
  for (const std::string& name :
       {"map.tsdf.partial-" + dead + "-0", "map.tsdf.partial-" + dead + "-7", "map.tsdf.partial-" + alive + "-99",
        "other.tsdf.partial-" + dead + "-0", std::string("map.tsdf.partial-x-0")}) {
    write_bytes(dir / name, "stale");
  }
  write_file_atomically(dir / "map.tsdf", "new", "map");
  EXPECT_EQ(read_bytes(dir / "map.tsdf"), "new");
  EXPECT_FALSE(fs::exists(dir / ("map.tsdf.partial-" + dead + "-0")));
  EXPECT_FALSE(fs::exists(dir / ("map.tsdf.partial-" + dead + "-7")));
  EXPECT_TRUE(fs::exists(dir / ("map.tsdf.partial-" + alive + "-99"))) << "a running writer's";
  EXPECT_TRUE(fs::exists(dir / ("other.tsdf.partial-" + dead + "-0"))) << "another output's";
  EXPECT_TRUE(fs::exists(dir / "map.tsdf.partial-x-0")) << "not a temporary's name";
}

}  // namespace
}  // namespace tsdf_mcl
