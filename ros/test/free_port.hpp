#pragma once
// A port for a ROS master of a test's own.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

namespace tsdf_mcl::ros_node {

// A TCP port that nothing on the loopback address holds now, from the kernel (a bind to port 0). A port made of
// the process id once fell on an ephemeral port that a node of the test running beside this one listened on, and
// rosmaster served nothing ("Address already in use"). The process id's port remains the fallback.
inline int free_loopback_port() {
  int port = 20000 + static_cast<int>(getpid() % 20000);
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return port;
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  address.sin_port = 0;
  socklen_t length = sizeof(address);
  if (bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0 &&
      getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length) == 0) {
    port = ntohs(address.sin_port);
  }
  close(fd);
  return port;
}

}  // namespace tsdf_mcl::ros_node
