#include "tsdf_mcl/io/isolated_call.hpp"

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <exception>

#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl {
namespace {

void write_all(int fd, const std::string& bytes) {
  for (std::size_t done = 0; done < bytes.size();) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return;
    done += static_cast<std::size_t>(n);
  }
}

}  // namespace

std::string call_isolated(const std::function<std::string()>& work,
                          const std::function<std::string(const std::string& how)>& crash_error) {
  int fds[2];
  if (::pipe(fds) != 0) throw Error(std::string("cannot start a child process: ") + std::strerror(errno));
  std::fflush(nullptr);  // nothing buffered is written twice
  const pid_t child = ::fork();
  if (child < 0) {
    ::close(fds[0]);
    ::close(fds[1]);
    throw Error(std::string("cannot start a child process: ") + std::strerror(errno));
  }
  if (child == 0) {
    ::close(fds[0]);
    const int null_fd = ::open("/dev/null", O_WRONLY);
    if (null_fd >= 0) ::dup2(null_fd, STDERR_FILENO);
    // The answer: a byte 1 and the work's bytes, or a byte 0 and the error's message.
    std::string answer;
    try {
      answer = std::string(1, '\1') + work();
    } catch (const std::exception& e) {
      answer = std::string(1, '\0') + e.what();
    }
    write_all(fds[1], answer);
    ::close(fds[1]);
    ::_exit(0);
  }
  ::close(fds[1]);
  std::string answer;
  char buffer[65536];
  for (;;) {
    const ssize_t n = ::read(fds[0], buffer, sizeof(buffer));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    answer.append(buffer, static_cast<std::size_t>(n));
  }
  ::close(fds[0]);
  int status = 0;
  while (::waitpid(child, &status, 0) < 0 && errno == EINTR) {
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || answer.empty()) {
    const std::string how = WIFSIGNALED(status)
                                ? "signal " + std::to_string(WTERMSIG(status))
                                : "exit status " + std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1);
    throw Error(crash_error(how));
  }
  if (answer[0] == '\0') throw Error(answer.substr(1));
  return answer.substr(1);
}

}  // namespace tsdf_mcl
