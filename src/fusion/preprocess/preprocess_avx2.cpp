/// @file preprocess_avx2.cpp
/// @brief The AVX2 build of the border-outlier row kernel (dispatched from preprocess.cpp when
/// the CPU has AVX2).
#include "fusion/preprocess/preprocess_kernels.h"

namespace aoscan::outlier_detail {

#if defined(AOSCAN_PREPROCESS_AVX2)
__attribute__((target("avx2"))) AOSCAN_NO_CONTRACT void filter_row_avx2(const float* up,
                                                                        const float* mid,
                                                                        const float* dn, int width,
                                                                        float t0, float per_m2,
                                                                        float* out) {
  filter_row_body(up, mid, dn, width, t0, per_m2, out);
}
#endif

}  // namespace aoscan::outlier_detail
