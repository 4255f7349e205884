/// @file ranks.cpp
/// @brief A single process, and MPI ranks when aoscan is built with MPI (AOSCAN_HAVE_MPI).
#include "pipeline/ranks.h"

#include <cstdlib>
#include <string>

#if AOSCAN_HAVE_MPI
#include <mpi.h>
#endif

#include "core/status.h"

namespace aoscan {
namespace {

class SingleProcess : public Ranks {
 public:
  int rank() const override { return 0; }
  int size() const override { return 1; }
  int local_size() const override { return 1; }
  void barrier() override {}
  long long sum(long long value) override { return value; }
  [[noreturn]] void abort(int exit_code) override { std::exit(exit_code); }
};

/// An integer from the environment, or `fallback`.
int env_int(const char* name, int fallback) {
  const char* v = std::getenv(name);
  if (!v || !*v) return fallback;
  char* end = nullptr;
  const long n = std::strtol(v, &end, 10);
  return *end == '\0' && n > 0 && n < 1 << 20 ? static_cast<int>(n) : fallback;
}

/// Ranks of the job as the launcher announces them (Open MPI, MPICH/Hydra, PMIx): 0 when this
/// process was not started by one.
int launcher_size() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE"}) {
    const int n = env_int(name, 0);
    if (n > 0) return n;
  }
  return 0;
}

#if AOSCAN_HAVE_MPI
class MpiRanks : public Ranks {
 public:
  MpiRanks() {
    int provided = 0;
    MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
    local_size_ = env_int("OMPI_COMM_WORLD_LOCAL_SIZE", env_int("MPI_LOCALNRANKS", size_));
  }
  ~MpiRanks() override { MPI_Finalize(); }
  int rank() const override { return rank_; }
  int size() const override { return size_; }
  int local_size() const override { return local_size_; }
  void barrier() override { MPI_Barrier(MPI_COMM_WORLD); }
  long long sum(long long value) override {
    long long total = 0;
    MPI_Allreduce(&value, &total, 1, MPI_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
    return total;
  }
  [[noreturn]] void abort(int exit_code) override {
    MPI_Abort(MPI_COMM_WORLD, exit_code);
    std::exit(exit_code);
  }

 private:
  int rank_ = 0;
  int size_ = 1;
  int local_size_ = 1;
};
#endif

}  // namespace

std::unique_ptr<Ranks> single_process() { return std::make_unique<SingleProcess>(); }

bool built_with_mpi() { return AOSCAN_HAVE_MPI != 0; }

std::unique_ptr<Ranks> open_ranks() {
  const int announced = launcher_size();
#if AOSCAN_HAVE_MPI
  if (announced > 0) return std::make_unique<MpiRanks>();
#else
  if (announced > 1)
    throw usage_error("started as one of " + std::to_string(announced) +
                      " MPI ranks, but this aoscan was built without MPI (install OpenMPI: "
                      "tools/install-deps.sh, and build again)");
#endif
  return single_process();
}

}  // namespace aoscan
