#pragma once
// Highway's target set for the SLAM's vectorised code, included before any Highway header: every
// attainable target (SSE4, AVX2, AVX-512 and the portable fallback), also when the build's own flags would
// make the static target the only one, so the run-time dispatch and its tests cover all vector widths.

#ifndef HWY_COMPILE_ALL_ATTAINABLE
#define HWY_COMPILE_ALL_ATTAINABLE
#endif
#ifndef HWY_WANT_AVX3_DL  // Highway 1.0.3 needs it when the build's flags already enable AVX3_DL
#define HWY_WANT_AVX3_DL
#endif
