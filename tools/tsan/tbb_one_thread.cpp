/// @file tbb_one_thread.cpp
/// @brief Linked into aoscan and every test executable of a ThreadSanitizer build
/// (AOSCAN_TSAN) only: oneTBB runs every parallel_for on the thread that calls it.
///
/// Debian's libtbb is not built with -fsanitize=thread, so TSan cannot see the task hand-offs
/// of its scheduler: with worker threads, every parallel_for body that reads what its caller
/// wrote is reported as a race. With one thread allowed (the smallest max_allowed_parallelism of
/// all live global_control objects wins, so the session's thread budget cannot raise it) the
/// bodies run on the calling thread, and what TSan checks is aoscan's own threads: the stage
/// chain, its queues and frame pool, the session's command pump, the view stage and the window
/// thread, the camera capture threads and the live recorder.
#include <tbb/global_control.h>

namespace {

const tbb::global_control one_tbb_thread(tbb::global_control::max_allowed_parallelism, 1);

}  // namespace
