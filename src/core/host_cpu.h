/// @file host_cpu.h
/// @brief The machine's CPU time counters (Linux /proc/stat): how much of the CPUs' time the
/// hypervisor took for other guests ("steal") while a run was being timed. On a shared virtual
/// machine a slow run with much steal says the host was busy, not the code. And a thread's
/// share of the CPUs (its nice value).
#pragma once

#include <cstdint>
#include <optional>
#include <string>

namespace aoscan {

/// The all-CPU line of /proc/stat, in clock ticks since boot.
struct HostCpuTimes {
  std::uint64_t total = 0;  ///< user + nice + system + idle + iowait + irq + softirq + steal
  std::uint64_t steal = 0;  ///< time the hypervisor ran something else while this guest waited
};

/// Reads the first ("cpu") line of `path` (default the kernel's /proc/stat). Nothing when the
/// file is absent or that line is not there or malformed; a kernel too old to report steal
/// (fewer than 8 fields) reads as steal 0.
std::optional<HostCpuTimes> read_host_cpu_times(const std::string& path = "/proc/stat");

/// Steal between two readings in percent of all CPU time between them; nothing when a reading
/// is missing or no time passed (or the counters went backwards).
std::optional<double> steal_percent(const std::optional<HostCpuTimes>& before,
                                    const std::optional<HostCpuTimes>& after);

/// Lowers the calling thread's scheduling priority by `increment` nice levels below its own (at
/// most to 19), so that the work it does for a viewer (the live window, the service's stream)
/// yields the CPU to fusion, also when the whole process runs under nice. False when the kernel
/// refused (the thread then keeps its priority).
bool lower_thread_priority(int increment);

}  // namespace aoscan
