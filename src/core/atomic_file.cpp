#include "tsdf_mcl/core/atomic_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>

#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl {
namespace fs = std::filesystem;
namespace {

// Beside the target (same file system, so rename is atomic), unique per process and call.
fs::path temporary_beside(const fs::path& file) {
  static std::atomic<unsigned> counter{0};
  return file.string() + ".partial-" + std::to_string(::getpid()) + "-" + std::to_string(counter++);
}

// Flushes a written file to disk, so that the rename cannot outlive its contents after a crash.
bool sync_file(const fs::path& file) {
  const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  const bool ok = ::fsync(fd) == 0;
  return ::close(fd) == 0 && ok;
}

void commit(const fs::path& temporary, const fs::path& file, const std::string& what) {
  std::error_code ec;
  if (!sync_file(temporary)) {
    fs::remove(temporary, ec);
    throw Error("cannot write " + what + " " + file.string() + " (disk full?)");
  }
  fs::rename(temporary, file, ec);
  if (ec) {
    std::error_code ignored;
    fs::remove(temporary, ignored);
    throw Error("cannot write " + what + " " + file.string() + ": " + ec.message());
  }
}

}  // namespace

void write_file_atomically(const fs::path& file, std::string_view bytes, const std::string& what) {
  write_file_atomically(
      file,
      [&](const fs::path& temporary) {
        const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (fd < 0) throw Error("cannot write " + what + " " + file.string() + ": " + std::strerror(errno));
        std::size_t done = 0;
        int error = 0;
        while (done < bytes.size()) {
          const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
          if (n < 0 && errno == EINTR) continue;
          if (n <= 0) {
            error = n < 0 ? errno : ENOSPC;
            break;
          }
          done += static_cast<std::size_t>(n);
        }
        if (::close(fd) != 0 && error == 0) error = errno;
        if (error != 0) throw Error("cannot write " + what + " " + file.string() + ": " + std::strerror(error));
      },
      what);
}

void write_file_atomically(const fs::path& file, const std::function<void(const fs::path&)>& write,
                           const std::string& what) {
  const fs::path temporary = temporary_beside(file);
  try {
    write(temporary);
  } catch (...) {
    std::error_code ignored;
    fs::remove(temporary, ignored);
    throw;
  }
  commit(temporary, file, what);
}

void check_output_file(const fs::path& file, const std::string& what) {
  if (file.empty()) throw Error(what + ": empty file name");
  const fs::path folder = file.has_parent_path() ? file.parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) {
    throw Error("cannot write " + what + " " + file.string() + ": folder " + folder.string() + " does not exist");
  }
  if (fs::is_directory(file, ec)) throw Error("cannot write " + what + " " + file.string() + ": it is a folder");
  const fs::path probe = temporary_beside(file);
  const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
  if (fd < 0) throw Error("cannot write " + what + " " + file.string() + ": " + std::strerror(errno));
  ::close(fd);
  fs::remove(probe, ec);
}

}  // namespace tsdf_mcl
