#pragma once
// Work that a third-party library may crash on (libhdf5 or rosbag_storage meeting a crafted file, before any check
// of ours sees the data) runs in a child process: its crash is one Error for the caller, not the caller's end.
#include <functional>
#include <string>

namespace tsdf_mcl {

// Runs `work` in a forked child and returns the bytes it returned. An exception it throws comes back as an Error
// with its what(); anything else that ends the child (a signal, a sanitizer's exit) is an Error worded by
// `crash_error` from how it ended ("signal 11", "exit status 1"). The child's stderr goes to /dev/null: a library's
// or a sanitizer's report is not the caller's one-line error. Throws Error if no child can be started.
std::string call_isolated(const std::function<std::string()>& work,
                          const std::function<std::string(const std::string& how)>& crash_error);

}  // namespace tsdf_mcl
