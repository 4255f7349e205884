/// @file host_cpu.cpp
#include "core/host_cpu.h"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <fstream>
#include <sstream>

namespace aoscan {

std::optional<HostCpuTimes> read_host_cpu_times(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  if (!in || !std::getline(in, line)) return std::nullopt;
  std::istringstream fields(line);
  std::string label;
  if (!(fields >> label) || label != "cpu") return std::nullopt;
  // user nice system idle iowait irq softirq steal (guest and guest_nice, already counted in
  // user and nice, follow and are not added).
  constexpr int kFields = 8, kSteal = 7, kRequired = 4;
  HostCpuTimes t;
  int read = 0;
  for (; read < kFields; ++read) {
    std::uint64_t v = 0;
    if (!(fields >> v)) break;
    t.total += v;
    if (read == kSteal) t.steal = v;
  }
  if (read < kRequired) return std::nullopt;
  return t;
}

std::optional<double> steal_percent(const std::optional<HostCpuTimes>& before,
                                    const std::optional<HostCpuTimes>& after) {
  if (!before || !after || after->total <= before->total || after->steal < before->steal)
    return std::nullopt;
  return 100.0 * static_cast<double>(after->steal - before->steal) /
         static_cast<double>(after->total - before->total);
}

bool lower_thread_priority(int increment) {
  const id_t tid = static_cast<id_t>(syscall(SYS_gettid));
  errno = 0;
  const int own_nice = getpriority(PRIO_PROCESS, tid);
  if (errno != 0) return false;
  return setpriority(PRIO_PROCESS, tid, std::min(own_nice + increment, 19)) == 0;
}

}  // namespace aoscan
