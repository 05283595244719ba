#include "tsdf_mcl/core/input_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl {
namespace fs = std::filesystem;

std::uint64_t input_file_size(const fs::path& file, const std::string& what, std::uint64_t max_bytes) {
  const std::string name = what + " " + file.string();
  std::error_code ec;
  const fs::file_status status = fs::status(file, ec);
  if (status.type() == fs::file_type::not_found) throw Error(name + " does not exist");
  if (ec) throw Error("cannot open " + name + ": " + ec.message());
  if (status.type() == fs::file_type::directory) throw Error(name + " is a directory, not a file");
  if (status.type() != fs::file_type::regular) {
    throw Error(name + " is not a regular file (a FIFO, socket or device cannot be read as " + what + ")");
  }
  const std::uint64_t size = fs::file_size(file, ec);
  if (ec) throw Error("cannot read " + name + ": " + ec.message());
  if (size > max_bytes) {
    throw Error(name + ": " + std::to_string(size) + " bytes, more than the limit of " + std::to_string(max_bytes) +
                " for a " + what + " file");
  }
  return size;
}

std::string read_input_file(const fs::path& file, const std::string& what, std::uint64_t max_bytes) {
  const std::uint64_t size = input_file_size(file, what, max_bytes);
  const std::string name = what + " " + file.string();
  // O_NONBLOCK: should the file have been swapped for a FIFO since the check, open() must not wait for a writer.
  const int fd = ::open(file.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) throw Error("cannot open " + name + ": " + std::strerror(errno));
  std::string data(static_cast<std::size_t>(size), '\0');
  std::size_t done = 0;
  while (done < data.size()) {
    const ssize_t n = ::read(fd, data.data() + done, data.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    done += static_cast<std::size_t>(n);
  }
  ::close(fd);
  if (done != data.size()) throw Error("cannot read " + name + " (it changed while being read)");
  return data;
}

}  // namespace tsdf_mcl
